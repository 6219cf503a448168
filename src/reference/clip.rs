//! Near/far clipping in `f64`, independent of the renderer's: each triangle is clipped on its own
//! (Sutherland–Hodgman against `depth ≥ near`, then `depth ≤ far`, in camera space), projected in
//! `f64` with the documented camera model, and fan-triangulated, for the exact-area oracle. It
//! shares nothing with `render/clip.rs` beyond the camera constants.

use glam::{DVec2, DVec3};

use super::oracle::exact_coverage_f64;
use crate::mirror::ViewParams;

/// Camera-space point of world point `p`: `c = R·p + t` from the view's rows, in `f64`.
pub fn camera_space_f64(view: &ViewParams, p: DVec3) -> DVec3 {
    let row = |r: [f32; 4]| DVec3::new(r[0] as f64, r[1] as f64, r[2] as f64).dot(p) + r[3] as f64;
    DVec3::new(row(view.row0), row(view.row1), row(view.row2))
}

/// Pixel coordinates of camera-space `c` (depth `−c.z`): perspective `x = cx + sx·c.x/d`,
/// `y = cy − sy·c.y/d`; orthographic without the division.
pub fn project_camera_f64(view: &ViewParams, c: DVec3) -> DVec2 {
    let d = -c.z;
    let (x, y) = if view.perspective == 1 { (c.x / d, c.y / d) } else { (c.x, c.y) };
    DVec2::new(view.centre[0] as f64 + view.scale[0] as f64 * x, view.centre[1] as f64 - view.scale[1] as f64 * y)
}

/// Keeps the part of `polygon` (camera space) where `sign · (depth − plane) ≥ 0`.
fn clip_polygon(polygon: &[DVec3], plane: f64, sign: f64) -> Vec<DVec3> {
    let inside = |c: DVec3| sign * (-c.z - plane) >= 0.0;
    let mut out = Vec::with_capacity(polygon.len() + 1);
    for (i, &a) in polygon.iter().enumerate() {
        let b = polygon[(i + 1) % polygon.len()];
        if inside(a) {
            out.push(a);
        }
        if inside(a) != inside(b) {
            let (da, db) = (-a.z, -b.z);
            if da != db {
                let t = (plane - da) / (db - da);
                out.push(a + t * (b - a));
            }
        }
    }
    out
}

/// The triangles of a mesh clipped to `near ≤ depth ≤ far` of `view` and projected: screen
/// vertices and fan triangles (three fresh vertices each). Triangles wholly at or behind the near
/// plane or at or beyond the far plane are left out.
pub fn clip_and_project(view: &ViewParams, positions: &[DVec3], triangles: &[[u32; 3]]) -> (Vec<DVec2>, Vec<[u32; 3]>) {
    let (near, far) = (view.near as f64, view.far as f64);
    let (mut vertices, mut out) = (Vec::new(), Vec::new());
    for t in triangles {
        let c: Vec<DVec3> = t.iter().map(|&v| camera_space_f64(view, positions[v as usize])).collect();
        let depths: Vec<f64> = c.iter().map(|c| -c.z).collect();
        if depths.iter().all(|&d| d <= near) || depths.iter().all(|&d| d >= far) {
            continue;
        }
        let polygon = clip_polygon(&clip_polygon(&c, near, 1.0), far, -1.0);
        if polygon.len() < 3 {
            continue;
        }
        let screen: Vec<DVec2> = polygon.iter().map(|&c| project_camera_f64(view, c)).collect();
        for i in 1..screen.len() - 1 {
            let base = vertices.len() as u32;
            vertices.extend([screen[0], screen[i], screen[i + 1]]);
            out.push([base, base + 1, base + 2]);
        }
    }
    (vertices, out)
}

/// The ideal image (`outside + (inside − outside)·area`) of a mesh seen by `view`, clipped to
/// `near ≤ depth ≤ far`: [`clip_and_project`], then the exact-area oracle.
pub fn clipped_image(
    view: &ViewParams,
    positions: &[DVec3],
    triangles: &[[u32; 3]],
    inside: f32,
    outside: f32,
) -> Vec<f64> {
    let (vertices, tris) = clip_and_project(view, positions, triangles);
    let (p1, p0) = (inside as f64, outside as f64);
    exact_coverage_f64(&vertices, &tris, view.width, view.height).into_iter().map(|a| p0 + (p1 - p0) * a).collect()
}
