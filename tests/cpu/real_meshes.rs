//! Real meshes from `$DIFFSIL_ASSETS` (the Stanford bunny and Keenan Crane's spot): they load,
//! render a plausible silhouette, and their 3D gradient matches central differences of the
//! exact-area oracle along random directions at 64² (`common::fd::check_3d_directions`).
//!
//! Ignored by default; run with
//! `DIFFSIL_ASSETS=/work/shared/assets cargo test --test cpu real_meshes -- --include-ignored`.

use std::path::PathBuf;
use std::time::Instant;

use crate::common::fd::{self, FdOptions};
use crate::common::scenes::Scene3d;
use diffsil::{Camera, Mesh, RenderSettings, Renderer, Vec3};

const TOL: f64 = 1e-3;

fn asset(name: &str) -> PathBuf {
    let dir = std::env::var_os("DIFFSIL_ASSETS").expect("set DIFFSIL_ASSETS to the folder holding the test meshes");
    PathBuf::from(dir).join(name)
}

/// The benchmark scene: the mesh normalised to radius 1, a perspective camera at (0, 0, 2.7)
/// looking at the origin, vertical fov 50°, 64².
fn scene(name: &'static str, file: &str) -> Scene3d {
    let started = Instant::now();
    let mesh: Mesh = diffsil::io::load_obj(asset(file)).unwrap_or_else(|e| panic!("{file}: {e}")).normalized(1.0);
    println!(
        "{name}: {} vertices, {} triangles, loaded in {:.2?}",
        mesh.positions().len(),
        mesh.triangles().len(),
        started.elapsed()
    );
    let camera = Camera::perspective(Vec3::new(0.0, 0.0, 2.7), Vec3::ZERO, 50f32.to_radians(), 64, 64);
    Scene3d { name, mesh, cameras: vec![camera] }
}

/// Renders the scene and checks the silhouette: coverage fraction within `coverage` and the
/// bounding box of covered pixels within `extent` of the frame (fractions of width and height).
fn check_render(scene: &Scene3d, coverage: (f64, f64), extent: (f64, f64)) {
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let frame = renderer.render(&scene.mesh, &scene.cameras).unwrap();
    let image = &frame.images()[0];
    assert!(image.data().iter().all(|v| v.is_finite() && (0.0..=1.0).contains(v)));
    let fraction = image.data().iter().map(|&v| v as f64).sum::<f64>() / image.data().len() as f64;
    let (w, h) = (image.width(), image.height());
    let rows: Vec<u32> = (0..h).filter(|&i| (0..w).any(|j| image.get(i, j) > 0.0)).collect();
    let cols: Vec<u32> = (0..w).filter(|&j| (0..h).any(|i| image.get(i, j) > 0.0)).collect();
    let (fw, fh) = (cols.len() as f64 / w as f64, rows.len() as f64 / h as f64);
    println!(
        "{}: covers {:.1}% of the pixels, {:.0}% × {:.0}% of the frame, {} candidate edges, {} culled",
        scene.name,
        100.0 * fraction,
        100.0 * fw,
        100.0 * fh,
        frame.stats()[0].candidate_edges,
        frame.stats()[0].culled_triangles
    );
    assert!((coverage.0..=coverage.1).contains(&fraction), "{}: coverage {fraction}", scene.name);
    assert!(fw >= extent.0 && fw <= extent.1 && fh >= extent.0 && fh <= extent.1, "{}: extent {fw} × {fh}", scene.name);
    assert_eq!(frame.stats()[0].culled_triangles, 0);
}

/// Step of the finite differences, pixels: 2⁻¹⁸ ≈ 3.8e-6. At 64² these meshes have sliver faces
/// whose free vertex lies within 2e-5 px of a contour edge, and a larger step straddles them (the
/// bunny's 2D gradient measures 5e-3 relative error at 2⁻¹⁴ px and 3e-7 at 2⁻¹⁸ px).
const H: f64 = 1.0 / 262144.0;

fn check_gradient(scene: &Scene3d) {
    let started = Instant::now();
    let check = fd::check_3d_directions(scene, FdOptions { h: H, seed: 21, ..FdOptions::default() });
    println!("3D {check}  ({:.2?})", started.elapsed());
    check.assert_within(TOL);
}

#[test]
#[ignore = "needs DIFFSIL_ASSETS"]
fn stanford_bunny() {
    let scene = scene("bunny", "stanford-bunny.obj");
    // The reference numbers: ~66% × 63% of the frame, ~25% of the pixels.
    check_render(&scene, (0.20, 0.30), (0.55, 0.75));
    check_gradient(&scene);
}

#[test]
#[ignore = "needs DIFFSIL_ASSETS"]
fn spot() {
    let scene = scene("spot", "spot.obj");
    check_render(&scene, (0.10, 0.45), (0.25, 0.95));
    check_gradient(&scene);
}
