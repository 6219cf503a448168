//! Scenes whose triangles cross a camera's near or far plane, and an `f64` reference for them:
//! the mesh clipped independently (`diffsil::reference::clip`), projected in `f64`, fed to the
//! exact-area oracle. Shared by the CPU and GPU test binaries.

#![allow(dead_code)]

use diffsil::reference::clip::clipped_image;
use diffsil::{shapes, Camera, Image, Mesh, RenderSettings, Renderer, Vec3};
use glam::DVec3;

/// A mesh and one camera whose near or far plane cuts it.
#[derive(Clone, Debug)]
pub struct ClipScene {
    /// Short name for reports.
    pub name: &'static str,
    /// The mesh.
    pub mesh: Mesh,
    /// The camera.
    pub camera: Camera,
}

/// A closed box `[−1, 1] × [−0.8, 1.1] × [−4, 1]` (12 triangles) with the camera inside it, near
/// 0.1 and far 2.5: the end wall behind the camera is wholly behind it, every side wall crosses
/// both planes, and the far end wall lies beyond the far plane, so the image is the side walls
/// with a hole whose outline is where they cross the far plane.
pub fn camera_in_box(size: u32) -> ClipScene {
    let (x0, x1, y0, y1, z0, z1) = (-1.0, 1.0, -0.8, 1.1, -4.0, 1.0);
    let positions = vec![
        Vec3::new(x0, y0, z0),
        Vec3::new(x1, y0, z0),
        Vec3::new(x1, y1, z0),
        Vec3::new(x0, y1, z0),
        Vec3::new(x0, y0, z1),
        Vec3::new(x1, y0, z1),
        Vec3::new(x1, y1, z1),
        Vec3::new(x0, y1, z1),
    ];
    let triangles = vec![
        [0, 2, 1],
        [0, 3, 2],
        [4, 5, 6],
        [4, 6, 7],
        [0, 1, 5],
        [0, 5, 4],
        [3, 7, 6],
        [3, 6, 2],
        [0, 4, 7],
        [0, 7, 3],
        [1, 2, 6],
        [1, 6, 5],
    ];
    let mesh = Mesh::new(positions, triangles).unwrap();
    let mut camera =
        Camera::perspective(Vec3::new(0.05, 0.03, 0.0), Vec3::new(0.12, 0.07, -1.0), 90f32.to_radians(), size, size);
    camera.near = 0.1;
    camera.far = 2.5;
    ClipScene { name: "camera_in_box", mesh, camera }
}

/// A unit icosphere (320 triangles) 2 units in front of the camera with near = 1.6: the near
/// plane cuts off the front cap beyond the contour, so the outline is where it cuts.
pub fn icosphere_close_up(size: u32) -> ClipScene {
    let mut camera =
        Camera::perspective(Vec3::new(0.07, 0.05, 2.0), Vec3::new(0.0, 0.01, 0.0), 70f32.to_radians(), size, size);
    camera.near = 1.6;
    ClipScene { name: "icosphere_close_up", mesh: shapes::icosphere(2), camera }
}

/// A unit icosphere whose front is cut by the near plane before its contour (near = 1.3): the
/// clip outline lies inside the silhouette (the back of the sphere covers it) and must add
/// nothing; the contour stays.
pub fn icosphere_near_inside(size: u32) -> ClipScene {
    let mut camera =
        Camera::perspective(Vec3::new(-0.06, 0.04, 2.0), Vec3::new(0.02, 0.0, 0.0), 70f32.to_radians(), size, size);
    camera.near = 1.3;
    ClipScene { name: "icosphere_near_inside", mesh: shapes::icosphere(2), camera }
}

/// A lumpy closed mesh (`shapes::blob`, 308 triangles) crossing the far plane (far = 2.6 for a
/// mesh about 2.15 to 3.85 away): only its front is drawn, outlined where the far plane cuts.
pub fn blob_far(size: u32) -> ClipScene {
    let mut camera =
        Camera::perspective(Vec3::new(0.1, 0.2, 3.0), Vec3::new(0.0, 0.0, 0.0), 50f32.to_radians(), size, size);
    camera.far = 2.6;
    ClipScene { name: "blob_far", mesh: shapes::blob(12, 14).normalized(0.85), camera }
}

/// A flat quad (two triangles, shared diagonal) on the floor running from behind the camera to
/// in front of it: both triangles and their shared edge cross the near plane (near = 0.5).
pub fn floor_quad(size: u32) -> ClipScene {
    let positions = vec![
        Vec3::new(-1.0, -0.5, 1.0),
        Vec3::new(1.2, -0.5, 1.0),
        Vec3::new(1.1, -0.5, -3.0),
        Vec3::new(-0.9, -0.45, -3.0),
    ];
    let mesh = Mesh::new(positions, vec![[0, 1, 2], [0, 2, 3]]).unwrap();
    let mut camera =
        Camera::perspective(Vec3::new(0.03, 0.3, 0.0), Vec3::new(0.0, -0.2, -1.0), 80f32.to_radians(), size, size);
    camera.near = 0.5;
    ClipScene { name: "floor_quad", mesh, camera }
}

/// An orthographic camera whose near plane (depth 0, at the eye) cuts an icosphere behind its
/// contour: the outline is the cut.
pub fn orthographic_half(size: u32) -> ClipScene {
    let camera = Camera::orthographic(Vec3::new(0.05, 0.1, -0.3), Vec3::new(0.0, 0.0, -1.3), 2.6, size, size);
    ClipScene { name: "orthographic_half", mesh: shapes::icosphere(2), camera }
}

/// Every clipping scene at `size`².
pub fn all(size: u32) -> Vec<ClipScene> {
    vec![
        camera_in_box(size),
        icosphere_close_up(size),
        icosphere_near_inside(size),
        blob_far(size),
        floor_quad(size),
        orthographic_half(size),
    ]
}

/// The reference image of `mesh` seen by `camera` (positions in `f64`).
pub fn reference_image(camera: &Camera, positions: &[DVec3], mesh: &Mesh, settings: RenderSettings) -> Vec<f64> {
    clipped_image(&camera.params(), positions, mesh.triangles(), settings.inside, settings.outside)
}

/// The mesh's positions in `f64`.
pub fn positions_f64(mesh: &Mesh) -> Vec<DVec3> {
    mesh.positions().iter().map(|p| p.as_dvec3()).collect()
}

/// The renderer's 3D gradient of `Σ w·I` for one view.
pub fn analytic(renderer: &mut Renderer, scene: &ClipScene, weights: &[f32]) -> Vec<Vec3> {
    let frame = renderer.render(&scene.mesh, &[scene.camera]).unwrap();
    let d = Image::from_vec(scene.camera.width, scene.camera.height, weights.to_vec()).unwrap();
    renderer.backward(&frame, &[d]).unwrap()
}
