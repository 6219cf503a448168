//! The crossing triangle pairs: a simultaneous descent of the BVH against itself, the
//! shared-vertex filter and the exact test on what remains.

use super::checker::SelfIntersectionChecker;
use super::contact::{contact_f64, TriangleContact};
use super::RebuildPolicy;

impl SelfIntersectionChecker {
    /// Self-traversal of the BVH, shared-vertex filter, exact test.
    pub(super) fn find_crossing_pairs(&mut self) {
        let mut work = self.traverse();
        if let RebuildPolicy::Refit { factor } = self.policy {
            if self.baseline_work == 0 {
                self.baseline_work = work.max(1);
            } else if work as f64 > factor.max(1.0) as f64 * self.baseline_work as f64 {
                self.rebuild_bvh();
                work = self.traverse();
                self.baseline_work = work.max(1);
            }
        }
        self.pairs.sort_unstable();
    }

    /// Fills `self.pairs` with the crossing pairs; returns the number of node pairs visited.
    fn traverse(&mut self) -> usize {
        self.pairs.clear();
        self.candidates.clear();
        let Some(bvh) = &self.bvh else { return 0 };
        let nodes = &bvh.nodes;
        if nodes.is_empty() {
            return 0;
        }
        let prims = &bvh.primitive_indices;
        // Boxes in the BVH's primitive order (the triangles were laid out so when it was built):
        // a leaf's primitives are contiguous.
        self.lanes.fill_boxes(prims, &self.aabbs);
        let lanes = &self.lanes;
        let candidates = &mut self.candidates;
        // Hot path: a leaf's triangles against a leaf's, four at a time: the boxes that meet,
        // less the neighbours (a shared vertex), as a bit mask `met` over the four triangles from
        // `first`, each set bit a candidate pair with `k`; exact tests come after, on the few left.
        let push = |candidates: &mut Vec<[u32; 2]>, k: u32, first: u32, mut met: u32| {
            while met != 0 {
                candidates.push([k, first + met.trailing_zeros()]);
                met &= met - 1;
            }
        };
        let half_areas = &mut self.half_areas;
        half_areas.clear();
        half_areas.extend(nodes.iter().map(|n| n.aabb().half_area()));
        let half_areas = &*half_areas;
        let stack = &mut self.stack;
        stack.clear();
        stack.push((0, 0));
        let mut work = 0usize;
        while let Some((a, b)) = stack.pop() {
            work += 1;
            let (na, nb) = (&nodes[a as usize], &nodes[b as usize]);
            if a == b {
                if na.is_leaf() {
                    let end = na.first_index + na.prim_count;
                    for k in na.first_index..end {
                        for first in (k + 1..end).step_by(4) {
                            let lanes_left = (end - first).min(4) as usize;
                            let met = lanes.overlaps(k as usize, first as usize, lanes_left)
                                & !lanes.shared(k as usize, first as usize);
                            push(candidates, k, first, met);
                        }
                    }
                } else {
                    let (l, r) = (na.first_index, na.first_index + 1);
                    stack.push((l, l));
                    stack.push((r, r));
                    if nodes[l as usize].aabb().intersect_aabb(nodes[r as usize].aabb()) {
                        stack.push((l, r));
                    }
                }
                continue;
            }
            match (na.is_leaf(), nb.is_leaf()) {
                (true, true) => {
                    // Group by group of the second leaf, each loaded once for all of the first's
                    // triangles.
                    let end = nb.first_index + nb.prim_count;
                    for first in (nb.first_index..end).step_by(4) {
                        let group = lanes.group(first as usize);
                        let lanes_left = (end - first).min(4) as usize;
                        for k in na.first_index..na.first_index + na.prim_count {
                            let met = lanes.group_overlaps(k as usize, &group, lanes_left)
                                & !lanes.shared(k as usize, group.first);
                            push(candidates, k, first, met);
                        }
                    }
                }
                (a_leaf, b_leaf) => {
                    let split_a = !a_leaf && (b_leaf || half_areas[a as usize] >= half_areas[b as usize]);
                    let (split, other) = if split_a { (na, b) } else { (nb, a) };
                    let other_box = nodes[other as usize].aabb();
                    for c in [split.first_index, split.first_index + 1] {
                        if nodes[c as usize].aabb().intersect_aabb(other_box) {
                            stack.push((c, other));
                        }
                    }
                }
            }
        }
        // Exact tests on the few non-neighbour candidates.
        for &[k, l] in self.candidates.iter() {
            let (i, j) = (prims[k as usize] as usize, prims[l as usize] as usize);
            if self.degenerate[i] || self.degenerate[j] {
                continue;
            }
            let a = self.triangles[i].map(|v| self.pos[v as usize]);
            let b = self.triangles[j].map(|v| self.pos[v as usize]);
            if contact_f64(&a, self.normals[i], &b, self.normals[j]) == TriangleContact::Crossing {
                self.pairs.push([i.min(j) as u32, i.max(j) as u32]);
            }
        }
        work
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::pose::self_intersection::triangle_contact;

    /// The BVH self-traversal finds exactly the box-overlapping pairs a brute-force scan finds.
    #[test]
    fn self_traversal_matches_brute_force() {
        let sphere = crate::scene::shapes::icosphere(2);
        // Two overlapping spheres as one mesh.
        let mut positions: Vec<Vec3> = sphere.positions().to_vec();
        let mut triangles: Vec<[u32; 3]> = sphere.triangles().to_vec();
        let offset = positions.len() as u32;
        positions.extend(sphere.positions().iter().map(|p| *p * 0.7 + Vec3::new(0.8, 0.1, 0.05)));
        triangles.extend(sphere.triangles().iter().map(|t| t.map(|i| i + offset)));
        let mut checker = SelfIntersectionChecker::from_triangles(positions.len(), &triangles).unwrap();
        let result = checker.check(&positions).unwrap();
        let mut brute = Vec::new();
        for i in 0..triangles.len() {
            for j in i + 1..triangles.len() {
                let (ti, tj) = (triangles[i], triangles[j]);
                if ti.iter().any(|v| tj.contains(v)) {
                    continue;
                }
                let a = ti.map(|v| positions[v as usize]);
                let b = tj.map(|v| positions[v as usize]);
                if triangle_contact(a, b) == TriangleContact::Crossing {
                    brute.push([i as u32, j as u32]);
                }
            }
        }
        assert!(!brute.is_empty());
        assert_eq!(checker.crossing_pairs(), &brute[..]);
        assert_eq!(result.intersecting_pairs, brute.len());
    }
}
