//! `bin` — CPU twin of `shaders/bin_count.wgsl` + `shaders/bin_fill.wgsl`: triangles → per-tile
//! lists (CSR) over a grid of `tile_size`-pixel tiles.
//!
//! A triangle is listed in every tile its snapped bounding box, grown by one fixed-point unit on
//! each side, overlaps. The margin makes the lists conservative for the float geometry as well,
//! so the `edge_grad` stage finds every triangle that can cover a point of a tile. Triangles with
//! a clipped vertex are not listed (they are culled); nor are those entirely off-screen.
//!
//! The CPU pipeline itself builds lists only for the tiles its backward needs ([`bin_tiles`]);
//! [`bin`] builds them all, as the WGSL stages do.

use rayon::prelude::*;

use crate::mirror::{RasterParams, ScreenVertex, INVALID_SNAPPED_VERTEX};
use crate::scene::mesh::Topology;
use crate::scene::patches::FacePatches;

mod back_faces;
pub use back_faces::{back_face_boundary, BackFaces};

/// Per-tile triangle lists in CSR form.
#[derive(Clone, Debug, Default)]
pub struct Bins {
    /// `offsets[t]..offsets[t + 1]` indexes `triangles` for tile `t` (row-major tiles).
    pub offsets: Vec<u32>,
    /// Triangle indices, grouped by tile.
    pub triangles: Vec<u32>,
    /// The float bounding box of each entry of `triangles` as `[xmin, ymin, −xmax, −ymax]` (so
    /// that one four-lane `>` tells that it misses a box), beside it so the `edge_grad` stage
    /// scans a tile without touching vertices (a CPU-side cache; the WGSL stage reads the
    /// vertices).
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
/// vertex is clipped: what the CPU `coverage` pass writes on its way, and what [`bin_tiles`]
/// reads.
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
    /// Tiles per row.
    tiles_x: usize,
}

impl TileRange {
    fn new(params: &RasterParams) -> TileRange {
        TileRange::of_grid(params, CellGrid::tiles(params))
    }

    /// The ranges over the cells of `grid` rather than the tiles.
    fn of_grid(params: &RasterParams, grid: CellGrid) -> TileRange {
        let tile_units = grid.cell_units as u64;
        TileRange {
            limit: [params.width as i64 * params.units as i64, params.height as i64 * params.units as i64],
            tile_units,
            shift: tile_units.is_power_of_two().then(|| tile_units.trailing_zeros()),
            last: [grid.cells_x - 1, grid.cells_y - 1],
            tiles_x: grid.cells_x as usize,
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

/// A grid of square cells over the image, `cell_units` fixed-point units on a side, for the CPU
/// backward's occluder lists ([`bin_tiles`]). The tiles of [`RasterParams::tile_size`] are one
/// such grid ([`CellGrid::tiles`]); the CPU backward uses finer cells when the triangles are
/// smaller than a pixel ([`CellGrid::for_extent`]), so that a segment's occluder scan reads the
/// few triangles near it instead of every triangle of its pixel. Which grid lists the occluders
/// does not change the result: any list that holds every triangle whose box meets a segment's
/// box gives the same intervals.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CellGrid {
    /// Cell side, fixed-point units.
    pub cell_units: u32,
    /// Cells per row.
    pub cells_x: u32,
    /// Cell rows.
    pub cells_y: u32,
}

impl CellGrid {
    /// Most cells in a grid of [`CellGrid::for_extent`] (coarser cells beyond).
    pub const MAX_CELLS: u64 = 1 << 22;

    /// The grid of `cell_units`-unit cells over the image of `params`.
    pub fn new(params: &RasterParams, cell_units: u32) -> CellGrid {
        let cells = |pixels: u32| (pixels as u64 * params.units as u64).div_ceil(cell_units as u64) as u32;
        CellGrid { cell_units, cells_x: cells(params.width), cells_y: cells(params.height) }
    }

    /// The grid of the tiles of `params` (`tile_size` pixels on a side).
    pub fn tiles(params: &RasterParams) -> CellGrid {
        CellGrid { cell_units: params.units * params.tile_size, cells_x: params.tiles_x, cells_y: params.tiles_y }
    }

    /// Cells one to two mean snapped extents of the `count` non-culled triangles on a side (the
    /// sum of their capped extents is `extent_sum` units, as for [`tile_size`]): the power of two
    /// at or above the mean, at least 1/16 pixel (one unit for F < 4), at most a tile, and no
    /// more than [`CellGrid::MAX_CELLS`] cells.
    ///
    /// A segment's occluder scan reads every entry of its cells' lists, so smaller cells mean
    /// shorter scans, while a triangle is listed in more cells. At one to two extents a triangle
    /// meets two or three cells per axis; twice that size doubled the entries a segment scans on a
    /// 7k-vertex body at 64² (whose silhouette crosses many triangles) and saved nothing on the
    /// bunny; half of it cost more in listing than it saved in scanning on the bunny.
    pub fn for_extent(params: &RasterParams, extent_sum: u64, count: u64) -> CellGrid {
        let tile_units = params.units * params.tile_size;
        let mean = if count == 0 { tile_units as f64 } else { extent_sum as f64 / count as f64 };
        let floor = (params.units / 16).max(1);
        let mut units = (mean.ceil().max(1.0).min(tile_units as f64) as u32).next_power_of_two();
        units = units.clamp(floor, tile_units);
        loop {
            let grid = CellGrid::new(params, units);
            if units >= tile_units || grid.count() as u64 <= Self::MAX_CELLS {
                return if units >= tile_units { CellGrid::tiles(params) } else { grid };
            }
            units *= 2;
        }
    }

    /// Number of cells.
    pub fn count(&self) -> usize {
        self.cells_x as usize * self.cells_y as usize
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

/// `⌊n / tile side in units⌋`, as a shift or a division (so that the loop of [`tile_pairs`] is
/// compiled once for each, without a branch per triangle).
trait TileDiv: Copy {
    fn div(self, n: u64) -> usize;
}

/// Division by a power of two.
#[derive(Clone, Copy)]
struct Shift(u32);

impl TileDiv for Shift {
    #[inline(always)]
    fn div(self, n: u64) -> usize {
        (n >> self.0) as usize
    }
}

/// Division by any positive number.
#[derive(Clone, Copy)]
struct Divide(u64);

impl TileDiv for Divide {
    #[inline(always)]
    fn div(self, n: u64) -> usize {
        (n / self.0) as usize
    }
}

/// The cells `[x0, x1, y0, y1]` (inclusive) that the snapped box `b`, grown by one unit on each
/// side, meets ([`triangle_tiles`] from the box, computed with `div`), or `None` when it meets
/// none (off the image, or [`CULLED_BOX`], whose `x1` is negative).
#[inline(always)]
fn grown_cells<D: TileDiv>(div: D, range: &TileRange, b: &[i32; 4]) -> Option<[usize; 4]> {
    let (x0, y0) = (b[0] as i64 - 1, b[1] as i64 - 1);
    let (x1, y1) = (b[2] as i64 + 1, b[3] as i64 + 1);
    if x1 < 0 || y1 < 0 || x0 >= range.limit[0] || y0 >= range.limit[1] {
        return None;
    }
    let (last_x, last_y) = (range.last[0] as usize, range.last[1] as usize);
    Some([
        div.div(x0.max(0) as u64),
        div.div(x1 as u64).min(last_x),
        div.div(y0.max(0) as u64),
        div.div(y1 as u64).min(last_y),
    ])
}

/// Appends `(slots[c], triangle)` for each wanted cell `c` that the grown box `b` meets.
#[inline(always)]
fn box_pairs<D: TileDiv>(
    div: D,
    range: &TileRange,
    slots: &[u32],
    b: &[i32; 4],
    triangle: u32,
    pairs: &mut Vec<(u32, u32)>,
) {
    let Some([tx0, tx1, ty0, ty1]) = grown_cells(div, range, b) else { return };
    let tiles_x = range.tiles_x;
    for ty in ty0..=ty1 {
        for &slot in &slots[ty * tiles_x + tx0..=ty * tiles_x + tx1] {
            if slot != u32::MAX {
                pairs.push((slot, triangle));
            }
        }
    }
}

/// Whether the grown box `b` meets a wanted cell.
#[inline(always)]
fn meets_wanted<D: TileDiv>(div: D, range: &TileRange, slots: &[u32], b: &[i32; 4]) -> bool {
    let Some([tx0, tx1, ty0, ty1]) = grown_cells(div, range, b) else { return false };
    let tiles_x = range.tiles_x;
    (ty0..=ty1).any(|ty| slots[ty * tiles_x + tx0..=ty * tiles_x + tx1].iter().any(|&slot| slot != u32::MAX))
}

/// Appends the `(slots[c], triangle)` pairs of the patches `first..end` of `patches`, patch after
/// patch, each patch's in its face order: a patch whose faces' boxes together (their union) meet
/// no wanted cell has none, and is passed over after one test. The pairs of a triangle of
/// positive on-screen area (`orientation` 1) carry [`POSITIVE`] in their triangle index.
/// A negative triangle that `back_faces` leaves out ([`BackFaces::leaves_out`]) has none.
#[allow(clippy::too_many_arguments)]
fn patch_pairs<D: TileDiv>(
    div: D,
    range: &TileRange,
    slots: &[u32],
    (boxes, orientation): (&[[i32; 4]], &[i8]),
    back_faces: Option<BackFaces>,
    patches: &FacePatches,
    (first, end): (usize, usize),
    pairs: &mut Vec<(u32, u32)>,
) {
    for p in first..end {
        let faces = patches.patch(p);
        // CULLED_BOX is the union's identity.
        let union = faces.iter().fold(CULLED_BOX, |u, &t| {
            let b = &boxes[t as usize];
            [u[0].min(b[0]), u[1].min(b[1]), u[2].max(b[2]), u[3].max(b[3])]
        });
        if !meets_wanted(div, range, slots, &union) {
            continue;
        }
        for &t in faces {
            let (o, b) = (orientation[t as usize], &boxes[t as usize]);
            if o < 0 && back_faces.is_some_and(|back| back.leaves_out(t, b)) {
                continue;
            }
            let tagged = t | if o > 0 { POSITIVE } else { 0 };
            box_pairs(div, range, slots, b, tagged, pairs);
        }
    }
}

/// The bit of a pair's triangle index in [`patch_pairs`] that marks a triangle of positive
/// on-screen area (free: a topology has fewer than 2³⁰ triangles).
const POSITIVE: u32 = 1 << 31;

/// Entries of the occluder lists per parallel task of [`bin_tiles`]' fill.
const ENTRIES_PER_TASK: usize = 4096;

/// Face patches per parallel task of [`bin_tiles`] (about 10k triangles).
const PATCHES_PER_TASK: usize = 512;

/// The occluder lists of [`bin_tiles`] and the buffers that build them, kept from call to call
/// so that a loop of backward passes does not allocate them again.
#[derive(Clone, Debug, Default)]
pub struct CellBins {
    /// The lists: `bins.tile(slot)` is the list of the cell numbered `slot`.
    pub bins: Bins,
    /// `(list, triangle)` pairs of each parallel task.
    pairs: Vec<Vec<(u32, u32)>>,
    /// Write positions of the counting sort, one per list: the next entry of a triangle of
    /// positive area (filled from the front).
    cursor: Vec<u32>,
    /// One past the last free entry of each list, for the other triangles (filled from the back).
    back: Vec<u32>,
}

/// The lists of [`bin`] for some cells of `grid` only (its tiles with [`CellGrid::tiles`]): cell
/// `t` (row-major) is wanted when `slots[t] != u32::MAX`, and its list is `out.bins.tile(slots[t])`
/// (`0..lists`), which holds the same triangles as [`bin`]'s list: first those of positive
/// on-screen area in the order of the topology's face patches ([`Topology::face_patches`]),
/// then the others in the reverse of that order; with `back_faces`, less the negative triangles
/// it leaves out ([`BackFaces`]: they cover no point the listed ones do not). Used by the
/// CPU backward, which needs lists only where silhouette segments with a non-zero incoming
/// gradient lie. `out`'s buffers are refilled (allocated only where they must grow).
///
/// Why that order: a segment's scan stops as soon as its occluders cover it (most segments of a
/// body are hidden), and the triangles of one orientation alone cover every point that the others
/// do, away from the mesh's boundary (the identity behind [`BackFaceSkip`](super::coverage::BackFaceSkip)).
/// A hidden segment's cover is then found among the first half of its list. The order changes
/// no result: a scan's intervals are kept sorted, and its early stop needs only the whole
/// segment covered.
///
/// Reads the triangles' snapped boxes (`faces.0`, one per triangle, as [`snapped_boxes`] gives
/// them and the CPU `coverage` pass writes them) rather than their snapped vertices, and their
/// orientations (`faces.1`, as [`face_orientations`](super::edges::face_orientations) gives
/// them: positive on-screen area is 1), patch by patch
/// in parallel over runs of patches: the union of a patch's boxes first, and its faces' boxes
/// only when that union meets a wanted cell (a patch is a small connected piece of the surface,
/// so away from the silhouette most patches are passed over after that one test). Then one
/// counting sort of the triangle indices by list, filling each list from both ends, and each
/// entry's float box and vertices in parallel.
#[allow(clippy::too_many_arguments)]
pub fn bin_tiles(
    params: &RasterParams,
    grid: CellGrid,
    screen: &[ScreenVertex],
    topology: &Topology,
    faces: (&[[i32; 4]], &[i8]),
    back_faces: Option<BackFaces>,
    slots: &[u32],
    lists: usize,
    out: &mut CellBins,
) {
    let range = TileRange::of_grid(params, grid);
    let triangles = topology.triangles();
    let patches = topology.face_patches();
    let CellBins { bins, pairs, cursor, back } = out;
    bins.offsets.clear();
    bins.offsets.resize(lists + 1, 0);
    bins.triangles.clear();
    bins.boxes.clear();
    bins.vertices.clear();
    if lists == 0 {
        return;
    }
    let tasks = patches.len().div_ceil(PATCHES_PER_TASK);
    pairs.resize_with(tasks, Vec::new);
    pairs[..tasks].par_iter_mut().enumerate().for_each(|(task, pairs)| {
        pairs.clear();
        let run = (task * PATCHES_PER_TASK, ((task + 1) * PATCHES_PER_TASK).min(patches.len()));
        match range.shift {
            Some(shift) => patch_pairs(Shift(shift), &range, slots, faces, back_faces, patches, run, pairs),
            None => patch_pairs(Divide(range.tile_units), &range, slots, faces, back_faces, patches, run, pairs),
        }
    });
    let parts = &pairs[..tasks];
    for &(slot, _) in parts.iter().flatten() {
        bins.offsets[slot as usize + 1] += 1;
    }
    for t in 0..lists {
        bins.offsets[t + 1] += bins.offsets[t];
    }
    let entries = bins.offsets[lists] as usize;
    cursor.clear();
    cursor.extend_from_slice(&bins.offsets[..lists]);
    back.clear();
    back.extend_from_slice(&bins.offsets[1..]);
    bins.triangles.resize(entries, 0);
    for &(slot, t) in parts.iter().flatten() {
        let at = if t & POSITIVE != 0 {
            let c = &mut cursor[slot as usize];
            *c += 1;
            *c - 1
        } else {
            let c = &mut back[slot as usize];
            *c -= 1;
            *c
        } as usize;
        bins.triangles[at] = t & !POSITIVE;
    }
    // Each entry's float box and vertices, in parallel.
    bins.boxes.resize(entries, [0.0; 4]);
    bins.vertices.resize(entries, [[0.0; 2]; 3]);
    bins.boxes
        .par_chunks_mut(ENTRIES_PER_TASK)
        .zip(bins.vertices.par_chunks_mut(ENTRIES_PER_TASK))
        .zip(bins.triangles.par_chunks(ENTRIES_PER_TASK))
        .for_each(|((boxes, vertices), listed)| {
            for ((bbox, v), &t) in boxes.iter_mut().zip(vertices).zip(listed) {
                (*bbox, *v) = float_box(screen, triangles[t as usize]);
            }
        });
}

#[cfg(test)]
mod tests;
