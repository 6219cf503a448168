//! Welding vertices by position: one vertex per position, as silhouettes need.

use std::collections::HashMap;

use glam::Vec3;

/// Merges vertices with exactly equal positions and remaps the triangles.
///
/// Deterministic: the output keeps the order of first occurrences (vertex k of the output is the
/// k-th distinct position met in `positions`), so an input without duplicates comes back
/// unchanged. `0.0` and `-0.0` count as equal. Triangles that become degenerate (an index
/// repeated) are kept: the renderer handles them. Unused vertices are kept. An index that is out
/// of range for `positions` becomes `u32::MAX`, which [`Mesh::new`](crate::Mesh::new) rejects.
pub fn weld_by_position(positions: &[Vec3], triangles: &[[u32; 3]]) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let (remap, kept) = weld_map(positions);
    let welded = kept.iter().map(|&i| positions[i]).collect();
    let triangles = triangles.iter().map(|t| t.map(|i| remap.get(i as usize).copied().unwrap_or(u32::MAX))).collect();
    (welded, triangles)
}

/// Welds exactly equal positions: `remap[i]` is the welded index of vertex `i`, `kept[k]` the first
/// vertex that became welded vertex `k` (first occurrences in order; `0.0` and `-0.0` weld).
pub(crate) fn weld_map(positions: &[Vec3]) -> (Vec<u32>, Vec<usize>) {
    let mut first: HashMap<[u32; 3], u32> = HashMap::with_capacity(positions.len());
    let mut kept = Vec::new();
    let remap = positions
        .iter()
        .enumerate()
        .map(|(i, p)| {
            // `+ 0.0` turns -0.0 into +0.0 so both weld; other values keep their bits.
            let key = [(p.x + 0.0).to_bits(), (p.y + 0.0).to_bits(), (p.z + 0.0).to_bits()];
            *first.entry(key).or_insert_with(|| {
                kept.push(i);
                (kept.len() - 1) as u32
            })
        })
        .collect();
    (remap, kept)
}
