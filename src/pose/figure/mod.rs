//! The built-in figure: a human-like skinned mesh generated in code, so that pose fitting runs
//! with no files at all.
//!
//! [`builtin_figure`] returns a [`SkinnedMesh`] with
//!
//! - a skeleton of the 24 joints of SMPL, in SMPL's order and hierarchy ([`JOINT_NAMES`],
//!   [`JOINT_PARENTS`]): pelvis (root), hips, three spine joints, knees, ankles, feet, neck,
//!   collars, head, shoulders, elbows, wrists and hands. Units are metres; y is up, the figure
//!   faces +z (its left is +x), stands on y = 0 and is about 1.74 m tall, arms in an A-pose
//!   (45° below horizontal) so that they do not touch the torso. Rest rotations are the identity
//!   and rest scales 1: each joint's rest transform is a translation from its parent, and its
//!   inverse bind matrix is the inverse of its rest world transform;
//! - a closed, welded, outward-oriented triangle surface of about 3,900 vertices (a sphere
//!   topologically, without self-intersections): the zero set of a signed distance field (a
//!   smooth union of tapered capsules and ellipsoids, one or more per bone) polygonised by
//!   marching tetrahedra on a 1.5 cm grid (about 32,000 vertices), then decimated by
//!   shortest-edge collapses that keep it a closed 2-manifold (link condition), keep triangles
//!   facing the field's gradient and small where the surface bends sharply, and put each merged
//!   vertex back on the zero set; a last pass of edge flips improves the worst triangles;
//! - smooth blend weights, at most 4 per vertex, summing to 1: each bone owns the primitives it
//!   moves, and a vertex is weighted to the bones whose primitives pass nearest to it,
//!   `w ∝ exp(−(d_bone − d_nearest)² / σ²)` with σ = 3 cm, restricted to bones within two links of
//!   the nearest one along the hierarchy (never a sibling limb, never a far-away bone), so knees
//!   and elbows blend between their two bones.
//!
//! Generation is deterministic (every call returns the same bits: no hash-map order or thread
//! schedule reaches the output) and takes about 0.4 s of one core in an optimised build.
//!
//! [`JointKind`] classifies joints so that an example can draw plausible random poses
//! (up to 0.5 rad for limbs, 0.25 rad for spine, neck and head); it also works by name on other
//! skeletons ([`joint_kinds`]).

mod decimate;
mod marching;
mod sdf;
mod skeleton;
mod weights;

use glam::{Mat4, Quat, Vec3};

use crate::pose::skin::{JointRest, Skeleton, SkinnedMesh};
use crate::Mesh;

use decimate::{decimate, flip_edges};
use marching::marching_tetrahedra;
use sdf::{body_primitives, body_sdf, gradient, project_to_surface};
use skeleton::joint_positions;
pub use skeleton::{joint_kinds, limb_joints, random_pose_limits, JointKind, JOINT_NAMES, JOINT_PARENTS};
use weights::skin_weights;

/// The built-in figure (see the [module documentation](self)): 24 joints, about 3,900 vertices,
/// closed and outward-oriented, 1.74 m tall, standing on y = 0 and facing +z. Deterministic.
pub fn builtin_figure() -> SkinnedMesh {
    let joints = joint_positions();
    let primitives = body_primitives(&joints);
    let sdf = |p: Vec3| body_sdf(&primitives, p);

    let (lo, hi) =
        primitives.iter().fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(lo, hi), p| {
            let (a, b) = p.shape.bounds();
            (lo.min(a), hi.max(b))
        });
    let (positions, triangles) = marching_tetrahedra(&sdf, lo - Vec3::splat(3.0 * CELL), hi + Vec3::splat(3.0 * CELL));
    let (mut positions, mut triangles) = decimate(
        positions,
        triangles,
        TARGET_VERTICES,
        MAX_EDGE,
        |p| project_to_surface(&sdf, p),
        |p| gradient(&sdf, p),
    );
    flip_edges(&positions, &mut triangles, |p| gradient(&sdf, p));

    // Weights in the generation frame, then everything is lifted so that the soles touch y = 0.
    let (joint_ids, weights): (Vec<[u16; 4]>, Vec<[f32; 4]>) =
        positions.iter().map(|&p| skin_weights(&primitives, p)).unzip();
    let floor = positions.iter().map(|p| p.y).fold(f32::INFINITY, f32::min);
    let lift = Vec3::new(0.0, -floor, 0.0);
    for p in &mut positions {
        *p += lift;
    }
    let world: Vec<Vec3> = joints.iter().map(|&p| p + lift).collect();

    let rest = (0..JOINT_COUNT)
        .map(|j| JointRest {
            translation: match JOINT_PARENTS[j] {
                Some(parent) => world[j] - world[parent],
                None => world[j],
            },
            rotation: Quat::IDENTITY,
            scale: Vec3::ONE,
        })
        .collect();
    let skeleton = Skeleton {
        names: JOINT_NAMES.iter().map(|s| s.to_string()).collect(),
        nodes: Vec::new(),
        parents: JOINT_PARENTS.to_vec(),
        rest,
        root_parent: vec![Mat4::IDENTITY; JOINT_COUNT],
        inverse_bind: world.iter().map(|&p| Mat4::from_translation(-p)).collect(),
    };
    let mesh = Mesh::new(positions, triangles).expect("the built-in figure is a valid mesh");
    SkinnedMesh { mesh, skeleton, joints: joint_ids, weights, morphs: Default::default() }
}

const JOINT_COUNT: usize = 24;
/// Grid cell of the polygonisation (metres).
const CELL: f32 = 0.015;
/// Vertex count the decimation stops at.
const TARGET_VERTICES: usize = 4000;
/// No decimation creates an edge longer than this (metres).
const MAX_EDGE: f32 = 0.05;
