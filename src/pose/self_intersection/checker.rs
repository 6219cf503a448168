//! The checker: per-topology tables (vertex → triangle adjacency, connected components), the BVH
//! over the triangle boxes (refitted or rebuilt between calls), scratch buffers, and the check
//! that runs the passes of the other files in order.

use std::time::Duration;

use glam::{DVec3, Vec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::bvh2::builder::build_bvh2;
use obvhs::bvh2::Bvh2;
use obvhs::BvhBuildParams;

use super::contact::{dvec, plane_normal};
use super::lanes::BoxLanes;
use super::{RebuildPolicy, SelfIntersection};
use crate::scene::mesh::{check_positions, check_triangles, find, union, vertex_csr, Topology};
use crate::Result;

/// Per-topology state for repeated self-intersection checks: the triangles, vertex → triangle
/// adjacency, connected components, the BVH (refitted between calls) and scratch buffers.
#[derive(Clone)]
pub struct SelfIntersectionChecker {
    pub(super) vertex_count: usize,
    pub(super) triangles: Vec<[u32; 3]>,
    /// CSR vertex → incident triangles.
    pub(super) vt_offsets: Vec<u32>,
    pub(super) vt_list: Vec<u32>,
    /// Connected component of each triangle (through shared vertex indices).
    pub(super) tri_component: Vec<u32>,
    pub(super) component_count: usize,
    pub(super) policy: RebuildPolicy,
    pub(super) bvh: Option<Bvh2>,
    /// Node pairs visited by the self-traversal right after the last rebuild.
    pub(super) baseline_work: usize,
    pub(super) rebuilds: usize,
    // Scratch.
    pub(super) pos: Vec<DVec3>,
    pub(super) aabbs: Vec<Aabb>,
    pub(super) normals: Vec<DVec3>,
    pub(super) degenerate: Vec<bool>,
    pub(super) flip: Vec<bool>,
    pub(super) stack: Vec<(u32, u32)>,
    /// Every BVH node's `half_area`, for the traversal's choice of which node to split.
    pub(super) half_areas: Vec<f32>,
    pub(super) lanes: BoxLanes,
    pub(super) candidates: Vec<[u32; 2]>,
    pub(super) pairs: Vec<[u32; 2]>,
    pub(super) cut: Vec<bool>,
    pub(super) parent: Vec<u32>,
    pub(super) terms: Vec<(u32, u32)>,
}

impl std::fmt::Debug for SelfIntersectionChecker {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SelfIntersectionChecker")
            .field("vertex_count", &self.vertex_count)
            .field("triangles", &self.triangles.len())
            .field("components", &self.component_count)
            .field("policy", &self.policy)
            .field("rebuilds", &self.rebuilds)
            .finish_non_exhaustive()
    }
}

impl SelfIntersectionChecker {
    /// A checker for meshes with this (already validated) topology.
    pub fn new(topology: &Topology) -> SelfIntersectionChecker {
        Self::build(topology.vertex_count(), topology.triangles().to_vec())
    }

    /// A checker for `vertex_count` vertices and these triangles; errors if an index is out of
    /// range.
    pub fn from_triangles(vertex_count: usize, triangles: &[[u32; 3]]) -> Result<SelfIntersectionChecker> {
        check_triangles(vertex_count, triangles)?;
        Ok(Self::build(vertex_count, triangles.to_vec()))
    }

    fn build(vertex_count: usize, triangles: Vec<[u32; 3]>) -> SelfIntersectionChecker {
        let (vt_offsets, vt_list) = vertex_csr(vertex_count, &triangles);
        // Components through shared vertices.
        let mut parent: Vec<u32> = (0..vertex_count as u32).collect();
        for tri in &triangles {
            union(&mut parent, tri[0], tri[1]);
            union(&mut parent, tri[0], tri[2]);
        }
        let mut component_of_root = vec![u32::MAX; vertex_count];
        let mut component_count = 0usize;
        let mut tri_component = Vec::with_capacity(triangles.len());
        for tri in &triangles {
            let root = find(&mut parent, tri[0]) as usize;
            if component_of_root[root] == u32::MAX {
                component_of_root[root] = component_count as u32;
                component_count += 1;
            }
            tri_component.push(component_of_root[root]);
        }
        SelfIntersectionChecker {
            vertex_count,
            triangles,
            vt_offsets,
            vt_list,
            tri_component,
            component_count,
            policy: RebuildPolicy::default(),
            bvh: None,
            baseline_work: 0,
            rebuilds: 0,
            pos: Vec::new(),
            aabbs: Vec::new(),
            normals: Vec::new(),
            degenerate: Vec::new(),
            flip: Vec::new(),
            stack: Vec::new(),
            half_areas: Vec::new(),
            lanes: BoxLanes::default(),
            candidates: Vec::new(),
            pairs: Vec::new(),
            cut: Vec::new(),
            parent,
            terms: Vec::new(),
        }
    }

    /// Sets when the BVH is rebuilt instead of refitted (default: [`RebuildPolicy::Refit`]).
    pub fn set_rebuild_policy(&mut self, policy: RebuildPolicy) {
        self.policy = policy;
    }

    /// How many times the BVH has been built so far.
    pub fn rebuild_count(&self) -> usize {
        self.rebuilds
    }

    /// The crossing triangle pairs `[i, j]` (`i < j`, ascending) found by the last
    /// [`check`](Self::check).
    pub fn crossing_pairs(&self) -> &[[u32; 2]] {
        &self.pairs
    }

    /// Number of vertices the checker expects.
    pub fn vertex_count(&self) -> usize {
        self.vertex_count
    }

    /// The penalty, surrogate and surrogate gradient for these positions (see the
    /// [module docs](super)).
    ///
    /// Errors: wrong number of positions ([`Error::LengthMismatch`](crate::Error::LengthMismatch)),
    /// a NaN or infinite coordinate ([`Error::NonFiniteVertex`](crate::Error::NonFiniteVertex)).
    pub fn check(&mut self, positions: &[Vec3]) -> Result<SelfIntersection> {
        check_positions(self.vertex_count, positions)?;
        let n = self.vertex_count;
        self.pairs.clear();
        if self.triangles.is_empty() {
            return Ok(SelfIntersection {
                penalty: 0.0,
                surrogate: 0.0,
                inside_vertices: Vec::new(),
                intersecting_pairs: 0,
                grad: vec![Vec3::ZERO; n],
            });
        }
        self.prepare_geometry(positions);
        self.update_bvh();
        self.find_crossing_pairs();
        let inside_vertices = self.classify_vertices(positions);
        let (surrogate, grad) = self.surrogate();
        Ok(SelfIntersection {
            penalty: if n == 0 { 0.0 } else { inside_vertices.len() as f64 / n as f64 },
            surrogate,
            inside_vertices,
            intersecting_pairs: self.pairs.len(),
            grad,
        })
    }

    /// f64 positions, triangle boxes, outward normals, degeneracy, component orientation.
    fn prepare_geometry(&mut self, positions: &[Vec3]) {
        self.pos.clear();
        self.pos.extend(positions.iter().map(|&p| dvec(p)));
        let pos = &self.pos;
        self.aabbs.clear();
        self.normals.clear();
        self.degenerate.clear();
        let mut volume = vec![0.0f64; self.component_count];
        let mut reference: Vec<Option<DVec3>> = vec![None; self.component_count];
        for (t, tri) in self.triangles.iter().enumerate() {
            // In SIMD lanes (`Vec3A`; the positions are finite, so `min`/`max` are the scalar ones).
            let p = tri.map(|v| Vec3A::from(positions[v as usize]));
            let lo = p[0].min(p[1]).min(p[2]);
            let hi = p[0].max(p[1]).max(p[2]);
            // A little slack so that f32 box tests never miss a contact that f64 sees.
            let pad = Vec3A::splat((hi - lo).max_element() * 1e-5 + lo.abs().max(hi.abs()).max_element() * 1e-6);
            let (lo, hi) = ((lo - pad).max(Vec3A::splat(-f32::MAX)), (hi + pad).min(Vec3A::splat(f32::MAX)));
            self.aabbs.push(Aabb::new(lo, hi));
            let q = tri.map(|v| pos[v as usize]);
            match plane_normal(&q) {
                Some(nrm) => {
                    self.normals.push(nrm);
                    self.degenerate.push(false);
                }
                None => {
                    self.normals.push(DVec3::ZERO);
                    self.degenerate.push(true);
                }
            }
            let c = self.tri_component[t] as usize;
            let r = *reference[c].get_or_insert(q[0]);
            volume[c] += (q[0] - r).dot((q[1] - r).cross(q[2] - r));
        }
        self.flip.clear();
        self.flip.extend(volume.iter().map(|&v| v < 0.0));
        for (t, nrm) in self.normals.iter_mut().enumerate() {
            if self.flip[self.tri_component[t] as usize] {
                *nrm = -*nrm;
            }
        }
    }

    fn update_bvh(&mut self) {
        let refit = match (self.policy, &mut self.bvh) {
            (RebuildPolicy::Refit { .. }, Some(bvh)) => {
                refit(bvh, &self.aabbs);
                true
            }
            _ => false,
        };
        if !refit {
            self.rebuild_bvh();
        }
    }

    pub(super) fn rebuild_bvh(&mut self) {
        let mut time = Duration::ZERO;
        // The fast preset, with leaves of up to 12 triangles and collapsing weighted towards
        // them (traversal cost 6 instead of 3): the self-traversal tests a leaf's triangles four
        // at a time (`lanes.rs`), so larger leaves cost little and save node pairs, whose visits
        // wait on memory (the built-in figure's check: 1.11 → 1.05 ms against 8 and 3; 16 and 6
        // 1.07, 32 and 10 1.30). A better tree saves more than its longer build costs (the BVH
        // is refitted, and rebuilt rarely).
        let params =
            BvhBuildParams { max_prims_per_leaf: 12, collapse_traversal_cost: 6.0, ..BvhBuildParams::fast_build() };
        let bvh = build_bvh2(&self.aabbs, params, &mut time);
        self.lanes.fill_triangles(&bvh.primitive_indices, &self.triangles);
        self.bvh = Some(bvh);
        self.rebuilds += 1;
        self.baseline_work = 0;
    }
}

/// Refits the BVH's boxes to new triangle boxes (same topology).
fn refit(bvh: &mut Bvh2, aabbs: &[Aabb]) {
    let Bvh2 { nodes, primitive_indices, .. } = bvh;
    for node in nodes.iter_mut() {
        if node.is_leaf() {
            let mut bb = Aabb::INVALID;
            for k in node.first_index..node.first_index + node.prim_count {
                bb = bb.union(&aabbs[primitive_indices[k as usize] as usize]);
            }
            node.set_aabb(bb);
        }
    }
    bvh.refit_all();
}
