//! `bin` — CPU twin of `shaders/bin_count.wgsl` + `shaders/bin_fill.wgsl`: triangles → per-tile
//! lists (CSR) over a grid of `tile_size`-pixel tiles.
//!
//! A triangle is listed in every tile its snapped bounding box, grown by one fixed-point unit on
//! each side, overlaps. The margin makes the lists conservative for the float geometry as well,
//! so the `edge_grad` stage finds every triangle that can cover a point of a tile. Triangles with
//! a clipped vertex are not listed (they are culled); nor are those entirely off-screen.

use crate::layout::{RasterParams, ScreenVertex};

/// Per-tile triangle lists in CSR form.
#[derive(Clone, Debug, Default)]
pub struct Bins {
    /// `offsets[t]..offsets[t + 1]` indexes `triangles` for tile `t` (row-major tiles).
    pub offsets: Vec<u32>,
    /// Triangle indices, grouped by tile.
    pub triangles: Vec<u32>,
}

impl Bins {
    /// Triangles listed in tile `t`.
    pub fn tile(&self, t: usize) -> &[u32] {
        &self.triangles[self.offsets[t] as usize..self.offsets[t + 1] as usize]
    }
}

/// Inclusive tile range `[tx0, ty0, tx1, ty1]` of a triangle, or `None` when it is culled or
/// entirely off-screen. Shared by the count and fill passes (as in WGSL).
pub fn triangle_tiles(params: &RasterParams, screen: &[ScreenVertex], tri: [u32; 3]) -> Option<[u32; 4]> {
    let v = tri.map(|i| screen[i as usize]);
    if v.iter().any(|s| s.valid == 0) {
        return None;
    }
    let xs = v.map(|s| params.snap(s.position[0]));
    let ys = v.map(|s| params.snap(s.position[1]));
    let units = params.units as i32;
    let span = |c: [i32; 3], size: u32| -> Option<(u32, u32)> {
        let lo = (c.iter().min().unwrap() - 1).div_euclid(units);
        let hi = (c.iter().max().unwrap() + 1).div_euclid(units);
        if hi < 0 || lo >= size as i32 {
            return None;
        }
        Some((lo.max(0) as u32 / params.tile_size, hi.min(size as i32 - 1) as u32 / params.tile_size))
    };
    let (tx0, tx1) = span(xs, params.width)?;
    let (ty0, ty1) = span(ys, params.height)?;
    Some([tx0, ty0, tx1, ty1])
}

/// Picks a tile side: a power of two near twice the mean on-screen triangle extent, 1 to 64 pixels,
/// so a triangle overlaps few tiles and a tile holds few triangles.
pub fn choose_tile_size(params: &RasterParams, screen: &[ScreenVertex], triangles: &[[u32; 3]]) -> u32 {
    let (mut sum, mut count) = (0.0f64, 0usize);
    for tri in triangles {
        let v = tri.map(|i| screen[i as usize]);
        if v.iter().any(|s| s.valid == 0) {
            continue;
        }
        let (mut lo, mut hi) = (v[0].position, v[0].position);
        for s in &v[1..] {
            for k in 0..2 {
                lo[k] = lo[k].min(s.position[k]);
                hi[k] = hi[k].max(s.position[k]);
            }
        }
        let extent = (hi[0] - lo[0]).max(hi[1] - lo[1]).min(params.width.max(params.height) as f32);
        sum += extent as f64;
        count += 1;
    }
    let mean = if count == 0 { 1.0 } else { sum / count as f64 };
    ((2.0 * mean).ceil().max(1.0) as u32).next_power_of_two().clamp(1, 64)
}

/// Fills `bins` with every listed triangle, in triangle order within each tile. Returns the number
/// of culled triangles (a vertex clipped by the camera).
pub fn bin(params: &RasterParams, screen: &[ScreenVertex], triangles: &[[u32; 3]], bins: &mut Bins) -> u32 {
    let tiles = params.tile_count();
    let ranges: Vec<Option<[u32; 4]>> = triangles.iter().map(|&t| triangle_tiles(params, screen, t)).collect();
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
    bins.triangles.clear();
    bins.triangles.resize(bins.offsets[tiles] as usize, 0);
    for (index, r) in ranges.iter().enumerate() {
        let Some(r) = r else { continue };
        for ty in r[1]..=r[3] {
            for tx in r[0]..=r[2] {
                let slot = &mut cursor[(ty * params.tiles_x + tx) as usize];
                bins.triangles[*slot as usize] = index as u32;
                *slot += 1;
            }
        }
    }
    triangles.iter().filter(|t| t.iter().any(|&i| screen[i as usize].valid == 0)).count() as u32
}
