//! `gather` — CPU twin of `shaders/gather.wgsl`: per-edge gradient slots → per-vertex gradients.

use glam::Vec2;

use crate::mirror::EdgeGrad;
use crate::scene::mesh::Topology;

/// Sums, for every vertex, the slots of its incident candidate edges in edge order. Reads the
/// candidates `(edge, side)` (in edge order, as the `edges` stage lists them) and their `slots`
/// (same order); writes `grads` (one per vertex).
///
/// The WGSL stage sums each vertex's incident edges over the topology's vertex → edge CSR, which
/// lists them in edge order; the slots of the other edges are `+0.0`, and adding `+0.0` to a sum
/// that starts at `+0.0` changes no bit. So scattering the candidates' slots in edge order gives
/// the same bits, deterministically, in time proportional to the number of candidates.
pub fn gather(topology: &Topology, candidates: &[(u32, i32)], slots: &[EdgeGrad], grads: &mut [Vec2]) {
    grads.fill(Vec2::ZERO);
    scatter(topology, candidates, slots, grads);
}

/// [`gather`] into `grads` that hold zeros already (a buffer just allocated zeroed): adds the
/// candidates' slots in edge order.
pub(crate) fn scatter(topology: &Topology, candidates: &[(u32, i32)], slots: &[EdgeGrad], grads: &mut [Vec2]) {
    let edges = topology.edges();
    for (&(e, _), slot) in candidates.iter().zip(slots) {
        let [a, b] = edges[e as usize];
        grads[a as usize] += Vec2::from(slot.a);
        grads[b as usize] += Vec2::from(slot.b);
    }
}
