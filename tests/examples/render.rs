//! The `render` example's command line and its forward + backward run, on small inputs: bad
//! arguments are clear errors (never panics), the camera options mean what `--help` says, and a
//! run reports consistent statistics, also with the camera inside the mesh.

#[allow(dead_code)]
#[path = "../../examples/render.rs"]
mod example;

use clap::error::ErrorKind;
use clap::{CommandFactory, Parser};
use diffsil::{Error, Image, Projection, RenderSettings, Renderer};
use example::*;

fn parse(args: &[&str]) -> Result<Options, clap::Error> {
    Options::try_parse_from(std::iter::once("render").chain(args.iter().copied()))
}

#[test]
fn bad_command_lines_are_errors_not_panics() {
    Options::command().debug_assert();
    assert_eq!(parse(&["-h"]).unwrap_err().kind(), ErrorKind::DisplayHelp);
    for (args, says) in [
        (&["--resolution"][..], "a value is required for '--resolution <N|WxH>'"),
        (&["--resolution", "12x"], "invalid value '12x' for '--resolution <N|WxH>'"),
        (&["--resolution", "-5"], "unexpected argument '-5'"),
        (&["--azimuth", "north"], "invalid value 'north' for '--azimuth <DEG>'"),
        (&["--elevation", "90"], "strictly between -90 and 90"),
        (&["--elevation", "-90"], "strictly between -90 and 90"),
        (&["--distance", "0"], "must be > 0"),
        (&["--distance", "inf"], "finite"),
        (&["--fov", "180"], "between 0 and 180"),
        (&["--fov", "NaN"], "finite"),
        (&["--view-height", "-1"], "must be > 0"),
        (&["--supersample", "x"], "invalid value 'x' for '--supersample <F>'"),
        (&["--repeat", "-1"], "unexpected argument '-1'"),
        (&["--backend", "tpu"], "[possible values: cpu, gpu, auto]"),
        (&["a.obj", "b.obj"], "unexpected argument 'b.obj'"),
        (&["a.obj", "--mesh", "b.obj"], "cannot be used with"),
        (&["--foo"], "unexpected argument '--foo'"),
        (&["--frobnicate", "1"], "unexpected argument '--frobnicate'"),
    ] {
        let error = parse(args).unwrap_err().to_string();
        assert!(error.contains(says), "{args:?}: {error}");
    }
}

#[test]
fn help_says_what_each_option_means_and_its_default() {
    let help = Options::command().render_long_help().to_string();
    for says in [
        "[default: 2.7]",
        "[default: 512; 1024 with --memory]",
        "[default: auto]",
        "[default: render.png]",
        "strictly between -90 and 90",
        "Stanford bunny",
    ] {
        assert!(help.contains(says), "--help lacks {says:?}:\n{help}");
    }
}

#[test]
fn options_mean_what_the_help_says() {
    let o = parse(&[]).unwrap();
    assert_eq!((o.size(), o.backend, o.supersample), ((512, 512), BackendName::Auto, 4));
    assert_eq!(parse(&["--memory"]).unwrap().size(), (1024, 1024), "--memory measures 1024²");
    let o = parse(&["--mesh", "m.obj", "--azimuth", "-30", "--elevation", "-45"]).unwrap();
    assert_eq!((o.mesh_path().unwrap().to_str(), o.azimuth, o.elevation), (Some("m.obj"), -30.0, -45.0));

    let o = parse(&["m.glb", "--resolution", "640x480", "--orthographic", "--view-height", "3", "--azimuth", "90"])
        .unwrap();
    assert_eq!(o.mesh_path().map(|p| p.as_path()), Some(std::path::Path::new("m.glb")));
    let camera = o.camera();
    camera.validate().unwrap();
    assert_eq!((camera.width, camera.height), (640, 480));
    assert_eq!(camera.projection, Projection::Orthographic { height: 3.0 });
    assert_eq!(camera.near, 0.0);
    // Azimuth 90°: the eye on +x, looking along −x.
    assert!((camera.eye - diffsil::Vec3::new(2.7, 0.0, 0.0)).length() < 1e-5, "{:?}", camera.eye);

    let o = parse(&["--elevation", "30", "--distance", "4", "--fov", "40"]).unwrap();
    let camera = o.camera();
    assert!((camera.eye.length() - 4.0).abs() < 1e-5 && camera.eye.y > 0.0, "{:?}", camera.eye);
    assert_eq!(camera.projection, Projection::Perspective { fov_y: 40f32.to_radians() });
}

#[test]
fn ranges_the_renderer_checks_give_its_errors() {
    let o = parse(&["--resolution", "0"]).unwrap();
    assert!(matches!(o.camera().validate(), Err(Error::InvalidResolution { .. })));
    let o = parse(&["--supersample", "0"]).unwrap();
    let settings = RenderSettings { supersample: o.supersample, ..RenderSettings::default() };
    assert!(matches!(Renderer::new(settings), Err(Error::InvalidSupersample(0))));
    let missing = parse(&["no/such/mesh.obj"]).unwrap();
    let error = load(&missing).unwrap_err().to_string();
    assert!(error.contains("no/such/mesh.obj"), "{error}");
    let unknown = parse(&["mesh.stl"]).unwrap();
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
    let o = parse(&["--resolution", "64", "--backend", "cpu"]).unwrap();
    let (mesh, _) = load(&o).unwrap();
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let run = run_once(&mut renderer, &mesh, &o.camera(), 2).unwrap();
    assert_eq!(run.culled, 0);
    assert!(run.candidates > 0 && (run.candidates as usize) < mesh.topology().edges().len());
    assert!(run.visible > 0 && run.visible <= run.segments, "{} of {}", run.visible, run.segments);
    assert!(run.loss > 0.0 && run.image.data().iter().all(|v| v.is_finite()));

    // The camera inside the mesh: triangles behind it are culled and counted, nothing is NaN.
    let inside = parse(&["--resolution", "64", "--distance", "0.3"]).unwrap();
    let run = run_once(&mut renderer, &mesh, &inside.camera(), 2).unwrap();
    assert!(run.culled > 0);
    assert!(run.loss.is_finite() && run.image.data().iter().all(|v| v.is_finite()));
}
