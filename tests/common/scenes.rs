//! Reusable test scenes, in screen space (2D) and in world space with cameras (3D).
//!
//! Sizes are moderate (16²–48² images, at most a few hundred triangles) so that finite
//! differences of the exact-area oracle stay fast. The GPU comparison tests reuse them.
//!
//! | scene                | what it exercises                                                  |
//! |----------------------|--------------------------------------------------------------------|
//! | `triangle`           | one triangle: boundary edges only                                  |
//! | `quad`               | two triangles sharing an edge that must contribute nothing         |
//! | `icosphere`          | a closed mesh: contour edges only, front and back faces overlap    |
//! | `torus_fold`         | a tilted torus: contour edges in front of the body (occluded)      |
//! | `blob`               | `shapes::blob`, a lumpy closed mesh with folds                     |
//! | `two_spheres`        | two overlapping closed components in one mesh                      |
//! | `open_patch`         | a wavy open grid: boundary edges (and folds)                       |
//! | `hemisphere`         | an open bowl seen from the side: boundary edges in front of it     |
//! | `square_on_grid`     | integer vertices: silhouette edges along pixel borders             |
//! | `diamond_on_grid`    | integer vertices: 45° edges through pixel corners                  |
//! | `flat_grid`          | a jittered flat grid: interior vertices must get zero gradient     |

#![allow(dead_code)]

use std::f32::consts::PI;
use std::sync::Arc;

use diffsil::{shapes, Camera, Mesh, Orbit, ScreenView, Topology, Vec2, Vec3};

/// A 2D scene: screen-space vertices (pixels, y down) and triangles, with an image size.
#[derive(Clone, Debug)]
pub struct Scene2d {
    /// Short name for reports.
    pub name: &'static str,
    /// Pixel coordinates per vertex.
    pub vertices: Vec<Vec2>,
    /// Triangles.
    pub triangles: Vec<[u32; 3]>,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
}

impl Scene2d {
    /// The topology (validated).
    pub fn topology(&self) -> Arc<Topology> {
        Arc::new(Topology::new(self.vertices.len(), self.triangles.clone()).expect("valid scene topology"))
    }

    /// The single screen view of this scene.
    pub fn view(&self) -> ScreenView {
        self.view_with(self.vertices.clone())
    }

    /// A screen view of this scene with other vertex positions.
    pub fn view_with(&self, vertices: Vec<Vec2>) -> ScreenView {
        ScreenView { vertices, width: self.width, height: self.height }
    }
}

/// A 3D scene: a mesh and one or more cameras.
#[derive(Clone, Debug)]
pub struct Scene3d {
    /// Short name for reports.
    pub name: &'static str,
    /// The mesh.
    pub mesh: Mesh,
    /// The views.
    pub cameras: Vec<Camera>,
}

impl Scene3d {
    /// The mesh projected through camera `view` (with the camera's own f32 projection) as a 2D
    /// scene. Panics if a vertex is clipped: the test scenes keep every vertex in front.
    pub fn screen(&self, view: usize, name: &'static str) -> Scene2d {
        let camera = &self.cameras[view];
        let params = camera.params();
        let vertices = self
            .mesh
            .positions()
            .iter()
            .map(|&p| {
                let (s, valid) = params.project(p);
                assert!(valid, "{name}: vertex {p} is clipped by the camera");
                s
            })
            .collect();
        Scene2d {
            name,
            vertices,
            triangles: self.mesh.triangles().to_vec(),
            width: camera.width,
            height: camera.height,
        }
    }
}

// -------------------------------------------------------------------------------------------------
// Meshes
// -------------------------------------------------------------------------------------------------

/// Applies `f` to every position of `mesh`.
pub fn transformed(mesh: &Mesh, f: impl Fn(Vec3) -> Vec3) -> Mesh {
    let positions = mesh.positions().iter().map(|&p| f(p)).collect();
    Mesh::with_topology(positions, mesh.topology().clone()).expect("finite transform")
}

/// Concatenates meshes into one mesh with several components.
pub fn merged(meshes: &[Mesh]) -> Mesh {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for m in meshes {
        let base = positions.len() as u32;
        positions.extend_from_slice(m.positions());
        triangles.extend(m.triangles().iter().map(|t| t.map(|i| i + base)));
    }
    Mesh::new(positions, triangles).expect("valid merged mesh")
}

/// A closed torus around the z axis (major radius `major`, tube radius `minor`), `major_segments ×
/// minor_segments` quads, `2·major_segments·minor_segments` triangles.
pub fn torus(major: f32, minor: f32, major_segments: u32, minor_segments: u32) -> Mesh {
    let mut positions = Vec::new();
    for i in 0..major_segments {
        let u = 2.0 * PI * i as f32 / major_segments as f32;
        for j in 0..minor_segments {
            let v = 2.0 * PI * j as f32 / minor_segments as f32;
            let r = major + minor * v.cos();
            positions.push(Vec3::new(r * u.cos(), r * u.sin(), minor * v.sin()));
        }
    }
    let index = |i: u32, j: u32| (i % major_segments) * minor_segments + j % minor_segments;
    let mut triangles = Vec::new();
    for i in 0..major_segments {
        for j in 0..minor_segments {
            let (a, b, c, d) = (index(i, j), index(i + 1, j), index(i + 1, j + 1), index(i, j + 1));
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
    }
    Mesh::new(positions, triangles).expect("valid torus")
}

/// An open `n × n`-quad grid over `[-1, 1]²` in the xy plane with height `z = height(x, y)`.
pub fn grid_patch(n: u32, height: impl Fn(f32, f32) -> f32) -> Mesh {
    let mut positions = Vec::new();
    for i in 0..=n {
        for j in 0..=n {
            let (x, y) = (-1.0 + 2.0 * j as f32 / n as f32, -1.0 + 2.0 * i as f32 / n as f32);
            positions.push(Vec3::new(x, y, height(x, y)));
        }
    }
    let index = |i: u32, j: u32| i * (n + 1) + j;
    let mut triangles = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let (a, b, c, d) = (index(i, j), index(i, j + 1), index(i + 1, j + 1), index(i + 1, j));
            if (i + j) % 2 == 0 {
                triangles.extend([[a, b, c], [a, c, d]]);
            } else {
                triangles.extend([[a, b, d], [b, c, d]]);
            }
        }
    }
    Mesh::new(positions, triangles).expect("valid grid")
}

/// Keeps only the triangles for which `keep(centroid)` holds (and drops unused vertices).
pub fn cut(mesh: &Mesh, keep: impl Fn(Vec3) -> bool) -> Mesh {
    let p = mesh.positions();
    let mut remap = vec![u32::MAX; p.len()];
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for t in mesh.triangles() {
        let centroid = (p[t[0] as usize] + p[t[1] as usize] + p[t[2] as usize]) / 3.0;
        if !keep(centroid) {
            continue;
        }
        triangles.push(t.map(|i| {
            if remap[i as usize] == u32::MAX {
                remap[i as usize] = positions.len() as u32;
                positions.push(p[i as usize]);
            }
            remap[i as usize]
        }));
    }
    Mesh::new(positions, triangles).expect("valid cut mesh")
}

/// Rotation about the x axis by `angle` radians.
pub fn rotate_x(p: Vec3, angle: f32) -> Vec3 {
    let (s, c) = angle.sin_cos();
    Vec3::new(p.x, c * p.y - s * p.z, s * p.y + c * p.z)
}

/// Rotation about the y axis by `angle` radians.
pub fn rotate_y(p: Vec3, angle: f32) -> Vec3 {
    let (s, c) = angle.sin_cos();
    Vec3::new(c * p.x + s * p.z, p.y, -s * p.x + c * p.z)
}

// -------------------------------------------------------------------------------------------------
// Cameras
// -------------------------------------------------------------------------------------------------

/// The default perspective camera of the 3D scenes: from `(0.35, 0.25, 3.2)` towards a point
/// slightly off the origin (so that nothing lines up with the pixel grid), vertical fov 50°.
pub fn default_camera(width: u32, height: u32) -> Camera {
    Camera::perspective(Vec3::new(0.35, 0.25, 3.2), Vec3::new(0.031, -0.017, 0.0), 50f32.to_radians(), width, height)
}

/// `n` perspective cameras around the origin at azimuths `phase + k·2π/n`, elevation 0.3 rad,
/// distance 3.2, fov 50°, aimed slightly off the origin.
pub fn orbit_cameras(n: usize, phase: f32, width: u32, height: u32) -> Vec<Camera> {
    (0..n)
        .map(|k| {
            let az = phase + 2.0 * PI * k as f32 / n as f32;
            let target = Vec3::new(0.023, -0.011, 0.017);
            Orbit { target, azimuth: az, elevation: 0.3, distance: 3.2, fov_y: 50f32.to_radians() }
                .camera(width, height)
        })
        .collect()
}

/// `n` orthographic cameras around the origin at azimuths `phase + k·2π/n`, elevation 0.3 rad,
/// the image height spanning 2.9 world units.
pub fn orthographic_cameras(n: usize, phase: f32, width: u32, height: u32) -> Vec<Camera> {
    (0..n)
        .map(|k| {
            let az = phase + 2.0 * PI * k as f32 / n as f32;
            let dir = Vec3::new(0.3f32.cos() * az.sin(), 0.3f32.sin(), 0.3f32.cos() * az.cos());
            let target = Vec3::new(0.023, -0.011, 0.017);
            Camera::orthographic(target + 5.0 * dir, target, 2.9, width, height)
        })
        .collect()
}

// -------------------------------------------------------------------------------------------------
// 3D scenes
// -------------------------------------------------------------------------------------------------

/// A closed unit icosphere (2 subdivisions, 320 triangles) seen by [`default_camera`] at 32².
pub fn icosphere_3d() -> Scene3d {
    Scene3d { name: "icosphere", mesh: shapes::icosphere(2), cameras: vec![default_camera(32, 32)] }
}

/// A torus (R = 1, r = 0.38, 20 × 8 quads = 320 triangles) tilted 60° about x, plus a little about
/// y, seen by [`default_camera`] at 40²: the near half of the tube hides parts of the far half and
/// of the hole, so some contour edges lie in front of the body and must contribute nothing.
pub fn torus_fold_3d() -> Scene3d {
    let mesh = transformed(&torus(1.0, 0.38, 20, 8), |p| rotate_y(rotate_x(p, 60f32.to_radians()), 0.2));
    Scene3d { name: "torus_fold", mesh, cameras: vec![default_camera(40, 40)] }
}

/// [`shapes::blob`] with 12 rings × 14 segments (308 triangles) at 32².
pub fn blob_3d() -> Scene3d {
    Scene3d {
        name: "blob",
        mesh: transformed(&shapes::blob(12, 14), |p| 0.85 * p),
        cameras: vec![default_camera(32, 32)],
    }
}

/// Two icospheres (1 subdivision, 80 triangles each) in one mesh: a larger one behind, a smaller
/// one in front and to the right, overlapping it on screen.
pub fn two_spheres_3d() -> Scene3d {
    let back = transformed(&shapes::icosphere(1), |p| 0.8 * p + Vec3::new(-0.45, 0.05, -0.2));
    let front = transformed(&shapes::icosphere(1), |p| 0.6 * rotate_y(p, 0.4) + Vec3::new(0.45, -0.1, 0.7));
    Scene3d { name: "two_spheres", mesh: merged(&[back, front]), cameras: vec![default_camera(32, 32)] }
}

/// An open wavy 10 × 10 grid (200 triangles) tilted towards the camera: boundary edges.
pub fn open_patch_3d() -> Scene3d {
    let patch = grid_patch(10, |x, y| 0.25 * (2.1 * x + 0.4).sin() * (1.7 * y - 0.3).cos());
    let mesh = transformed(&patch, |p| rotate_y(rotate_x(p, -0.9), 0.35));
    Scene3d { name: "open_patch", mesh, cameras: vec![default_camera(32, 32)] }
}

/// The upper part of an icosphere (an open bowl, its rim a boundary) tilted so the camera sees
/// the outside and, over the rim, the inside.
pub fn hemisphere_3d() -> Scene3d {
    let bowl = cut(&shapes::icosphere(2), |c| c.y > -0.15);
    let mesh = transformed(&bowl, |p| rotate_x(p, 0.6));
    Scene3d { name: "hemisphere", mesh, cameras: vec![default_camera(32, 32)] }
}

// -------------------------------------------------------------------------------------------------
// 2D scenes
// -------------------------------------------------------------------------------------------------

/// One triangle, generic coordinates, 24².
pub fn triangle() -> Scene2d {
    Scene2d {
        name: "triangle",
        vertices: vec![Vec2::new(3.3, 4.1), Vec2::new(19.7, 7.9), Vec2::new(8.2, 20.6)],
        triangles: vec![[0, 1, 2]],
        width: 24,
        height: 24,
    }
}

/// A quad of two triangles sharing the edge 0–2 (opposite windings on purpose: winding must not
/// matter), 24².
pub fn quad() -> Scene2d {
    Scene2d {
        name: "quad",
        vertices: vec![Vec2::new(3.4, 5.2), Vec2::new(20.1, 3.7), Vec2::new(21.3, 19.6), Vec2::new(4.7, 18.2)],
        triangles: vec![[0, 1, 2], [0, 3, 2]],
        width: 24,
        height: 24,
    }
}

/// [`icosphere_3d`] projected to the screen.
pub fn icosphere() -> Scene2d {
    icosphere_3d().screen(0, "icosphere")
}

/// [`torus_fold_3d`] projected to the screen.
pub fn torus_fold() -> Scene2d {
    torus_fold_3d().screen(0, "torus_fold")
}

/// [`blob_3d`] projected to the screen.
pub fn blob() -> Scene2d {
    blob_3d().screen(0, "blob")
}

/// [`two_spheres_3d`] projected to the screen.
pub fn two_spheres() -> Scene2d {
    two_spheres_3d().screen(0, "two_spheres")
}

/// [`open_patch_3d`] projected to the screen.
pub fn open_patch() -> Scene2d {
    open_patch_3d().screen(0, "open_patch")
}

/// [`hemisphere_3d`] projected to the screen.
pub fn hemisphere() -> Scene2d {
    hemisphere_3d().screen(0, "hemisphere")
}

/// An axis-aligned square with integer corners (two triangles): its silhouette runs exactly along
/// pixel borders and its corners sit on pixel corners. 20 × 18 (non-square image).
pub fn square_on_grid() -> Scene2d {
    Scene2d {
        name: "square_on_grid",
        vertices: vec![Vec2::new(4.0, 3.0), Vec2::new(15.0, 3.0), Vec2::new(15.0, 13.0), Vec2::new(4.0, 13.0)],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        width: 20,
        height: 18,
    }
}

/// A 45° diamond with integer vertices (four triangles around an integer centre): every
/// silhouette edge passes exactly through pixel corners, and each pixel it crosses is cut along
/// its diagonal. 24².
pub fn diamond_on_grid() -> Scene2d {
    Scene2d {
        name: "diamond_on_grid",
        vertices: vec![
            Vec2::new(12.0, 12.0),
            Vec2::new(12.0, 3.0),
            Vec2::new(21.0, 12.0),
            Vec2::new(12.0, 21.0),
            Vec2::new(3.0, 12.0),
        ],
        triangles: vec![[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]],
        width: 24,
        height: 24,
    }
}

/// A flat, jittered `n × n`-quad grid over `[3, 21]²` in a 24² image; vertex `(i, j)` is
/// `i·(n+1) + j`. Interior vertices are on no silhouette edge.
pub fn flat_grid(n: u32) -> Scene2d {
    let mut vertices = Vec::new();
    for i in 0..=n {
        for j in 0..=n {
            let jitter = |k: u32| 0.23 * ((k as f32 * 12.9898).sin() * 43758.547).fract();
            let x = 3.0 + 18.0 * j as f32 / n as f32 + jitter(3 * (i * (n + 1) + j) + 1);
            let y = 3.0 + 18.0 * i as f32 / n as f32 + jitter(3 * (i * (n + 1) + j) + 2);
            vertices.push(Vec2::new(x, y));
        }
    }
    let mesh = grid_patch(n, |_, _| 0.0);
    Scene2d { name: "flat_grid", vertices, triangles: mesh.triangles().to_vec(), width: 24, height: 24 }
}

/// Every 2D scene the gradient tests check.
pub fn all_2d() -> Vec<Scene2d> {
    vec![
        triangle(),
        quad(),
        icosphere(),
        torus_fold(),
        blob(),
        two_spheres(),
        open_patch(),
        hemisphere(),
        square_on_grid(),
        diamond_on_grid(),
        flat_grid(4),
    ]
}
