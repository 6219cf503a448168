//! Visibility from the view's contour: which parts of a candidate edge have an uncovered outside,
//! found from the mesh edges that do not cancel in this view rather than from the triangles near
//! the edge.
//!
//! Why this is exact. A point is covered when a triangle of non-zero float area holds it (one
//! with a clipped vertex holds nothing, as in the forward). Over
//! the triangles, `N₊` (the positive ones holding a point) and `D = N₊ − N₋` are sums over the
//! *contour*: the edges whose weights `w₊` (positive faces running the edge `a → b` minus those
//! running it `b → a`) and `w` (the same over the faces of either sign) are not both zero, as in
//! the forward's coverage from the contour (`cpu/coverage/contour.rs`), here with the float
//! orientations of [`face_orientations`](crate::cpu::edges::face_orientations). A point is
//! covered when `N₊ > 0` or `N₋ = N₊ − D > 0`. Along a candidate edge's outside these sums
//! change only where the edge crosses a contour edge, by that edge's weights: so a candidate's
//! visible parts follow from the sums at its start (`ContourBands::trace`: a ray cast against
//! the contour edges of the start's band) and from its crossings with the contour edges near it.
//! The work is in the contour's edges (a few thousand of the bunny's 104k edges at 64²), not in
//! the triangles.
//!
//! Degenerate positions (a vertex on the edge's line, the start on another edge, a contour edge
//! through an end point) are decided as for the point `va + δ·d + ε·outward` with
//! `0 < ε ≪ δ ≪ 1`: every sign test looks at the exact term first and then at the coefficients
//! of `δ` and `ε`, so every decision has one answer. A contour edge lying on the candidate's line
//! with a face on the candidate's inside takes the stretch it spans from the candidate when that
//! face ranks first (`coincident_rank`): the rule of coincident edges
//! that the WGSL stage applies triangle by triangle.
//!
//! The signs are those of f64 expressions in differences of the f32 screen positions, as in the
//! triangle-by-triangle tests this replaced (kept as the reference of `edge_grad`'s tests; the
//! WGSL stage evaluates them in float-float); the crossings' parameters are rounded quotients, so
//! the visible intervals' ends can differ from the triangle tests' in their last bits (a
//! relative 1e-16, far below the f32 gradient slots' precision).

use glam::{DVec2, Vec2};
use rayon::prelude::*;

use crate::cpu::coverage::contour::{edge_weights, wing_weights};
use crate::cpu::edges::edge_side;
use crate::mirror::ScreenVertex;
use crate::reference::closed_form::segment_weights;
use crate::scene::mesh::Topology;

/// One edge of the view's contour (48 bytes: the band lists hold a copy per band). Its points are
/// the screen vertices' f32 values, converted to f64 (exactly) where they are used.
#[derive(Clone, Copy, Debug)]
struct ContourEdge {
    /// End points, in the topology's order `[a, b]`.
    a: Vec2,
    b: Vec2,
    /// Its box.
    lo: Vec2,
    hi: Vec2,
    /// `w₊` and `w` for the direction `a → b`.
    positive: i32,
    net: i32,
    /// The mesh edge.
    edge: u32,
    /// The first band that lists it.
    first_band: u32,
}

/// Bands of the image whose height is at most this many pixels and at least
/// [`MIN_BAND`]: about the contour edges' mean height.
const MAX_BAND: f64 = 64.0;

/// The smallest band height in pixels.
const MIN_BAND: f64 = 1.0 / 256.0;

/// Most bands.
const MAX_BANDS: f64 = 65536.0;

/// The view's contour edges, listed by horizontal bands of the image: a band lists every contour
/// edge whose y range meets it (the first band holds also those above the image, the last those
/// below it). Built once per view ([`ContourBands::build`]), read by every candidate edge.
#[derive(Clone, Debug, Default)]
pub struct ContourBands {
    /// The contour edges, once each.
    edges: Vec<ContourEdge>,
    /// Their indices by increasing `lo.x` (below the order key of [`x_key`]).
    order: Vec<u64>,
    /// The band lists, one after the other.
    entries: Vec<ContourEdge>,
    /// Each entry's `lo.x`, the key the searches of a band list read (beside the entries, so a
    /// search touches a few cache lines rather than one per probe).
    keys: Vec<f32>,
    /// `offsets[k]..offsets[k + 1]` indexes `entries` for band `k`, sorted by `lo.x`.
    offsets: Vec<u32>,
    /// The widest box of each band (`hi.x − lo.x`, rounded up a little): an entry whose `lo.x`
    /// is further left than that from a point ends left of it.
    widths: Vec<f64>,
    /// Bands per pixel (a power of two, so `y · per_pixel` is exact).
    per_pixel: f64,
    /// Number of bands.
    bands: u32,
    /// The last band listing each of `edges` (the first is in the edge).
    last_bands: Vec<u32>,
    /// The fill's cursor per band (kept for its buffer).
    next: Vec<u32>,
}

impl ContourBands {
    /// Lists the contour: the `candidates` (from the `edges` stage) and the other edges with
    /// non-zero weights (edges with faces on both sides whose faces do not cancel: only where
    /// the topology is not two faces running an edge opposite ways).
    pub fn build(
        &mut self,
        screen: &[ScreenVertex],
        orientation: &[i8],
        topology: &Topology,
        candidates: &[(u32, i32)],
        image_height: u32,
    ) {
        let edges = topology.edges();
        let weights = |e: u32| match topology.edge_wings()[e as usize] {
            [f, g] if f != u32::MAX => wing_weights(orientation[f as usize], orientation[g as usize]),
            _ => edge_weights(topology, orientation, e as usize),
        };
        let contour_edge = |e: u32, (positive, net): (i32, i32)| {
            let [a, b] = edges[e as usize].map(|v| Vec2::from_array(screen[v as usize].position));
            let (lo, hi) = (a.min(b), a.max(b));
            ContourEdge { a, b, lo, hi, positive, net, edge: e, first_band: 0 }
        };
        self.edges.clear();
        self.edges.par_extend(candidates.par_iter().with_min_len(1024).map(|&(e, _)| contour_edge(e, weights(e))));
        for &e in topology.irregular_edges() {
            if edge_side(orientation, topology, e as usize) == 0 {
                let w = edge_weights(topology, orientation, e as usize);
                if w != (0, 0) {
                    self.edges.push(contour_edge(e, w));
                }
            }
        }
        // Bands about one mean edge height high: an edge then meets one or two bands, and a
        // band holds about as many edges as the contour crosses one image row.
        let extent: f64 = self.edges.iter().map(|c| (c.hi.y as f64 - c.lo.y as f64).min(MAX_BAND)).sum();
        let mean = if self.edges.is_empty() { MAX_BAND } else { extent / self.edges.len() as f64 };
        let mut height = mean.clamp(MIN_BAND, MAX_BAND);
        height = 2f64.powi(height.log2().ceil() as i32);
        while image_height as f64 / height > MAX_BANDS {
            height *= 2.0;
        }
        self.per_pixel = 1.0 / height;
        self.bands = ((image_height as f64 * self.per_pixel).ceil() as u32).max(1);
        self.offsets.clear();
        self.offsets.resize(self.bands as usize + 2, 0);
        self.last_bands.clear();
        // Each edge adds 1 from its first band's count to its last's: `+1` and `−1` at the ends
        // here, summed into counts below (branch-free per edge), then into list starts.
        for c in &mut self.edges {
            c.first_band = band_of(self.per_pixel, self.bands, c.lo.y as f64);
            let last = band_of(self.per_pixel, self.bands, c.hi.y as f64);
            self.last_bands.push(last);
            // (Wrapping: a slot may go below zero before its sums.)
            let (start, end) = (c.first_band as usize + 1, last as usize + 2);
            self.offsets[start] = self.offsets[start].wrapping_add(1);
            self.offsets[end] = self.offsets[end].wrapping_sub(1);
        }
        for _ in 0..2 {
            for k in 0..self.bands as usize {
                self.offsets[k + 1] = self.offsets[k + 1].wrapping_add(self.offsets[k]);
            }
        }
        self.offsets.truncate(self.bands as usize + 1);
        let total = self.offsets[self.bands as usize] as usize;
        // Every entry is written below: resizing keeps old values without rewriting them.
        self.entries.resize(total, EMPTY);
        self.keys.resize(total, 0.0);
        let next = &mut self.next;
        next.clear();
        next.extend_from_slice(&self.offsets);
        self.widths.clear();
        self.widths.resize(self.bands as usize, 0.0);
        // Filled in the order of `lo.x`, so that every band list is sorted by it.
        self.order.clear();
        self.order.extend(self.edges.iter().enumerate().map(|(i, c)| (x_key(c.lo.x) << 32) | i as u64));
        self.order.sort_unstable();
        for &key in &self.order {
            let i = key as u32 as usize;
            let c = &self.edges[i];
            for k in c.first_band..=self.last_bands[i] {
                self.entries[next[k as usize] as usize] = *c;
                self.keys[next[k as usize] as usize] = c.lo.x;
                next[k as usize] += 1;
                self.widths[k as usize] = self.widths[k as usize].max(c.hi.x as f64 - c.lo.x as f64);
            }
        }
        for width in &mut self.widths {
            // Rounded up, so that `lo.x < x − width` leaves `hi.x < x` whatever the roundings.
            *width = *width * (1.0 + 1e-9) + 1e-300;
        }
    }

    /// The band holding height `y`.
    fn band(&self, y: f64) -> u32 {
        band_of(self.per_pixel, self.bands, y)
    }

    /// The band list `k`, its entries' keys (`lo.x`), and the index of its first entry whose box
    /// may reach `x` or further right (every entry before it ends left of `x`).
    fn list(&self, k: u32, x: f64) -> (&[ContourEdge], &[f32], usize) {
        let range = self.offsets[k as usize] as usize..self.offsets[k as usize + 1] as usize;
        let (list, keys) = (&self.entries[range.clone()], &self.keys[range]);
        let bound = x - self.widths[k as usize];
        let bound = f32_at_or_above(bound - 1e-12 * bound.abs());
        (list, keys, keys.partition_point(|&key| key < bound))
    }

    /// What the visible parts of candidate edge `e` (`va → vb`, outward normal `outward`; its end
    /// points f32 screen coordinates, as the contour's, converted to f64) follow from, into
    /// `out`: the sums `(N₊, D)` just outside its start, each crossing with a contour edge (its
    /// parameter and the sums after it, in order), and the stretches that coincident edges
    /// ranking before `rank` take from it.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn trace(
        &self,
        screen: &[ScreenVertex],
        orientation: &[i8],
        topology: &Topology,
        e: u32,
        (va, vb, outward): (DVec2, DVec2, DVec2),
        rank: u32,
        out: &mut EdgeContour,
    ) {
        let d = vb - va;
        let (lo, hi) = (va.min(vb), va.max(vb));
        // The end points are f32 screen coordinates: so is the box, and comparing it with the
        // contour edges' f32 boxes in f32 is exact.
        let (lo32, hi32) = (lo.as_vec2(), hi.as_vec2());
        let (first, last, start_band) = (self.band(lo.y), self.band(hi.y), self.band(va.y));
        out.crossings.clear();
        out.yielded.clear();
        for k in first..=last {
            let (list, keys, reach) = self.list(k, lo.x);
            let end = keys.partition_point(|&key| key <= hi32.x);
            for c in &list[reach.min(end)..end] {
                // An edge listed in several of these bands is tested in the first one.
                if c.first_band.max(first) != k || c.hi.x < lo32.x || c.hi.y < lo32.y || c.lo.y > hi32.y {
                    continue;
                }
                let (ca, cb) = (c.a.as_dvec2(), c.b.as_dvec2());
                let (ha, hb) = ((ca - va).dot(outward), (cb - va).dot(outward));
                if (ha > 0.0) != (hb > 0.0) {
                    // It crosses the line just outside the edge (an end on the edge's line
                    // counts as inside); where, from the two ends' sides of its own line.
                    let u = cb - ca;
                    let (c0, c1) = (cross(u, ca - va), cross(u, ca - vb));
                    if (c0 > 0.0 && c1 < 0.0) || (c0 < 0.0 && c1 > 0.0) {
                        let dir = if c0 > 0.0 { 1 } else { -1 };
                        out.crossings.push((c0 / (c0 - c1), dir * c.positive, dir * c.net));
                    }
                } else if ha == 0.0 && hb == 0.0 && c.edge != e {
                    if let Some(stretch) = yielded_stretch(screen, orientation, topology, c, (va, d, outward), rank) {
                        out.yielded.push(stretch);
                    }
                }
            }
        }
        // The sums at the start: a ray cast to the left or to the right of it, whichever meets
        // fewer entries of its band.
        let (list, keys, reach) = self.list(start_band, va.x);
        let left = keys.partition_point(|&key| key <= va.x as f32);
        let (mut positive, mut net) = (0, 0);
        if left <= list.len() - reach {
            for c in &list[..left] {
                let chi = ray_crossing(c, va, d, outward, Ray::Left);
                positive -= chi * c.positive;
                net -= chi * c.net;
            }
        } else {
            for c in &list[reach..] {
                let chi = ray_crossing(c, va, d, outward, Ray::Right);
                positive += chi * c.positive;
                net += chi * c.net;
            }
        }
        out.start = (positive, net);
        out.crossings.sort_unstable_by(|x, y| x.0.total_cmp(&y.0));
        let (mut p, mut n) = out.start;
        for x in &mut out.crossings {
            p += x.1;
            n += x.2;
            (x.1, x.2) = (p, n);
        }
    }
}

/// A band list entry that is never read (the fill value of an empty list).
const EMPTY: ContourEdge = ContourEdge {
    a: Vec2::ZERO,
    b: Vec2::ZERO,
    lo: Vec2::ZERO,
    hi: Vec2::ZERO,
    positive: 0,
    net: 0,
    edge: u32::MAX,
    first_band: 0,
};

/// The band of `bands` (`per_pixel` per pixel) holding height `y`, the first for every `y`
/// above the image and the last for every one below it. Monotonic in `y`.
fn band_of(per_pixel: f64, bands: u32, y: f64) -> u32 {
    // Clamped first, then truncated: for a value in [0, bands − 1] truncation is the floor, and
    // a NaN gives band 0 either way. Branch-free (the counts of `build` call it twice per
    // contour edge and `trace` three times per candidate, at unpredictable heights).
    (y * per_pixel).max(0.0).min((bands - 1) as f64) as u32
}

/// The least f32 at or above `x`, so that `key < x` exactly when `key < f32_at_or_above(x)`
/// for every f32 `key`: the band searches then compare f32 keys without converting each to f64
/// (a conversion on the critical path of every probe). Infinite above `f32::MAX`; NaN for NaN.
#[inline]
fn f32_at_or_above(x: f64) -> f32 {
    let nearest = x as f32;
    if (nearest as f64) < x {
        nearest.next_up()
    } else {
        nearest
    }
}

/// A key whose unsigned order is the order of the f32 `x` (for every non-NaN `x`; `-0.0` before
/// `0.0`, which the band searches treat alike).
#[inline]
fn x_key(x: f32) -> u64 {
    let bits = x.to_bits();
    (if bits >> 31 == 1 { !bits } else { bits | 1 << 31 }) as u64
}

/// `u.x·v.y − u.y·v.x`.
#[inline]
fn cross(u: DVec2, v: DVec2) -> f64 {
    u.x * v.y - u.y * v.x
}

/// The sign of `x + δ·y + ε·z` for `0 < ε ≪ δ ≪ 1`.
#[inline]
fn sign3(x: f64, y: f64, z: f64) -> i32 {
    let v = if x != 0.0 {
        x
    } else if y != 0.0 {
        y
    } else {
        z
    };
    (v > 0.0) as i32 - (v < 0.0) as i32
}

/// Which way a ray from the start runs ([`ray_crossing`]).
#[derive(Clone, Copy, PartialEq, Eq)]
enum Ray {
    Left,
    Right,
}

/// The crossing count of contour edge `c` with the ray from `p = va + δ·d + ε·n` along its row.
/// To the right, `χ(c, p)`: `+1` when `c` runs downwards over `p`'s height (`a.y ≤ p.y < b.y`)
/// with `p` strictly left of it, `−1` when it runs upwards (`b.y ≤ p.y < a.y`) with `p` strictly
/// left of it, else 0; then `N = Σ w·χ` (the module's sums, as in the forward). To the left,
/// `χ′(c, p)`, the same with `p` strictly right of `c`: over a closed chain `Σ w·(χ + χ′) = 0`
/// (each crossing of `p`'s row lies on one side of `p`), so `N = −Σ w·χ′`.
#[inline]
fn ray_crossing(c: &ContourEdge, va: DVec2, d: DVec2, n: DVec2, ray: Ray) -> i32 {
    // Strictly above or below both ends, the point's perturbations change nothing: no crossing.
    // (`va` is an f32 screen point: the f32 comparison is exact.)
    let y = va.y as f32;
    if y < c.lo.y || y > c.hi.y {
        return 0;
    }
    let at_or_below = |y: f64| sign3(va.y - y, d.y, n.y) > 0;
    let (a_le, b_le) = (at_or_below(c.a.y as f64), at_or_below(c.b.y as f64));
    if a_le == b_le {
        return 0;
    }
    let (ca, cb) = (c.a.as_dvec2(), c.b.as_dvec2());
    let u = cb - ca;
    // > 0: p lies left of a downward edge, right of an upward one.
    // The δ and ε terms only where the exact one vanishes (a point on the contour edge's line).
    let exact = cross(u, va - ca);
    let side = if exact != 0.0 { sign3(exact, 0.0, 0.0) } else { sign3(0.0, cross(u, d), cross(u, n)) };
    let wanted = if a_le == (ray == Ray::Right) { side > 0 } else { side < 0 };
    if a_le {
        wanted as i32
    } else {
        -(wanted as i32)
    }
}

/// The stretch `[t(a), t(b)]` of the candidate `va + t·d` that contour edge `c`, lying on its
/// line, takes from it: when a face of `c` of non-zero orientation lies on the candidate's inside
/// and ranks before the candidate (`face < rank`). Faces on the outside cover the stretch
/// anyway (the sums count them).
fn yielded_stretch(
    screen: &[ScreenVertex],
    orientation: &[i8],
    topology: &Topology,
    c: &ContourEdge,
    (va, d, outward): (DVec2, DVec2, DVec2),
    rank: u32,
) -> Option<(f64, f64)> {
    let [a, b] = topology.edges()[c.edge as usize];
    let takes = topology.edge_faces(c.edge as usize).iter().any(|&f| {
        if f >= rank || orientation[f as usize] == 0 {
            return false;
        }
        let third = topology.triangles()[f as usize].into_iter().find(|&v| v != a && v != b);
        third.is_some_and(|v| {
            let p = screen[v as usize].position;
            (DVec2::new(p[0] as f64, p[1] as f64) - va).dot(outward) < 0.0
        })
    });
    if !takes {
        return None;
    }
    let dd = d.dot(d);
    let (ta, tb) = ((c.a.as_dvec2() - va).dot(d) / dd, (c.b.as_dvec2() - va).dot(d) / dd);
    Some((ta.min(tb), ta.max(tb)))
}

/// A candidate edge's contour, as [`ContourBands::trace`] finds it, and the buffers of its
/// segments' sweeps.
#[derive(Clone, Debug, Default)]
pub(super) struct EdgeContour {
    /// `(N₊, D)` just outside the start.
    start: (i32, i32),
    /// Each crossing's parameter and `(N₊, D)` just after it, in order.
    crossings: Vec<(f64, i32, i32)>,
    /// Stretches taken by coincident edges ranking first.
    yielded: Vec<(f64, f64)>,
    /// The covered intervals of one segment.
    intervals: Vec<(f64, f64)>,
}

/// Whether sums `(N₊, D)` say covered: `N₊ > 0` or `N₋ = N₊ − D > 0`.
#[inline]
fn covered((positive, net): (i32, i32)) -> bool {
    positive > 0 || positive - net > 0
}

impl EdgeContour {
    /// Endpoint weights `[∫(1 − s), ∫s]` over the visible part of the parameter interval `c`:
    /// where the sums say uncovered and no coincident edge ranking first takes the stretch.
    pub(super) fn visible_weights(&mut self, c: (f64, f64)) -> (f64, f64) {
        let k = self.crossings.partition_point(|x| x.0 <= c.0);
        let mut state = if k == 0 { self.start } else { (self.crossings[k - 1].1, self.crossings[k - 1].2) };
        let intervals = &mut self.intervals;
        intervals.clear();
        let mut open = covered(state).then_some(c.0);
        for &(t, p, n) in &self.crossings[k..] {
            if t >= c.1 {
                break;
            }
            state = (p, n);
            match (open, covered(state)) {
                (None, true) => open = Some(t),
                (Some(lo), false) => {
                    intervals.push((lo, t));
                    open = None;
                }
                _ => {}
            }
        }
        if let Some(lo) = open {
            intervals.push((lo, c.1));
        }
        if !self.yielded.is_empty() {
            intervals.extend(self.yielded.iter().map(|&(lo, hi)| (lo.max(c.0), hi.min(c.1))).filter(|x| x.1 > x.0));
            intervals.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.total_cmp(&y.1)));
        }
        let (mut visible_a, mut visible_b, mut cursor) = (0.0, 0.0, c.0);
        for &(lo, hi) in intervals.iter().chain(std::iter::once(&(c.1, c.1))) {
            if lo > cursor {
                let [ka, kb] = segment_weights(cursor, lo);
                visible_a += ka;
                visible_b += kb;
            }
            cursor = cursor.max(hi);
        }
        (visible_a, visible_b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`x_key`] orders f32 values as `<` does (and `-0.0` just before `0.0`).
    #[test]
    fn x_key_orders_as_the_floats() {
        let mut values = vec![f32::NEG_INFINITY, -3.5e30, -2.0, -1.0, -1e-40, -0.0, 0.0, 1e-40, 0.5, 1.0, 7e20];
        values.push(f32::MAX);
        values.push(f32::INFINITY);
        for pair in values.windows(2) {
            assert!(x_key(pair[0]) < x_key(pair[1]), "{} {}", pair[0], pair[1]);
        }
    }

    /// [`f32_at_or_above`] answers `key < x` for f32 keys as the f64 comparison does: `x`
    /// exactly an f32, halfway and just beside one, beyond f32's range, subnormal, ±0 and NaN,
    /// against the f32 values around it.
    #[test]
    fn f32_at_or_above_keeps_the_f64_comparison() {
        let mut rng = crate::random::SplitMix64::new(11);
        let mut xs: Vec<f64> = (0..3000).map(|_| rng.range(-1e3, 1e3) as f64 * 1.000_000_1).collect();
        for v in [1.0f32, -1.0, 0.1, 3.4e38, f32::MAX, f32::MIN_POSITIVE, f32::from_bits(1), 7.0e-3] {
            let v = v as f64;
            let half = (v.abs() * 2f64.powi(-24)).max(1e-46);
            xs.extend([v, -v, v + half, v - half, v + half * 0.5, v - half * 1.5, -v + half]);
        }
        xs.extend([0.0, -0.0, 1e39, -1e39, f64::MAX, -f64::MAX, f64::INFINITY, f64::NEG_INFINITY, f64::NAN]);
        xs.extend([f32::MAX as f64 * (1.0 + 1e-9), -(f32::MAX as f64) * (1.0 + 1e-9)]);
        for x in xs {
            let bound = f32_at_or_above(x);
            let near = x as f32;
            let keys =
                [near, near.next_up(), near.next_down(), near.next_up().next_up(), 0.0, -0.0, f32::MAX, -f32::MAX];
            for key in keys.into_iter().filter(|k| k.is_finite()) {
                assert_eq!(key < bound, (key as f64) < x, "key {key:e}, x {x:e}, bound {bound:e}");
            }
        }
    }

    /// [`band_of`] is the floor of `y · per_pixel` clamped to the bands, for heights inside,
    /// above and below the image, on band boundaries, and not finite.
    #[test]
    fn band_of_is_the_clamped_floor() {
        let mut rng = crate::random::SplitMix64::new(3);
        for (per_pixel, bands) in [(1.0, 16), (4.0, 256), (1.0 / 64.0, 1), (256.0, 65536)] {
            let mut heights: Vec<f64> = (0..2000).map(|_| rng.range(-40.0, 1200.0) as f64).collect();
            heights.extend((0..=bands + 1).map(|k| k as f64 / per_pixel));
            heights.extend([-0.0, -1e-300, 1e300, -1e300, f64::INFINITY, f64::NEG_INFINITY, f64::NAN]);
            for y in heights {
                let floor = (y * per_pixel).floor();
                let expected = if floor.is_nan() { 0 } else { floor.clamp(0.0, (bands - 1) as f64) as u32 };
                assert_eq!(band_of(per_pixel, bands, y), expected, "y = {y}, {bands} bands of {per_pixel} per pixel");
            }
        }
    }

    /// Each band lists exactly the contour edges whose heights meet it, in the order of `lo.x`
    /// (then of the contour's order), with their keys: triangle soups and meshes reaching far
    /// above and below the image.
    #[test]
    fn band_lists_hold_the_edges_meeting_each_band() {
        let mut rng = crate::random::SplitMix64::new(5);
        for case in 0..12 {
            let (n, height) = ([3, 50, 800][case % 3], [16u32, 64, 200][case / 3 % 3]);
            let h = height as f32;
            let screen: Vec<ScreenVertex> = (0..3 * n)
                .map(|_| ScreenVertex {
                    position: [rng.range(-10.0, 80.0), rng.range(-0.5 * h, 1.5 * h)],
                    valid: 1,
                    pad: 0,
                })
                .collect();
            let triangles = (0..n as u32).map(|k| [3 * k, 3 * k + 1, 3 * k + 2]).collect();
            let topology = Topology::new(3 * n, triangles).unwrap();
            let mut orientation = vec![0i8; n];
            crate::cpu::edges::face_orientations(&screen, topology.triangles(), &mut orientation);
            let mut candidates = Vec::new();
            crate::cpu::edges::edges(&orientation, &topology, &mut candidates);
            let mut bands = ContourBands::default();
            bands.build(&screen, &orientation, &topology, &candidates, height);
            assert!(!bands.edges.is_empty(), "case {case}: a contour");
            assert_eq!(bands.offsets.len(), bands.bands as usize + 1);
            for k in 0..bands.bands {
                let range = bands.offsets[k as usize] as usize..bands.offsets[k as usize + 1] as usize;
                let mut expected: Vec<(u64, usize)> = (0..bands.edges.len())
                    .filter(|&i| {
                        let c = &bands.edges[i];
                        let band = |y: f32| band_of(bands.per_pixel, bands.bands, y as f64);
                        band(c.lo.y) <= k && k <= band(c.hi.y)
                    })
                    .map(|i| (x_key(bands.edges[i].lo.x), i))
                    .collect();
                expected.sort();
                let listed: Vec<u32> = bands.entries[range.clone()].iter().map(|c| c.edge).collect();
                let expected_edges: Vec<u32> = expected.iter().map(|&(_, i)| bands.edges[i].edge).collect();
                assert_eq!(listed, expected_edges, "case {case}, band {k}");
                let keys: Vec<f32> = expected.iter().map(|&(_, i)| bands.edges[i].lo.x).collect();
                assert_eq!(&bands.keys[range], &keys[..], "case {case}, band {k}");
            }
        }
    }
}
