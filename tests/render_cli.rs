//! The `render` example's command line and its forward + backward run, on small inputs: bad
//! arguments are clear errors (never panics), the camera options mean what `--help` says, and a
//! run reports consistent statistics, also with the camera inside the mesh.

#[allow(dead_code)]
#[path = "../examples/render.rs"]
mod render;

use diffsil::{Error, Image, Projection, RenderSettings, Renderer};
use render::*;

fn parse(args: &[&str]) -> Result<Option<Options>, String> {
    parse_args(args.iter().map(|s| s.to_string()))
}

#[test]
fn bad_command_lines_are_errors_not_panics() {
    assert_eq!(parse(&["-h"]).unwrap(), None);
    for (args, says) in [
        (&["--resolution"][..], "needs a value"),
        (&["--resolution", "12x"], "--resolution 12x"),
        (&["--resolution", "-5"], "--resolution -5"),
        (&["--azimuth", "north"], "--azimuth north"),
        (&["--elevation", "90"], "strictly between -90 and 90"),
        (&["--distance", "0"], "must be > 0"),
        (&["--distance", "inf"], "finite"),
        (&["--fov", "180"], "between 0 and 180"),
        (&["--fov", "NaN"], "finite"),
        (&["--view-height", "-1"], "must be > 0"),
        (&["--supersample", "x"], "--supersample x"),
        (&["--repeat", "-1"], "--repeat -1"),
        (&["--backend", "tpu"], "cpu, gpu or auto"),
        (&["a.obj", "b.obj"], "only one mesh"),
        (&["--frobnicate", "1"], "unknown option"),
    ] {
        let error = parse(args).unwrap_err();
        assert!(error.contains(says), "{args:?}: {error}");
    }
}

#[test]
fn options_mean_what_the_help_says() {
    let o = parse(&[]).unwrap().unwrap();
    assert_eq!((o.size(), o.backend.as_str(), o.supersample), ((512, 512), "auto", 4));
    assert_eq!(parse(&["--memory"]).unwrap().unwrap().size(), (1024, 1024), "--memory measures 1024²");

    let o = parse(&["m.glb", "--resolution", "640x480", "--orthographic", "--view-height", "3", "--azimuth", "90"])
        .unwrap()
        .unwrap();
    assert_eq!(o.mesh.as_deref(), Some(std::path::Path::new("m.glb")));
    let camera = o.camera();
    camera.validate().unwrap();
    assert_eq!((camera.width, camera.height), (640, 480));
    assert_eq!(camera.projection, Projection::Orthographic { height: 3.0 });
    // Azimuth 90°: the eye on +x, looking along −x.
    assert!((camera.eye - diffsil::Vec3::new(2.7, 0.0, 0.0)).length() < 1e-5, "{:?}", camera.eye);

    let o = parse(&["--elevation", "30", "--distance", "4", "--fov", "40"]).unwrap().unwrap();
    let camera = o.camera();
    assert!((camera.eye.length() - 4.0).abs() < 1e-5 && camera.eye.y > 0.0, "{:?}", camera.eye);
    assert_eq!(camera.projection, Projection::Perspective { fov_y: 40f32.to_radians() });
}

#[test]
fn ranges_the_renderer_checks_give_its_errors() {
    let o = parse(&["--resolution", "0"]).unwrap().unwrap();
    assert!(matches!(o.camera().validate(), Err(Error::InvalidResolution { .. })));
    let o = parse(&["--supersample", "0"]).unwrap().unwrap();
    let settings = RenderSettings { supersample: o.supersample, ..RenderSettings::default() };
    assert!(matches!(Renderer::new(settings), Err(Error::InvalidSupersample(0))));
    let missing = parse(&["no/such/mesh.obj"]).unwrap().unwrap();
    let error = load(&missing).unwrap_err().to_string();
    assert!(error.contains("no/such/mesh.obj"), "{error}");
    let unknown = parse(&["mesh.stl"]).unwrap().unwrap();
    let error = load(&unknown).unwrap_err().to_string();
    assert!(error.contains(".obj, .gltf or .glb"), "{error}");
}

#[test]
fn shifted_moves_columns_right_and_fills_with_zero() {
    let image = Image::from_vec(3, 2, vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]).unwrap();
    assert_eq!(shifted(&image, 1).data(), &[0.0, 1.0, 2.0, 0.0, 4.0, 5.0]);
    assert_eq!(shifted(&image, 0), image);
    assert_eq!(shifted(&image, 7).data(), &[0.0; 6], "a shift past the width empties the image");
}

#[test]
fn a_run_reports_consistent_statistics() {
    let o = parse(&["--resolution", "64", "--backend", "cpu"]).unwrap().unwrap();
    let (mesh, _) = load(&o).unwrap();
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let run = run_once(&mut renderer, &mesh, &o.camera(), 2).unwrap();
    assert_eq!(run.culled, 0);
    assert!(run.candidates > 0 && (run.candidates as usize) < mesh.topology().edges().len());
    assert!(run.visible > 0 && run.visible <= run.segments, "{} of {}", run.visible, run.segments);
    assert!(run.loss > 0.0 && run.image.data().iter().all(|v| v.is_finite()));

    // The camera inside the mesh: triangles behind it are culled and counted, nothing is NaN.
    let inside = parse(&["--resolution", "64", "--distance", "0.3"]).unwrap().unwrap();
    let run = run_once(&mut renderer, &mesh, &inside.camera(), 2).unwrap();
    assert!(run.culled > 0);
    assert!(run.loss.is_finite() && run.image.data().iter().all(|v| v.is_finite()));
}
