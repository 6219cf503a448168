//! `gather` — CPU twin of `shaders/gather.wgsl`: per-edge gradient slots → per-vertex gradients.

use glam::Vec2;
use rayon::prelude::*;

use crate::layout::EdgeGrad;
use crate::mesh::Topology;

/// Sums, for every vertex, the slots of its incident edges in the fixed order of the topology's
/// vertex → edge CSR (deterministic, atomic-free). Reads `slots`; writes `grads` (one per vertex).
pub fn gather(topology: &Topology, slots: &[EdgeGrad], grads: &mut [Vec2]) {
    let edges = topology.edges();
    grads.par_iter_mut().with_min_len(4096).enumerate().for_each(|(v, g)| {
        let mut sum = Vec2::ZERO;
        for &e in topology.vertex_edges(v) {
            let slot = &slots[e as usize];
            sum += Vec2::from(if edges[e as usize][0] as usize == v { slot.a } else { slot.b });
        }
        *g = sum;
    });
}
