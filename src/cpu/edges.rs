//! `edges` — CPU twin of `shaders/edges.wgsl`: which mesh edges can be on the silhouette in this
//! view, and on which side their inside lies.
//!
//! An edge is a *candidate* when all of its adjacent, non-culled, non-degenerate faces lie on one
//! side of it in screen space: an open boundary edge (one face), a contour edge (two faces folded
//! onto the same side) or a non-manifold edge whose faces all lie on one side. An edge with faces
//! on both sides is inside the silhouette and skipped.
//!
//! The side test uses the unsnapped `f32` screen positions with an `f64` cross product (the sign
//! is exact for pixel-range coordinates), i.e. the same geometry as the backward (`edge_grad`)
//! and the exact-area ideal image it differentiates. The snapped fixed-point coordinates of the `coverage`
//! stage must not be used here: a sliver face seen nearly edge-on (common along a contour) can
//! flip or vanish when snapped, which moves the silhouette to the wrong edges and lets the
//! sliver occlude the edges that remain.

use rayon::prelude::*;

use crate::layout::ScreenVertex;
use crate::mesh::Topology;

/// Side of the inside of a candidate edge `[a, b]`: `+1` when the faces lie to the left of
/// `a → b` (where `cross(b − a, p − a) > 0`, screen y down), `-1` to the right, `0` when the edge
/// is not a candidate.
pub fn edge_side(screen: &[ScreenVertex], topology: &Topology, edge: usize) -> i32 {
    let [a, b] = topology.edges()[edge];
    let pos = |v: u32| {
        let p = screen[v as usize].position;
        [p[0] as f64, p[1] as f64]
    };
    if screen[a as usize].valid == 0 || screen[b as usize].valid == 0 {
        return 0;
    }
    let (pa, pb) = (pos(a), pos(b));
    let (mut left, mut right) = (false, false);
    for &face in topology.edge_faces(edge) {
        let tri = topology.triangles()[face as usize];
        let Some(&w) = tri.iter().find(|&&v| v != a && v != b) else { continue };
        if screen[w as usize].valid == 0 {
            continue; // culled face: not drawn, so not a side
        }
        let pw = pos(w);
        // f32 differences and their products are exact in f64, so the sign is exact.
        let cross = (pb[0] - pa[0]) * (pw[1] - pa[1]) - (pb[1] - pa[1]) * (pw[0] - pa[0]);
        left |= cross > 0.0;
        right |= cross < 0.0;
    }
    match (left, right) {
        (true, false) => 1,
        (false, true) => -1,
        _ => 0,
    }
}

/// Classifies every edge of the topology. Reads the screen vertices; writes `sides` (one per edge).
pub fn edges(screen: &[ScreenVertex], topology: &Topology, sides: &mut [i32]) {
    sides.par_iter_mut().with_min_len(4096).enumerate().for_each(|(e, side)| {
        *side = edge_side(screen, topology, e);
    });
}
