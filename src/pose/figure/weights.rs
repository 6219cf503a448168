//! Blend weights: each vertex bound to the bones whose primitives pass nearest to it.

use glam::Vec3;

use super::sdf::Primitive;
use super::{JOINT_COUNT, JOINT_PARENTS};

/// Width of the blend-weight falloff (metres).
const SIGMA: f32 = 0.03;

/// Up to four joints and weights for a vertex at `p`: each joint scores the smallest distance from
/// `p` to its primitives; joints more than two links away from the nearest one along the hierarchy,
/// or its siblings, are left out; the rest are weighted by `exp(−(d − d_min)² / σ²)`, the four
/// largest kept and normalised.
pub(super) fn skin_weights(primitives: &[Primitive], p: Vec3) -> ([u16; 4], [f32; 4]) {
    let mut score = [f32::INFINITY; JOINT_COUNT];
    for prim in primitives {
        score[prim.joint] = score[prim.joint].min(prim.shape.distance(p));
    }
    let nearest = (0..JOINT_COUNT).fold(0, |best, j| if score[j] < score[best] { j } else { best });
    let within_two = |from: usize, to: usize| {
        let parent = JOINT_PARENTS[from];
        to == from || parent == Some(to) || parent.and_then(|q| JOINT_PARENTS[q]) == Some(to)
    };
    let mut candidates: Vec<(f32, usize)> = (0..JOINT_COUNT)
        .filter(|&j| score[j].is_finite() && (within_two(nearest, j) || within_two(j, nearest)))
        .map(|j| {
            let d = (score[j] - score[nearest]) / SIGMA;
            ((-d * d).exp(), j)
        })
        .filter(|&(w, _)| w > 1e-3)
        .collect();
    // Largest weight first; ties by joint index so the order is fully determined.
    candidates.sort_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)));
    candidates.truncate(4);
    let total: f32 = candidates.iter().map(|c| c.0).sum();
    let mut joints = [0u16; 4];
    let mut weights = [0f32; 4];
    for (k, &(w, j)) in candidates.iter().enumerate() {
        joints[k] = j as u16;
        weights[k] = w / total;
    }
    (joints, weights)
}
