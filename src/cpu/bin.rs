//! `bin` — CPU twin of `shaders/bin_count.wgsl` + `shaders/bin_fill.wgsl`: triangles → per-tile
//! lists (CSR) over a grid of `tile_size`-pixel tiles.
//!
//! A triangle is listed in every tile its snapped bounding box, grown by one fixed-point unit on
//! each side, overlaps. The margin makes the lists conservative for the float geometry as well,
//! so the WGSL `edge_grad` stage finds every triangle that can cover a point of a tile.
//! Triangles with a clipped vertex are not listed (they are culled); nor are those entirely
//! off-screen.
//!
//! The CPU pipeline builds no tile lists: its backward finds visibility from the view's contour
//! ([`edge_grad::contour`](super::edge_grad::contour)). [`bin`] builds them all, as the WGSL
//! stages do, for the tests (the triangle reference of `edge_grad`'s); the CPU forward takes
//! the tile size from [`tile_size`].

use rayon::prelude::*;

use crate::mirror::{RasterParams, ScreenVertex, INVALID_SNAPPED_VERTEX};

/// Per-tile triangle lists in CSR form.
#[derive(Clone, Debug, Default)]
pub struct Bins {
    /// `offsets[t]..offsets[t + 1]` indexes `triangles` for tile `t` (row-major tiles).
    pub offsets: Vec<u32>,
    /// Triangle indices, grouped by tile.
    pub triangles: Vec<u32>,
    /// The float bounding box of each entry of `triangles` as `[xmin, ymin, −xmax, −ymax]` (so
    /// that one four-lane `>` tells that it misses a box), beside it so that a scan of a tile's
    /// list (the triangle reference of the `edge_grad` tests) does not touch the vertices (a
    /// CPU-side cache; the WGSL stage reads the vertices).
    pub boxes: Vec<[f32; 4]>,
    /// The screen positions of each entry's vertices (a CPU-side cache, like `boxes`).
    pub vertices: Vec<[[f32; 2]; 3]>,
}

impl Bins {
    /// Entries `(triangle, box, vertices)` of tile `t`.
    pub fn tile(&self, t: usize) -> impl Iterator<Item = (u32, &[f32; 4], &[[f32; 2]; 3])> {
        let range = self.offsets[t] as usize..self.offsets[t + 1] as usize;
        self.triangles[range.clone()]
            .iter()
            .copied()
            .zip(&self.boxes[range.clone()])
            .zip(&self.vertices[range])
            .map(|((t, b), v)| (t, b, v))
    }
}

/// Inclusive tile range `[tx0, ty0, tx1, ty1]` of a triangle, or `None` when it is culled or
/// entirely off-screen. Shared by the count and fill passes (as in WGSL).
pub fn triangle_tiles(params: &RasterParams, snapped: &[[i32; 2]], tri: [u32; 3]) -> Option<[u32; 4]> {
    TileRange::new(params).of(snapped, tri)
}

/// The snapped bounding box `[xmin, ymin, xmax, ymax]` (fixed-point units) of a triangle whose
/// vertices are all valid; a culled triangle (a clipped vertex) gets this, which no tile range
/// meets.
pub const CULLED_BOX: [i32; 4] = [i32::MAX, i32::MAX, i32::MIN, i32::MIN];

/// Every triangle's snapped bounding box `[xmin, ymin, xmax, ymax]`, or [`CULLED_BOX`] when a
/// vertex is clipped (what [`draw_triangles`](super::coverage::draw_triangles) writes on its way).
pub fn snapped_boxes(snapped: &[[i32; 2]], triangles: &[[u32; 3]]) -> Vec<[i32; 4]> {
    triangles
        .iter()
        .map(|tri| {
            let v = tri.map(|i| snapped[i as usize]);
            if v.contains(&INVALID_SNAPPED_VERTEX) {
                return CULLED_BOX;
            }
            [
                v[0][0].min(v[1][0]).min(v[2][0]),
                v[0][1].min(v[1][1]).min(v[2][1]),
                v[0][0].max(v[1][0]).max(v[2][0]),
                v[0][1].max(v[1][1]).max(v[2][1]),
            ]
        })
        .collect()
}

/// [`triangle_tiles`] with its divisions prepared once (shifts when the tile side in fixed-point
/// units is a power of two, as it is for F = 1, 2, 4, 8, 16).
#[derive(Clone, Copy, Debug)]
struct TileRange {
    /// Image width and height in fixed-point units.
    limit: [i64; 2],
    /// Fixed-point units per tile side.
    tile_units: u64,
    /// `log2(tile_units)` when it is a power of two.
    shift: Option<u32>,
    /// Last tile column and row.
    last: [u32; 2],
}

impl TileRange {
    fn new(params: &RasterParams) -> TileRange {
        let tile_units = params.units as u64 * params.tile_size as u64;
        TileRange {
            limit: [params.width as i64 * params.units as i64, params.height as i64 * params.units as i64],
            tile_units,
            shift: tile_units.is_power_of_two().then(|| tile_units.trailing_zeros()),
            last: [params.tiles_x - 1, params.tiles_y - 1],
        }
    }

    /// `⌊n / tile_units⌋` for `n ≥ 0`.
    #[inline(always)]
    fn tile(&self, n: i64) -> u32 {
        match self.shift {
            Some(shift) => (n as u64 >> shift) as u32,
            None => (n as u64 / self.tile_units) as u32,
        }
    }

    /// The tile range of `tri`: the pixels `⌊(min − 1)/units⌋ ..= ⌊(max + 1)/units⌋` clamped to
    /// the image, divided by the tile side (`⌊⌊a/b⌋/c⌋ = ⌊a/(b·c)⌋`).
    #[inline(always)]
    fn of(&self, snapped: &[[i32; 2]], tri: [u32; 3]) -> Option<[u32; 4]> {
        let [a, b, c] = tri.map(|i| snapped[i as usize]);
        // A clipped vertex is INVALID_SNAPPED_VERTEX; valid coordinates are within ±2^29.
        if a[0] == INVALID_SNAPPED_VERTEX[0] || b[0] == INVALID_SNAPPED_VERTEX[0] || c[0] == INVALID_SNAPPED_VERTEX[0] {
            return None;
        }
        let lo = [a[0].min(b[0]).min(c[0]) as i64 - 1, a[1].min(b[1]).min(c[1]) as i64 - 1];
        let hi = [a[0].max(b[0]).max(c[0]) as i64 + 1, a[1].max(b[1]).max(c[1]) as i64 + 1];
        if hi[0] < 0 || hi[1] < 0 || lo[0] >= self.limit[0] || lo[1] >= self.limit[1] {
            return None;
        }
        Some([
            self.tile(lo[0].max(0)),
            self.tile(lo[1].max(0)),
            self.tile(hi[0]).min(self.last[0]),
            self.tile(hi[1]).min(self.last[1]),
        ])
    }
}

/// Picks a tile side: a power of two near twice the mean on-screen triangle extent, 1 to 64 pixels,
/// so a triangle overlaps few tiles and a tile holds few triangles.
pub fn choose_tile_size(params: &RasterParams, snapped: &[[i32; 2]], triangles: &[[u32; 3]]) -> u32 {
    let limit = params.width.max(params.height) as i64 * params.units as i64;
    let (sum, count) = triangles
        .par_iter()
        .with_min_len(4096)
        .filter_map(|tri| {
            let v = tri.map(|i| snapped[i as usize]);
            if v.contains(&INVALID_SNAPPED_VERTEX) {
                return None;
            }
            let extent = |k: usize| {
                let c = v.map(|p| p[k] as i64);
                c[0].max(c[1]).max(c[2]) - c[0].min(c[1]).min(c[2])
            };
            Some((extent(0).max(extent(1)).min(limit) as u64, 1u64))
        })
        .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    tile_size(params, sum, count)
}

/// The tile side [`choose_tile_size`] picks from the sum of the capped extents (units) of the
/// `count` non-culled triangles (which the CPU `coverage` pass adds up on its way,
/// [`TriangleSummary`](super::coverage::TriangleSummary)).
pub fn tile_size(params: &RasterParams, extent_sum: u64, count: u64) -> u32 {
    let mean = if count == 0 { 1.0 } else { extent_sum as f64 / count as f64 / params.units as f64 };
    ((2.0 * mean).ceil().max(1.0) as u32).next_power_of_two().clamp(1, 64)
}

/// Fills `bins` with every listed triangle, in triangle order within each tile. Returns the number
/// of culled triangles (a vertex clipped by the camera).
pub fn bin(
    params: &RasterParams,
    screen: &[ScreenVertex],
    snapped: &[[i32; 2]],
    triangles: &[[u32; 3]],
    bins: &mut Bins,
) -> u32 {
    let tiles = params.tile_count();
    let range = TileRange::new(params);
    let ranges: Vec<Option<[u32; 4]>> =
        triangles.par_iter().with_min_len(4096).map(|&t| range.of(snapped, t)).collect();
    bins.offsets.clear();
    bins.offsets.resize(tiles + 1, 0);
    for r in ranges.iter().flatten() {
        for ty in r[1]..=r[3] {
            for tx in r[0]..=r[2] {
                bins.offsets[(ty * params.tiles_x + tx) as usize + 1] += 1;
            }
        }
    }
    for t in 0..tiles {
        bins.offsets[t + 1] += bins.offsets[t];
    }
    let mut cursor = bins.offsets.clone();
    let entries = bins.offsets[tiles] as usize;
    bins.triangles.clear();
    bins.triangles.resize(entries, 0);
    bins.boxes.clear();
    bins.boxes.resize(entries, [0.0; 4]);
    bins.vertices.clear();
    bins.vertices.resize(entries, [[0.0; 2]; 3]);
    for (index, r) in ranges.iter().enumerate() {
        let Some(r) = r else { continue };
        let (bbox, vertices) = float_box(screen, triangles[index]);
        for ty in r[1]..=r[3] {
            for tx in r[0]..=r[2] {
                let slot = &mut cursor[(ty * params.tiles_x + tx) as usize];
                bins.triangles[*slot as usize] = index as u32;
                bins.boxes[*slot as usize] = bbox;
                bins.vertices[*slot as usize] = vertices;
                *slot += 1;
            }
        }
    }
    culled_triangles(screen, triangles)
}

/// Number of triangles culled because a vertex was clipped by the camera.
pub fn culled_triangles(screen: &[ScreenVertex], triangles: &[[u32; 3]]) -> u32 {
    triangles.par_iter().with_min_len(4096).filter(|t| t.iter().any(|&i| screen[i as usize].valid == 0)).count() as u32
}

/// Float bounding box `[xmin, ymin, −xmax, −ymax]` of a triangle, and its vertex positions.
///
/// With plain comparisons rather than `f32::min`/`max` (which handle NaN at a cost): the positions
/// of valid vertices are finite, and where the two differ, on `-0.0` against `+0.0`, the box
/// tests of `edge_grad` (`>` against finite bounds) give the same answer.
fn float_box(screen: &[ScreenVertex], tri: [u32; 3]) -> ([f32; 4], [[f32; 2]; 3]) {
    let p = tri.map(|v| screen[v as usize].position);
    let min = |a: f32, b: f32| if b < a { b } else { a };
    let max = |a: f32, b: f32| if b > a { b } else { a };
    let bbox = [
        min(min(p[0][0], p[1][0]), p[2][0]),
        min(min(p[0][1], p[1][1]), p[2][1]),
        -max(max(p[0][0], p[1][0]), p[2][0]),
        -max(max(p[0][1], p[1][1]), p[2][1]),
    ];
    (bbox, p)
}

#[cfg(test)]
mod tests;
