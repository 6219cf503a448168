//! The triangles' boxes and vertex indices in the BVH's primitive order, one array per bound and
//! per corner (structure of arrays), so that the self-traversal tests one triangle against four
//! others in one go, without a branch per pair.

use glam::{BVec4A, Vec4};
use obvhs::aabb::Aabb;

/// The box lanes of four consecutive triangles ([`BoxLanes::group`]).
pub(super) struct Group {
    lo: [Vec4; 3],
    hi: [Vec4; 3],
    /// The first of the four.
    pub(super) first: usize,
}

/// Lanes past the last triangle, so that a group of four starting at any triangle can be loaded.
const PAD: usize = 3;

/// Per-coordinate bounds of the triangles' boxes, `lo[axis][k]` and `hi[axis][k]`, and their
/// vertex indices `corner[c][k]`, for the `k`-th triangle in the BVH's primitive order, with
/// [`PAD`] unused lanes at the end. The indices are held as `f32`, exact below 2²⁴ (where four
/// of them compare in one instruction); `indices` keeps them as integers for larger meshes.
#[derive(Clone, Debug, Default)]
pub(super) struct BoxLanes {
    lo: [Vec<f32>; 3],
    hi: [Vec<f32>; 3],
    corner: [Vec<f32>; 3],
    /// The triangles' vertex indices in the same order, read instead of `corner` when an index
    /// is 2²⁴ or more.
    indices: Vec<[u32; 3]>,
    /// Whether every index converts to `f32` exactly.
    exact: bool,
}

/// Indices below this convert to `f32` exactly (and distinct ones stay distinct).
const EXACT_INDEX: u32 = 1 << 24;

impl BoxLanes {
    /// Fills the vertex-index lanes with `triangles[order[k]]` (when the BVH, and so its
    /// primitive order, is built).
    pub(super) fn fill_triangles(&mut self, order: &[u32], triangles: &[[u32; 3]]) {
        self.indices.clear();
        self.indices.extend(order.iter().map(|&p| triangles[p as usize]));
        self.exact = self.indices.iter().flatten().all(|&v| v < EXACT_INDEX);
        for (c, corner) in self.corner.iter_mut().enumerate() {
            corner.clear();
            if self.exact {
                corner.extend(self.indices.iter().map(|t| t[c] as f32));
                // NaN equals nothing: the padding lanes share no vertex.
                corner.extend([f32::NAN; PAD]);
            }
        }
    }

    /// Fills the box lanes with `boxes[order[k]]` (at every check: the boxes move).
    pub(super) fn fill_boxes(&mut self, order: &[u32], boxes: &[Aabb]) {
        for axis in 0..3 {
            for (bounds, of) in [(&mut self.lo[axis], 0), (&mut self.hi[axis], 1)] {
                bounds.clear();
                bounds.extend(order.iter().map(|&p| {
                    let b = &boxes[p as usize];
                    if of == 0 {
                        b.min[axis]
                    } else {
                        b.max[axis]
                    }
                }));
                bounds.extend([0.0; PAD]);
            }
        }
    }

    /// The box lanes of triangles `first..first + 4`, loaded once for tests against many
    /// triangles ([`BoxLanes::group_overlaps`]).
    #[inline(always)]
    pub(super) fn group(&self, first: usize) -> Group {
        let load = |a: &[f32]| Vec4::from_slice(&a[first..first + 4]);
        Group {
            lo: [load(&self.lo[0]), load(&self.lo[1]), load(&self.lo[2])],
            hi: [load(&self.hi[0]), load(&self.hi[1]), load(&self.hi[2])],
            first,
        }
    }

    /// [`BoxLanes::overlaps`] of triangle `k` against a loaded group.
    #[inline(always)]
    pub(super) fn group_overlaps(&self, k: usize, group: &Group, count: usize) -> u32 {
        let one = |a: &[f32]| Vec4::splat(a[k]);
        let mut met = group.lo[0].cmple(one(&self.hi[0])) & one(&self.lo[0]).cmple(group.hi[0]);
        for axis in 1..3 {
            met &= group.lo[axis].cmple(one(&self.hi[axis])) & one(&self.lo[axis]).cmple(group.hi[axis]);
        }
        met.bitmask() & ((1u32 << count) - 1)
    }

    /// Bit `j` set when the box of triangle `k` overlaps (closed boxes: touching counts) that of
    /// triangle `first + j`, for `j` in `0..count` (`count` ≤ 4). The same comparisons as
    /// [`Aabb::intersect_aabb`] on finite boxes.
    #[inline(always)]
    pub(super) fn overlaps(&self, k: usize, first: usize, count: usize) -> u32 {
        let group = |a: &[f32]| Vec4::from_slice(&a[first..first + 4]);
        let one = |a: &[f32]| Vec4::splat(a[k]);
        let mut met = group(&self.lo[0]).cmple(one(&self.hi[0])) & one(&self.lo[0]).cmple(group(&self.hi[0]));
        for axis in 1..3 {
            met &= group(&self.lo[axis]).cmple(one(&self.hi[axis])) & one(&self.lo[axis]).cmple(group(&self.hi[axis]));
        }
        met.bitmask() & ((1u32 << count) - 1)
    }

    /// Bit `j` set when triangle `k` shares a vertex index with triangle `first + j`, for `j` in
    /// `0..4` (lanes past the last triangle share none).
    #[inline(always)]
    pub(super) fn shared(&self, k: usize, first: usize) -> u32 {
        if !self.exact {
            let own = &self.indices[k];
            let others = self.indices.get(first..).unwrap_or_default();
            return others
                .iter()
                .take(4)
                .enumerate()
                .fold(0, |bits, (j, t)| bits | ((own.iter().any(|v| t.contains(v)) as u32) << j));
        }
        let group = |c: usize| Vec4::from_slice(&self.corner[c][first..first + 4]);
        let (g0, g1, g2) = (group(0), group(1), group(2));
        let hit = self.corner.iter().fold(BVec4A::splat(false), |hit, corner| {
            let own = Vec4::splat(corner[k]);
            hit | g0.cmpeq(own) | g1.cmpeq(own) | g2.cmpeq(own)
        });
        hit.bitmask()
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3A;

    use super::*;
    use crate::random::SplitMix64;

    /// The four-wide test agrees with `Aabb::intersect_aabb` on random boxes, touching ones
    /// included, for every group start and length, and so does its test against a loaded group.
    #[test]
    fn overlaps_match_the_scalar_test() {
        let mut rng = SplitMix64::new(3);
        // Coordinates on a coarse grid, so that boxes often touch exactly.
        let mut coordinate = || (rng.range(0.0, 8.0) as i32) as f32 * 0.5;
        let boxes: Vec<Aabb> = (0..40)
            .map(|_| {
                let (a, b) = (
                    Vec3A::new(coordinate(), coordinate(), coordinate()),
                    Vec3A::new(coordinate(), coordinate(), coordinate()),
                );
                Aabb::new(a.min(b), a.max(b))
            })
            .collect();
        let order: Vec<u32> = (0..boxes.len() as u32).rev().collect();
        let mut lanes = BoxLanes::default();
        lanes.fill_boxes(&order, &boxes);
        let mut touching = 0;
        for k in 0..boxes.len() {
            for first in 0..boxes.len() {
                for count in 0..=4.min(boxes.len() - first) {
                    let bits = lanes.overlaps(k, first, count);
                    assert_eq!(lanes.group_overlaps(k, &lanes.group(first), count), bits, "a loaded group");
                    for j in 0..4 {
                        let expected =
                            j < count && boxes[order[k] as usize].intersect_aabb(&boxes[order[first + j] as usize]);
                        assert_eq!(bits & (1 << j) != 0, expected, "k {k}, first {first}, count {count}, lane {j}");
                    }
                }
            }
            let b = &boxes[order[k] as usize];
            touching += boxes.iter().filter(|o| o.min.x == b.max.x || o.max.x == b.min.x).count();
        }
        assert!(touching > 0, "the boxes should touch somewhere");
    }

    /// The four-wide shared-vertex test agrees with a pairwise one, for triangles that share
    /// one, two, three or no indices, in every corner; with small indices (compared as `f32`)
    /// and with indices from 2²⁴ up (compared as integers: as `f32`, 2²⁴ and 2²⁴ + 1 are equal).
    #[test]
    fn shared_matches_the_pairwise_test() {
        let mut rng = SplitMix64::new(9);
        let small: Vec<[u32; 3]> = (0..30).map(|_| [0; 3].map(|_| rng.range(0.0, 12.0) as u32)).collect();
        let large: Vec<[u32; 3]> = small.iter().map(|t| t.map(|v| EXACT_INDEX + v)).collect();
        for triangles in [small, large] {
            let order: Vec<u32> = (0..triangles.len() as u32).collect();
            let mut lanes = BoxLanes::default();
            lanes.fill_triangles(&order, &triangles);
            let (mut some, mut none) = (0, 0);
            for k in 0..triangles.len() {
                for first in 0..triangles.len() {
                    let bits = lanes.shared(k, first);
                    for j in 0..4 {
                        let expected = first + j < triangles.len()
                            && triangles[k].iter().any(|v| triangles[first + j].contains(v));
                        assert_eq!(bits & (1 << j) != 0, expected, "k {k}, first {first}, lane {j}");
                        if first + j < triangles.len() {
                            if expected {
                                some += 1;
                            } else {
                                none += 1;
                            }
                        }
                    }
                }
            }
            assert!(some > 0 && none > 0);
        }
    }
}
