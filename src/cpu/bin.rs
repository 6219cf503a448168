//! `bin` — CPU twin of `shaders/bin_count.wgsl` + `shaders/bin_fill.wgsl`: triangles → per-tile
//! lists (CSR) over a grid of `tile_size`-pixel tiles.
//!
//! A triangle is listed in every tile its snapped bounding box, grown by one fixed-point unit on
//! each side, overlaps. The margin makes the lists conservative for the float geometry as well,
//! so the `edge_grad` stage finds every triangle that can cover a point of a tile. Triangles with
//! a clipped vertex are not listed (they are culled); nor are those entirely off-screen.

use rayon::prelude::*;

use crate::layout::{RasterParams, ScreenVertex, INVALID_SNAPPED};

/// Per-tile triangle lists in CSR form.
#[derive(Clone, Debug, Default)]
pub struct Bins {
    /// `offsets[t]..offsets[t + 1]` indexes `triangles` for tile `t` (row-major tiles).
    pub offsets: Vec<u32>,
    /// Triangle indices, grouped by tile.
    pub triangles: Vec<u32>,
    /// The float bounding box `[xmin, ymin, xmax, ymax]` of each entry of `triangles`, beside it
    /// so the `edge_grad` stage scans a tile without touching vertices (a CPU-side cache; the
    /// WGSL stage reads the vertices).
    pub boxes: Vec<[f32; 4]>,
}

impl Bins {
    /// Entries `(triangle, bounding box)` of tile `t`.
    pub fn tile(&self, t: usize) -> impl Iterator<Item = (u32, &[f32; 4])> {
        let range = self.offsets[t] as usize..self.offsets[t + 1] as usize;
        self.triangles[range.clone()].iter().copied().zip(&self.boxes[range])
    }
}

/// Inclusive tile range `[tx0, ty0, tx1, ty1]` of a triangle, or `None` when it is culled or
/// entirely off-screen. Shared by the count and fill passes (as in WGSL).
pub fn triangle_tiles(params: &RasterParams, snapped: &[[i32; 2]], tri: [u32; 3]) -> Option<[u32; 4]> {
    let v = tri.map(|i| snapped[i as usize]);
    if v.contains(&INVALID_SNAPPED) {
        return None;
    }
    let units = params.units as i32;
    let span = |c: [i32; 3], size: u32| -> Option<(u32, u32)> {
        let lo = (c[0].min(c[1]).min(c[2]) - 1).div_euclid(units);
        let hi = (c[0].max(c[1]).max(c[2]) + 1).div_euclid(units);
        if hi < 0 || lo >= size as i32 {
            return None;
        }
        Some((lo.max(0) as u32 / params.tile_size, hi.min(size as i32 - 1) as u32 / params.tile_size))
    };
    let (tx0, tx1) = span(v.map(|p| p[0]), params.width)?;
    let (ty0, ty1) = span(v.map(|p| p[1]), params.height)?;
    Some([tx0, ty0, tx1, ty1])
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
            if v.contains(&INVALID_SNAPPED) {
                return None;
            }
            let extent = |k: usize| {
                let c = v.map(|p| p[k] as i64);
                c[0].max(c[1]).max(c[2]) - c[0].min(c[1]).min(c[2])
            };
            Some((extent(0).max(extent(1)).min(limit), 1u64))
        })
        .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    let mean = if count == 0 { 1.0 } else { sum as f64 / count as f64 / params.units as f64 };
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
    let ranges: Vec<Option<[u32; 4]>> =
        triangles.par_iter().with_min_len(4096).map(|&t| triangle_tiles(params, snapped, t)).collect();
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
    for (index, r) in ranges.iter().enumerate() {
        let Some(r) = r else { continue };
        let p = triangles[index].map(|v| screen[v as usize].position);
        let bbox = [
            p[0][0].min(p[1][0]).min(p[2][0]),
            p[0][1].min(p[1][1]).min(p[2][1]),
            p[0][0].max(p[1][0]).max(p[2][0]),
            p[0][1].max(p[1][1]).max(p[2][1]),
        ];
        for ty in r[1]..=r[3] {
            for tx in r[0]..=r[2] {
                let slot = &mut cursor[(ty * params.tiles_x + tx) as usize];
                bins.triangles[*slot as usize] = index as u32;
                bins.boxes[*slot as usize] = bbox;
                *slot += 1;
            }
        }
    }
    triangles.par_iter().with_min_len(4096).filter(|t| t.iter().any(|&i| screen[i as usize].valid == 0)).count() as u32
}
