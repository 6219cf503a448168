//! Near/far clipping of a view's triangles on the host, before either engine sees them.
//!
//! A triangle whose vertices are not all strictly inside `near < depth < far` (the test the
//! `project` stage applies, in the same `f32` arithmetic) is replaced by the polygon
//! `triangle ∩ {near ≤ depth ≤ far}`, fan-triangulated from its first vertex in the triangle's
//! winding. The two planes are parallel, so every vertex of that polygon is either an original
//! vertex or the point where one original edge crosses one plane: `p = a + t·(b − a)` with
//! `t = (plane − d_a)/(d_b − d_a)`, `a` the endpoint with the lower index. A crossing is keyed by
//! (edge, plane), so two triangles sharing a clipped edge share the new vertex bit for bit: no
//! crack and no double boundary.
//!
//! A view in which no triangle needs this is rendered exactly as without clipping (same call,
//! same bits). A view that does is rendered from screen-space vertices with its own topology
//! (the originals, then the new vertices); the backward chains each new vertex's screen gradient
//! through the projection at `p` and through `p(a, b)` (with `t`'s dependence on both depths)
//! into the two original vertices: the exact derivative of the exact area of the clipped
//! geometry. Triangles with every vertex at or behind the near plane, or at or beyond the far
//! plane (a triangle lying in a plane included), are dropped and counted as culled, as are
//! polygons with a vertex that projects beyond [`COORD_LIMIT`] (raise `near` for close-ups).

use std::collections::HashMap;
use std::sync::Arc;

use glam::{DVec2, DVec3, Vec2, Vec3};

use crate::mirror::{ScreenVertex, ViewParams, COORD_LIMIT};
use crate::scene::mesh::Topology;
use crate::Result;

/// Whether every vertex's depth lies strictly between the near and far planes: eight vertices
/// at a time, with AVX2 where the processor has it (`cpu/isa.rs`). The depth is `row_dot`'s, the
/// grouping of `ViewParams::camera_space` and `project`, so the answer is the same.
fn all_between_planes(view: &ViewParams, positions: &[Vec3]) -> bool {
    #[cfg(target_arch = "x86_64")]
    if crate::cpu::isa::has_avx2() {
        // SAFETY: the processor runs AVX2.
        return unsafe { all_between_planes_avx2(view, positions) };
    }
    all_between_planes_any(view, positions)
}

/// [`all_between_planes_any`] compiled with AVX2; only for a processor that has it.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn all_between_planes_avx2(view: &ViewParams, positions: &[Vec3]) -> bool {
    all_between_planes_any(view, positions)
}

/// [`all_between_planes`] on any processor: each block of eight without branches, so the
/// compiler vectorises it.
#[inline(always)]
fn all_between_planes_any(view: &ViewParams, positions: &[Vec3]) -> bool {
    let (near, far) = (view.near, view.far);
    let inside = |p: &Vec3| {
        let depth = -crate::cpu::project::row_dot(view.row2, *p);
        (depth > near) & (depth < far)
    };
    let mut blocks = positions.chunks_exact(8);
    for block in &mut blocks {
        if !block.iter().fold(true, |all, p| all & inside(p)) {
            return false;
        }
    }
    blocks.remainder().iter().all(inside)
}

/// Where a depth lies relative to the open range `(near, far)`.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Side {
    /// `depth ≤ near` (or not finite).
    Near,
    /// `near < depth < far`: what `project` draws.
    Inside,
    /// `depth ≥ far`.
    Far,
}

/// One vertex added by clipping: where original edge `(a, b)` (`a < b`) crosses a plane.
#[derive(Clone, Copy, Debug)]
struct NewVertex {
    /// Lower-index endpoint.
    a: u32,
    /// Higher-index endpoint.
    b: u32,
    /// Depth of the plane (`near` or `far`).
    plane: f64,
    /// `(plane − d_a)/(d_b − d_a)`, in `(0, 1)`.
    t: f64,
}

/// A view whose triangles needed clipping: the geometry the engine renders instead of the mesh.
pub(crate) struct ClipView {
    /// The originals' vertices, then the new vertices; the kept and clipped triangles.
    pub topology: Arc<Topology>,
    /// Screen vertex of every vertex of `topology`.
    pub screen: Vec<ScreenVertex>,
    /// The vertices after the originals.
    new_vertices: Vec<NewVertex>,
    /// Original vertices exactly on a plane that a kept polygon uses (projected here, since
    /// `project` rejects them).
    on_plane: Vec<u32>,
    /// Original vertex count.
    vertex_count: usize,
    /// Triangles of the mesh drawn clipped.
    pub clipped_triangles: u32,
    /// Triangles of the mesh dropped (wholly outside the range, or a vertex not drawable).
    pub culled_triangles: u32,
}

/// Projection of camera-space `c` at depth `depth` (> 0 for perspective) in `f64`, then rounded
/// to `f32`, with its validity (finite, within [`COORD_LIMIT`]).
fn screen_at(view: &ViewParams, c: DVec3, depth: f64) -> ScreenVertex {
    let (x, y) = if view.perspective == 1 { (c.x / depth, c.y / depth) } else { (c.x, c.y) };
    let s =
        DVec2::new(view.centre[0] as f64 + view.scale[0] as f64 * x, view.centre[1] as f64 - view.scale[1] as f64 * y)
            .as_vec2();
    let valid = s.is_finite() && s.x.abs() < COORD_LIMIT && s.y.abs() < COORD_LIMIT;
    ScreenVertex { position: if valid { s.to_array() } else { [0.0; 2] }, valid: valid as u32, pad: 0 }
}

/// `∂(screen)/∂c` at camera-space `c` and depth `depth`, applied transposed to `g`: `∂L/∂c`.
fn screen_grad_to_camera(view: &ViewParams, c: DVec3, depth: f64, g: Vec2) -> DVec3 {
    let (sx, sy) = (view.scale[0] as f64, view.scale[1] as f64);
    let (gx, gy) = (g.x as f64, g.y as f64);
    if view.perspective == 1 {
        // x = cx + sx·c.x/d, y = cy − sy·c.y/d with d = −c.z: ∂d/∂c.z = −1.
        DVec3::new(gx * sx / depth, -gy * sy / depth, (gx * sx * c.x - gy * sy * c.y) / (depth * depth))
    } else {
        DVec3::new(gx * sx, -gy * sy, 0.0)
    }
}

/// The rows of `R` in `f64`: `∂L/∂p = Rᵀ·∂L/∂c`.
fn rotation_rows(view: &ViewParams) -> [DVec3; 3] {
    [view.row0, view.row1, view.row2].map(|r| DVec3::new(r[0] as f64, r[1] as f64, r[2] as f64))
}

/// The topologies of the last few clipped views, reused while the clipped triangle list stays the
/// same (building one sorts every edge of the mesh; in a fit the clipped set rarely changes).
#[derive(Default)]
pub(crate) struct TopologyCache(Vec<Arc<Topology>>);

/// How many clipped topologies a renderer keeps.
const CACHED_TOPOLOGIES: usize = 8;

impl TopologyCache {
    /// The topology of `triangles` over `vertex_count` vertices: a cached one with the same
    /// triangles, or a new one (then cached, the oldest dropped).
    fn get(&mut self, vertex_count: usize, triangles: Vec<[u32; 3]>) -> Result<Arc<Topology>> {
        if let Some(k) =
            self.0.iter().position(|t| t.vertex_count() == vertex_count && t.triangles() == triangles.as_slice())
        {
            let topology = self.0.remove(k);
            self.0.push(topology.clone());
            return Ok(topology);
        }
        let topology = Arc::new(Topology::new(vertex_count, triangles)?);
        if self.0.len() == CACHED_TOPOLOGIES {
            self.0.remove(0);
        }
        self.0.push(topology.clone());
        Ok(topology)
    }
}

impl ClipView {
    /// Clips the triangles of one view, or `None` when none needs it (the view renders as
    /// without clipping). `triangles` index `positions`; `cache` keeps recent clipped topologies.
    pub fn new(
        view: &ViewParams,
        positions: &[Vec3],
        triangles: &[[u32; 3]],
        cache: &mut TopologyCache,
    ) -> Result<Option<ClipView>> {
        // The common case, every vertex strictly between the planes: no triangle can need
        // clipping, and one pass over the vertices (no allocation) says so.
        if all_between_planes(view, positions) {
            return Ok(None);
        }
        let camera: Vec<Vec3> = positions.iter().map(|&p| view.camera_space(p)).collect();
        let side = |v: u32| {
            let d = -camera[v as usize].z;
            if d > view.near && d < view.far {
                Side::Inside
            } else if d >= view.far {
                Side::Far
            } else {
                Side::Near // d ≤ near, or NaN
            }
        };
        let needs_clipping = |t: &[u32; 3]| {
            let s = t.map(side);
            let all = |x: Side| s.iter().all(|&y| y == x);
            let finite = t.iter().all(|&v| camera[v as usize].is_finite());
            finite && !all(Side::Inside) && !all(Side::Near) && !all(Side::Far) && !drops(view, &camera, t)
        };
        if !triangles.iter().any(needs_clipping) {
            return Ok(None);
        }
        let n = positions.len();
        let mut screen: Vec<ScreenVertex> = positions
            .iter()
            .map(|&p| {
                let (s, valid) = view.project(p);
                ScreenVertex { position: s.to_array(), valid: valid as u32, pad: 0 }
            })
            .collect();
        let mut new_vertices = Vec::new();
        let mut keys: HashMap<(u32, u32, bool), u32> = HashMap::new();
        let mut on_plane = Vec::new();
        let mut is_on_plane = vec![false; n];
        let mut out = Vec::with_capacity(triangles.len() + triangles.len() / 4);
        let (mut clipped, mut culled) = (0u32, 0u32);
        let planes = [(false, view.near as f64), (true, view.far as f64)];
        let c64 = |v: u32| camera[v as usize].as_dvec3();
        let depth = |v: u32| -(camera[v as usize].z as f64);
        for t in triangles {
            if t.iter().all(|&v| side(v) == Side::Inside) {
                // Drawn as without clipping (culled by the engine if beyond the coordinate limit).
                culled += t.iter().any(|&v| screen[v as usize].valid == 0) as u32;
                out.push(*t);
                continue;
            }
            if !needs_clipping(t) {
                culled += 1; // wholly outside the range, or not finite: dropped
                continue;
            }
            // The polygon, in the triangle's winding: each vertex inside the closed range, then
            // the crossings of the edge that follows it, in order along the edge.
            let mut polygon: Vec<u32> = Vec::with_capacity(5);
            for k in 0..3 {
                let (u, w) = (t[k], t[(k + 1) % 3]);
                let du = depth(u);
                if du >= view.near as f64 && du <= view.far as f64 {
                    if side(u) != Side::Inside && !is_on_plane[u as usize] {
                        is_on_plane[u as usize] = true;
                        on_plane.push(u);
                    }
                    polygon.push(u);
                }
                let dw = depth(w);
                let mut crossings: Vec<(f64, u32)> = Vec::with_capacity(2);
                for (is_far, plane) in planes {
                    if !((du < plane && dw > plane) || (du > plane && dw < plane)) {
                        continue;
                    }
                    let (a, b) = (u.min(w), u.max(w));
                    let index = *keys.entry((a, b, is_far)).or_insert_with(|| {
                        let (da, db) = (depth(a), depth(b));
                        let t = ((plane - da) / (db - da)).clamp(0.0, 1.0);
                        new_vertices.push(NewVertex { a, b, plane, t });
                        let c = c64(a) + t * (c64(b) - c64(a));
                        screen.push(screen_at(view, c, plane));
                        (n + new_vertices.len() - 1) as u32
                    });
                    // Distance along u → w, for the order of two crossings on one edge.
                    crossings.push(((plane - du).abs(), index));
                }
                crossings.sort_by(|x, y| x.0.total_cmp(&y.0));
                polygon.extend(crossings.iter().map(|c| c.1));
            }
            if polygon.len() < 3 {
                culled += 1;
                continue;
            }
            for &v in &polygon {
                if (v as usize) < n && side(v) != Side::Inside && screen[v as usize].valid == 0 {
                    screen[v as usize] = screen_at(view, c64(v), depth(v));
                }
            }
            if polygon.iter().any(|&v| screen[v as usize].valid == 0) {
                culled += 1; // not drawable (the engine culls its pieces)
            } else {
                clipped += 1;
            }
            for i in 1..polygon.len() - 1 {
                out.push([polygon[0], polygon[i], polygon[i + 1]]);
            }
        }
        let topology = cache.get(n + new_vertices.len(), out)?;
        Ok(Some(ClipView {
            topology,
            screen,
            new_vertices,
            on_plane,
            vertex_count: n,
            clipped_triangles: clipped,
            culled_triangles: culled,
        }))
    }

    /// `∂L/∂(3D vertex)` of this view from `∂L/∂(screen vertex)` of its geometry (`screen_grads`,
    /// one per vertex of [`ClipView::topology`]): the originals through `view`'s Jacobian (as for a
    /// view without clipping), each new vertex into its edge's two endpoints. Fixed order: the
    /// originals, then the on-plane originals and the new vertices in index order, summed in `f64`.
    pub fn chain_to_3d(&self, view: &ViewParams, positions: &[Vec3], screen_grads: &[Vec2]) -> Vec<Vec3> {
        let n = self.vertex_count;
        let mut grads = super::views::view_to_3d(view, positions, &screen_grads[..n.min(screen_grads.len())]);
        let rows = rotation_rows(view);
        let to_world = |gc: DVec3| rows[0] * gc.x + rows[1] * gc.y + rows[2] * gc.z;
        let c64 = |v: u32| view.camera_space(positions[v as usize]).as_dvec3();
        let mut extra = vec![DVec3::ZERO; n];
        let mut on_plane = self.on_plane.clone();
        on_plane.sort_unstable();
        for &v in &on_plane {
            let g = screen_grads.get(v as usize).copied().unwrap_or(Vec2::ZERO);
            if g != Vec2::ZERO {
                let c = c64(v);
                extra[v as usize] += to_world(screen_grad_to_camera(view, c, -c.z, g));
            }
        }
        for (k, nv) in self.new_vertices.iter().enumerate() {
            let g = screen_grads.get(n + k).copied().unwrap_or(Vec2::ZERO);
            if g == Vec2::ZERO {
                continue;
            }
            let (ca, cb) = (c64(nv.a), c64(nv.b));
            let c = ca + nv.t * (cb - ca);
            let gc = screen_grad_to_camera(view, c, nv.plane, g);
            // t = (P − d_a)/(d_b − d_a), d = −c.z: ∂t/∂d_a = (P − d_b)/Δ², ∂t/∂d_b = −(P − d_a)/Δ².
            let (da, db) = (-ca.z, -cb.z);
            let delta = db - da;
            let along = gc.dot(cb - ca);
            let dt_dca_z = -(nv.plane - db) / (delta * delta);
            let dt_dcb_z = (nv.plane - da) / (delta * delta);
            let ga = (1.0 - nv.t) * gc + DVec3::new(0.0, 0.0, along * dt_dca_z);
            let gb = nv.t * gc + DVec3::new(0.0, 0.0, along * dt_dcb_z);
            extra[nv.a as usize] += to_world(ga);
            extra[nv.b as usize] += to_world(gb);
        }
        for (g, e) in grads.iter_mut().zip(&extra) {
            if *e != DVec3::ZERO {
                *g += e.as_vec3();
            }
        }
        grads
    }
}

/// Whether a triangle that is not wholly inside is dropped all the same: every vertex at or behind
/// the near plane, or at or beyond the far plane.
fn drops(view: &ViewParams, camera: &[Vec3], t: &[u32; 3]) -> bool {
    let d = t.map(|v| -camera[v as usize].z);
    d.iter().all(|&d| d <= view.near) || d.iter().all(|&d| d >= view.far)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::random::SplitMix64;

    /// A view at distance 3 with near 0.5 and far 5: rotated (the projection tests' view: no zero
    /// entry in its depth row, so another grouping of the dot product would round differently
    /// somewhere), or looking down −z (so depths exactly at the planes are easy to place).
    fn view(rotated: bool) -> ViewParams {
        let view = crate::cpu::project::tests::view(true);
        if rotated {
            view
        } else {
            ViewParams { row2: [0.0, 0.0, 1.0, -3.0], ..view }
        }
    }

    /// The blocked check answers as `ViewParams::camera_space`'s depth vertex by vertex,
    /// compiled either way, for every length of a last block, one vertex out of place at every
    /// position (on a plane, within rounding of one, just inside one, behind the camera, not
    /// finite), and none.
    #[test]
    fn the_blocked_plane_check_is_the_vertex_at_a_time_one() {
        let mut rng = SplitMix64::new(9);
        let mut answers = [0; 2];
        for rotated in [true, false] {
            let view = view(rotated);
            let one_by_one = |positions: &[Vec3]| {
                positions.iter().all(|&p| {
                    let d = -view.camera_space(p).z;
                    d > view.near && d < view.far
                })
            };
            let odd = [
                Vec3::new(0.0, 0.0, 2.5),        // depth 0.5 (looking down −z): on near
                Vec3::new(0.0, 0.0, -2.0),       // depth 5: on far
                Vec3::new(0.0, 0.0, 2.4999998),  // just inside near
                Vec3::new(0.0, 0.0, -1.9999998), // just inside far
                Vec3::new(0.1, -0.2, 3.5),       // behind the camera
                Vec3::new(f32::NAN, 0.0, 0.0),
                Vec3::new(0.0, f32::INFINITY, 0.0),
            ];
            for n in (0..=17).chain([100, 1001]) {
                let base: Vec<Vec3> = (0..n)
                    .map(|_| Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)))
                    .collect();
                let mut cases = vec![base.clone()];
                for k in 0..n {
                    let mut positions = base.clone();
                    positions[k] = if k % 2 == 0 {
                        odd[k / 2 % odd.len()]
                    } else {
                        // Within rounding of a plane: z solved in f32 for a random x and y.
                        let (r, plane) = (view.row2, [view.near, view.far][k / 2 % 2]);
                        let (x, y) = (rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
                        Vec3::new(x, y, (-plane - r[3] - r[0] * x - r[1] * y) / r[2])
                    };
                    cases.push(positions);
                }
                for positions in cases {
                    let expected = one_by_one(&positions);
                    answers[expected as usize] += 1;
                    assert_eq!(all_between_planes_any(&view, &positions), expected, "{n} vertices: {positions:?}");
                    assert_eq!(all_between_planes(&view, &positions), expected, "{n} vertices: {positions:?}");
                }
            }
        }
        assert!(answers.iter().all(|&a| a > 20), "both answers occur: {answers:?}");
    }
}
