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

use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap};

use glam::{Mat4, Quat, Vec3};
use rayon::prelude::*;

use crate::pose::skin::{JointRest, Skeleton, SkinnedMesh};
use crate::Mesh;

/// Joint names of the built-in figure, in SMPL's order.
pub const JOINT_NAMES: [&str; 24] = [
    "pelvis",
    "left_hip",
    "right_hip",
    "spine1",
    "left_knee",
    "right_knee",
    "spine2",
    "left_ankle",
    "right_ankle",
    "spine3",
    "left_foot",
    "right_foot",
    "neck",
    "left_collar",
    "right_collar",
    "head",
    "left_shoulder",
    "right_shoulder",
    "left_elbow",
    "right_elbow",
    "left_wrist",
    "right_wrist",
    "left_hand",
    "right_hand",
];

/// Parent of each joint of the built-in figure (SMPL's kinematic tree); parents come first.
pub const JOINT_PARENTS: [Option<usize>; 24] = [
    None,
    Some(0),
    Some(0),
    Some(0),
    Some(1),
    Some(2),
    Some(3),
    Some(4),
    Some(5),
    Some(6),
    Some(7),
    Some(8),
    Some(9),
    Some(9),
    Some(9),
    Some(12),
    Some(13),
    Some(14),
    Some(16),
    Some(17),
    Some(18),
    Some(19),
    Some(20),
    Some(21),
];

/// What part of the body a joint moves; decides how far a random plausible pose may rotate it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum JointKind {
    /// The root (pelvis): its rotation duplicates the global orientation.
    Root,
    /// Spine / torso joints.
    Spine,
    /// Collar bones (clavicles).
    Collar,
    /// The neck.
    Neck,
    /// The head.
    Head,
    /// Arms, legs, hands and feet.
    Limb,
}

impl JointKind {
    /// Classifies a non-root joint by its name (case-insensitive): names containing `spine`,
    /// `torso`, `chest` or `abdomen` are [`Spine`](JointKind::Spine), `collar` or `clavicle`
    /// [`Collar`](JointKind::Collar), `neck` [`Neck`](JointKind::Neck), `head`
    /// [`Head`](JointKind::Head), `pelvis` or exactly `hips`/`root`
    /// [`Root`](JointKind::Root); anything else is a [`Limb`](JointKind::Limb).
    pub fn of_name(name: &str) -> JointKind {
        let n = name.to_ascii_lowercase();
        let has = |words: &[&str]| words.iter().any(|w| n.contains(w));
        if has(&["spine", "torso", "chest", "abdomen"]) {
            JointKind::Spine
        } else if has(&["collar", "clavicle"]) {
            JointKind::Collar
        } else if has(&["neck"]) {
            JointKind::Neck
        } else if has(&["head"]) {
            JointKind::Head
        } else if has(&["pelvis"]) || n == "hips" || n == "root" {
            JointKind::Root
        } else {
            JointKind::Limb
        }
    }

    /// Largest rotation offset (radians) of a random plausible pose: 0.5 for limbs, 0.25 for
    /// spine, collars, neck and head, 0 for the root (use the global orientation instead).
    pub fn random_pose_limit(self) -> f32 {
        match self {
            JointKind::Root => 0.0,
            JointKind::Spine | JointKind::Collar | JointKind::Neck | JointKind::Head => 0.25,
            JointKind::Limb => 0.5,
        }
    }
}

/// The kind of every joint of a skeleton: roots (no parent) are [`JointKind::Root`], others are
/// classified by name with [`JointKind::of_name`].
pub fn joint_kinds(skeleton: &Skeleton) -> Vec<JointKind> {
    skeleton
        .parents
        .iter()
        .enumerate()
        .map(|(j, parent)| match parent {
            None => JointKind::Root,
            Some(_) => JointKind::of_name(skeleton.names.get(j).map_or("", String::as_str)),
        })
        .collect()
}

/// Every joint's [`JointKind::random_pose_limit`], in joint order: the `limits` of
/// [`crate::pose::fit::random_pose`] for this skeleton.
pub fn random_pose_limits(skeleton: &Skeleton) -> Vec<f32> {
    joint_kinds(skeleton).iter().map(|k| k.random_pose_limit()).collect()
}

/// Indices of the joints of kind [`JointKind::Limb`] (arms, legs, hands, feet).
pub fn limb_joints(figure: &SkinnedMesh) -> Vec<usize> {
    joint_kinds(&figure.skeleton).iter().enumerate().filter(|(_, k)| **k == JointKind::Limb).map(|(j, _)| j).collect()
}

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
        parents: JOINT_PARENTS.to_vec(),
        rest,
        root_parent: vec![Mat4::IDENTITY; JOINT_COUNT],
        inverse_bind: world.iter().map(|&p| Mat4::from_translation(-p)).collect(),
    };
    let mesh = Mesh::new(positions, triangles).expect("the built-in figure is a valid mesh");
    SkinnedMesh { mesh, skeleton, joints: joint_ids, weights }
}

const JOINT_COUNT: usize = 24;
/// Grid cell of the polygonisation (metres).
const CELL: f32 = 0.015;
/// Vertex count the decimation stops at.
const TARGET_VERTICES: usize = 4000;
/// No decimation creates an edge longer than this (metres).
const MAX_EDGE: f32 = 0.05;
/// Decimation keeps the normals at a triangle's corners within about 45° of each other.
const MIN_SPREAD: f32 = 0.7;
/// Width of the blend-weight falloff (metres).
const SIGMA: f32 = 0.03;
/// Primitives farther than this from a point (by bounding box) do not shape the field there.
const CULL: f32 = 0.08;

/// Rest world positions of the joints before the figure is lifted onto the floor.
fn joint_positions() -> [Vec3; JOINT_COUNT] {
    let mut p = [Vec3::ZERO; JOINT_COUNT];
    let mut pair = |left: usize, v: Vec3| {
        p[left] = v;
        p[left + 1] = v * Vec3::new(-1.0, 1.0, 1.0);
    };
    // Left arm direction: 45° below horizontal, outwards.
    let arm = Vec3::new(1.0, -1.0, 0.0).normalize();
    let shoulder = Vec3::new(0.185, 1.425, -0.015);
    let elbow = shoulder + 0.265 * arm;
    let wrist = elbow + 0.245 * arm;
    pair(1, Vec3::new(0.09, 0.87, 0.0));
    pair(4, Vec3::new(0.10, 0.49, 0.005));
    pair(7, Vec3::new(0.11, 0.085, -0.03));
    pair(10, Vec3::new(0.115, 0.03, 0.09));
    pair(13, Vec3::new(0.075, 1.40, -0.005));
    pair(16, shoulder);
    pair(18, elbow);
    pair(20, wrist);
    pair(22, wrist + 0.085 * arm);
    p[0] = Vec3::new(0.0, 0.94, 0.0);
    p[3] = Vec3::new(0.0, 1.05, -0.01);
    p[6] = Vec3::new(0.0, 1.18, -0.005);
    p[9] = Vec3::new(0.0, 1.25, 0.0);
    p[12] = Vec3::new(0.0, 1.47, -0.015);
    p[15] = Vec3::new(0.0, 1.56, 0.01);
    p
}

/// A solid the body is made of.
#[derive(Clone, Copy, Debug)]
enum Shape {
    /// Points within a linearly varying radius of a segment (a tapered capsule).
    Cone { a: Vec3, b: Vec3, ra: f32, rb: f32 },
    /// An ellipsoid with orthonormal axes `u`, `v`, `u × v` and these semi-axes.
    Ellipsoid { centre: Vec3, u: Vec3, v: Vec3, radii: Vec3 },
}

impl Shape {
    fn cone(a: Vec3, b: Vec3, ra: f32, rb: f32) -> Shape {
        Shape::Cone { a, b, ra, rb }
    }

    fn ellipsoid(centre: Vec3, radii: Vec3) -> Shape {
        Shape::Ellipsoid { centre, u: Vec3::X, v: Vec3::Y, radii }
    }

    /// Approximate signed distance (exact for capsules, a smooth bound for the rest).
    fn distance(&self, p: Vec3) -> f32 {
        match *self {
            Shape::Cone { a, b, ra, rb } => {
                let ab = b - a;
                let t = ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
                (p - (a + ab * t)).length() - (ra + (rb - ra) * t)
            }
            Shape::Ellipsoid { centre, u, v, radii } => {
                let d = p - centre;
                let q = Vec3::new(d.dot(u), d.dot(v), d.dot(u.cross(v)));
                let k0 = (q / radii).length();
                let k1 = (q / (radii * radii)).length();
                if k1 > 0.0 {
                    k0 * (k0 - 1.0) / k1
                } else {
                    -radii.min_element()
                }
            }
        }
    }

    /// An axis-aligned box containing the solid.
    fn bounds(&self) -> (Vec3, Vec3) {
        match *self {
            Shape::Cone { a, b, ra, rb } => {
                let r = Vec3::splat(ra.max(rb));
                (a.min(b) - r, a.max(b) + r)
            }
            Shape::Ellipsoid { centre, radii, .. } => {
                let r = Vec3::splat(radii.max_element());
                (centre - r, centre + r)
            }
        }
    }
}

/// A solid, the joint whose bone it belongs to, and how smoothly it blends into what came before.
#[derive(Clone, Copy, Debug)]
struct Primitive {
    shape: Shape,
    joint: usize,
    blend: f32,
    /// The shape's bounds grown by [`CULL`]: farther points ignore the primitive.
    lo: Vec3,
    hi: Vec3,
}

/// The solids of the body, in the order they are blended.
fn body_primitives(j: &[Vec3; JOINT_COUNT]) -> Vec<Primitive> {
    let mut out = Vec::new();
    let mut add = |joint: usize, blend: f32, shape: Shape| {
        let (lo, hi) = shape.bounds();
        out.push(Primitive { shape, joint, blend, lo: lo - Vec3::splat(CULL), hi: hi + Vec3::splat(CULL) })
    };
    let v = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    let torso = 0.04;
    add(0, torso, Shape::ellipsoid(v(0.0, 0.93, -0.005), v(0.165, 0.12, 0.105)));
    add(3, torso, Shape::ellipsoid(v(0.0, 1.07, 0.0), v(0.145, 0.13, 0.10)));
    add(6, torso, Shape::ellipsoid(v(0.0, 1.20, 0.005), v(0.155, 0.12, 0.105)));
    add(9, torso, Shape::ellipsoid(v(0.0, 1.32, 0.0), v(0.17, 0.15, 0.11)));
    add(12, 0.03, Shape::cone(v(0.0, 1.40, -0.01), v(0.0, 1.575, 0.0), 0.056, 0.05));
    add(15, 0.03, Shape::ellipsoid(v(0.0, 1.635, 0.015), v(0.078, 0.105, 0.095)));
    let arm = (j[18] - j[16]).normalize();
    let across = Vec3::Z.cross(arm); // in the xy plane, perpendicular to the arm
    for side in [0, 1] {
        let m = if side == 0 { Vec3::ONE } else { v(-1.0, 1.0, 1.0) };
        let s = |k: usize| k + side;
        // Glutes belong to the pelvis; collars carry the top of the shoulders.
        add(0, 0.03, Shape::ellipsoid(m * v(0.07, 0.885, -0.04), v(0.085, 0.095, 0.08)));
        add(s(13), 0.03, Shape::cone(m * v(0.04, 1.41, -0.01), j[s(16)], 0.06, 0.055));
        add(s(16), 0.02, Shape::cone(j[s(16)], j[s(18)], 0.05, 0.04));
        add(s(18), 0.02, Shape::cone(j[s(18)], j[s(20)], 0.04, 0.03));
        let (arm, across) = (m * arm, m * across);
        add(
            s(20),
            0.015,
            Shape::Ellipsoid { centre: j[s(20)] + 0.05 * arm, u: arm, v: across, radii: v(0.06, 0.025, 0.045) },
        );
        add(
            s(22),
            0.015,
            Shape::Ellipsoid { centre: j[s(20)] + 0.12 * arm, u: arm, v: across, radii: v(0.06, 0.02, 0.04) },
        );
        add(s(1), 0.02, Shape::cone(j[s(1)], j[s(4)], 0.08, 0.055));
        add(s(4), 0.02, Shape::cone(j[s(4)], j[s(7)], 0.055, 0.035));
        let calf = j[s(4)] + 0.3 * (j[s(7)] - j[s(4)]) + v(0.0, 0.0, -0.015);
        add(s(4), 0.02, Shape::ellipsoid(calf, v(0.055, 0.11, 0.055)));
        add(s(7), 0.02, Shape::cone(m * v(0.11, 0.04, -0.05), m * v(0.115, 0.03, 0.09), 0.04, 0.033));
        add(s(10), 0.015, Shape::cone(m * v(0.115, 0.028, 0.09), m * v(0.118, 0.025, 0.15), 0.03, 0.026));
    }
    out
}

/// Polynomial smooth minimum: `min(a, b)` rounded over a width `k`.
fn smooth_min(a: f32, b: f32, k: f32) -> f32 {
    let h = (k - (a - b).abs()).max(0.0) / k;
    a.min(b) - h * h * k * 0.25
}

/// The body's field: the smooth union of the primitives near `p` (those whose grown bounds
/// contain it). Farther primitives are at least [`CULL`] away, more than any blend width, so
/// leaving them out changes nothing near the surface; a point near none of them gets `CULL`.
fn body_sdf(primitives: &[Primitive], p: Vec3) -> f32 {
    let mut acc = f32::INFINITY;
    for prim in primitives {
        if p.cmplt(prim.lo).any() || p.cmpgt(prim.hi).any() {
            continue;
        }
        let d = prim.shape.distance(p);
        acc = if acc.is_finite() { smooth_min(acc, d, prim.blend) } else { d };
    }
    acc.min(CULL)
}

fn gradient(sdf: &impl Fn(Vec3) -> f32, p: Vec3) -> Vec3 {
    gradient_from(sdf, p, sdf(p))
}

/// Forward differences from `f = sdf(p)`.
fn gradient_from(sdf: &impl Fn(Vec3) -> f32, p: Vec3, f: f32) -> Vec3 {
    let e = 1e-3;
    Vec3::new(sdf(p + Vec3::X * e) - f, sdf(p + Vec3::Y * e) - f, sdf(p + Vec3::Z * e) - f) / e
}

/// Newton steps along the gradient onto the zero set (two suffice from a point within a few
/// millimetres of it).
fn project_to_surface(sdf: &impl Fn(Vec3) -> f32, mut p: Vec3) -> Vec3 {
    for _ in 0..2 {
        let f = sdf(p);
        if f.abs() < 1e-6 {
            break;
        }
        let g = gradient_from(sdf, p, f);
        let g2 = g.length_squared();
        if g2 < 1e-6 {
            break;
        }
        // Never move farther than a cell: the field is only a bound far from the surface.
        p -= (g * (f / g2)).clamp_length_max(CELL);
    }
    p
}

/// Marching tetrahedra over the box `[lo, hi]` with cells of side [`CELL`], each cube split into
/// the six tetrahedra around its main diagonal (a triangulation that matches across cube faces).
/// The zero set of the piecewise-linear interpolant is a closed 2-manifold as long as no grid
/// value is exactly zero, which the sampling guarantees by nudging tiny values outwards.
/// Vertices are shared per grid edge; triangles face from negative to positive values.
fn marching_tetrahedra(sdf: &(impl Fn(Vec3) -> f32 + Sync), lo: Vec3, hi: Vec3) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let n = ((hi - lo) / CELL).ceil().as_uvec3() + 1;
    let (nx, ny, nz) = (n.x as usize, n.y as usize, n.z as usize);
    let point = |g: usize| {
        let (i, j, k) = (g % nx, (g / nx) % ny, g / (nx * ny));
        lo + Vec3::new(i as f32, j as f32, k as f32) * CELL
    };
    let eps = 0.05 * CELL;
    let values: Vec<f32> = (0..nx * ny * nz)
        .into_par_iter()
        .map(|g| {
            let f = sdf(point(g));
            if f.abs() < eps {
                eps
            } else {
                f
            }
        })
        .collect();

    // The six tetrahedra [0, e_a, e_a + e_b, 7] (corner bit i = offset along axis i), with the
    // sign of each one's orientation (the parity of the axis permutation).
    const TETS: [([usize; 4], bool); 6] = [
        ([0, 1, 3, 7], true),
        ([0, 1, 5, 7], false),
        ([0, 2, 3, 7], false),
        ([0, 2, 6, 7], true),
        ([0, 4, 5, 7], true),
        ([0, 4, 6, 7], false),
    ];
    let mut edge_vertex: HashMap<(usize, usize), u32> = HashMap::new();
    let mut positions: Vec<Vec3> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    let mut vertex = |a: usize, b: usize, positions: &mut Vec<Vec3>| -> u32 {
        let (a, b) = (a.min(b), a.max(b));
        *edge_vertex.entry((a, b)).or_insert_with(|| {
            let (fa, fb) = (values[a], values[b]);
            positions.push(point(a) + (point(b) - point(a)) * (fa / (fa - fb)));
            positions.len() as u32 - 1
        })
    };
    for k in 0..nz - 1 {
        for j in 0..ny - 1 {
            for i in 0..nx - 1 {
                let base = i + nx * (j + ny * k);
                let corner = |c: usize| base + (c & 1) + ((c >> 1) & 1) * nx + ((c >> 2) & 1) * nx * ny;
                let inside: [bool; 8] = std::array::from_fn(|c| values[corner(c)] < 0.0);
                if inside.iter().all(|&x| x) || inside.iter().all(|&x| !x) {
                    continue;
                }
                for (tet, positive) in TETS {
                    let g = tet.map(corner);
                    let ins = tet.map(|c| inside[c]);
                    let count = ins.iter().filter(|&&x| x).count();
                    match count {
                        1 | 3 => {
                            // The lone corner and the other three in increasing order: the face
                            // (j, k, l) points away from the lone corner i iff i is even in a
                            // positive tetrahedron (odd in a negative one).
                            let lone_inside = count == 1;
                            let i = (0..4).find(|&c| ins[c] == lone_inside).expect("one lone corner");
                            let o: Vec<usize> = (0..4).filter(|&c| c != i).collect();
                            let away = (i % 2 == 0) == positive;
                            let mut tri = [o[0], o[1], o[2]].map(|c| vertex(g[i], g[c], &mut positions));
                            if away != lone_inside {
                                tri.swap(1, 2);
                            }
                            triangles.push(tri);
                        }
                        2 => {
                            // Inside a, b; outside c, d. The quad (ac, ad, bd, bc) faces outwards
                            // iff the permutation (a, b, c, d) has the tetrahedron's parity.
                            let ab: Vec<usize> = (0..4).filter(|&c| ins[c]).collect();
                            let cd: Vec<usize> = (0..4).filter(|&c| !ins[c]).collect();
                            let perm = [ab[0], ab[1], cd[0], cd[1]];
                            let inversions = (0..4)
                                .flat_map(|x| (x + 1..4).map(move |y| (x, y)))
                                .filter(|&(x, y)| perm[x] > perm[y])
                                .count();
                            let outward = (inversions % 2 == 0) == positive;
                            let mut e = |x: usize, y: usize, positions: &mut Vec<Vec3>| vertex(g[x], g[y], positions);
                            let q = [
                                e(ab[0], cd[0], &mut positions),
                                e(ab[0], cd[1], &mut positions),
                                e(ab[1], cd[1], &mut positions),
                                e(ab[1], cd[0], &mut positions),
                            ];
                            if outward {
                                triangles.push([q[0], q[1], q[2]]);
                                triangles.push([q[0], q[2], q[3]]);
                            } else {
                                triangles.push([q[0], q[2], q[1]]);
                                triangles.push([q[0], q[3], q[2]]);
                            }
                        }
                        _ => {}
                    }
                }
            }
        }
    }
    (positions, triangles)
}

/// Triangle quality: 1 for equilateral, 0 for degenerate.
fn quality(a: Vec3, b: Vec3, c: Vec3) -> f32 {
    let area2 = (b - a).cross(c - a).length();
    let sum = (b - a).length_squared() + (c - b).length_squared() + (a - c).length_squared();
    if sum > 0.0 {
        2.0 * 3f32.sqrt() * area2 / sum
    } else {
        0.0
    }
}

/// Collapses the shortest edges of a closed, oriented 2-manifold until `target` vertices remain
/// (or no edge shorter than `max_edge` can go), then collapses what is left of the very short
/// edges (under a fifth of a cell) that marching tetrahedra makes near grid nodes. A collapse
/// merges the two vertices at their midpoint moved by `project`, and is refused when it would
/// break the manifold (the link condition: the two vertices share exactly the two opposite
/// vertices of their two triangles), turn a triangle away from the field's `normal` (fold-over),
/// make the worst triangle of the two fans worse than quality 0.15, or create an edge longer than
/// `max_edge`. Orientation is kept. Returns the compacted vertices and triangles.
fn decimate(
    pos: Vec<Vec3>,
    tris: Vec<[u32; 3]>,
    target: usize,
    max_edge: f32,
    project: impl Fn(Vec3) -> Vec3,
    normal: impl Fn(Vec3) -> Vec3,
) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let n = pos.len();
    let mut vtris: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (t, tri) in tris.iter().enumerate() {
        for &v in tri {
            vtris[v as usize].push(t as u32);
        }
    }
    let normals = pos.iter().map(|&p| normal(p).normalize_or_zero()).collect();
    let mut d = Decimator {
        tri_alive: vec![true; tris.len()],
        v_alive: vec![true; n],
        alive: n,
        pos,
        tris,
        vtris,
        normals,
        max2: max_edge * max_edge,
        tidying: false,
        project,
        normal,
    };
    d.run(d.edges(max_edge), target, max_edge);
    let short = 0.2 * CELL;
    d.tidying = true;
    for _ in 0..5 {
        if d.run(d.edges(short), 0, short) + d.remove_valence_three() == 0 {
            break;
        }
    }
    d.finish()
}

struct Decimator<P, N> {
    pos: Vec<Vec3>,
    tris: Vec<[u32; 3]>,
    vtris: Vec<Vec<u32>>,
    normals: Vec<Vec3>,
    tri_alive: Vec<bool>,
    v_alive: Vec<bool>,
    alive: usize,
    max2: f32,
    /// Collapsing only very short edges: the surface's bend across a triangle is not checked.
    tidying: bool,
    project: P,
    normal: N,
}

type EdgeHeap = BinaryHeap<Reverse<(u32, u32, u32)>>;

impl<P: Fn(Vec3) -> Vec3, N: Fn(Vec3) -> Vec3> Decimator<P, N> {
    fn len_key(&self, a: u32, b: u32) -> u32 {
        self.pos[a as usize].distance_squared(self.pos[b as usize]).to_bits()
    }

    /// Every live edge shorter than `max_len`, once, shortest first.
    fn edges(&self, max_len: f32) -> EdgeHeap {
        let mut heap = BinaryHeap::new();
        for (tri, _) in self.tris.iter().zip(&self.tri_alive).filter(|(_, &live)| live) {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                let key = self.len_key(a, b);
                if a < b && f32::from_bits(key) < max_len * max_len {
                    heap.push(Reverse((key, a, b)));
                }
            }
        }
        heap
    }

    fn neighbours(&self, v: u32) -> Vec<u32> {
        let mut out: Vec<u32> =
            self.vtris[v as usize].iter().flat_map(|&t| self.tris[t as usize]).filter(|&w| w != v).collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// Collapses edges from the heap, shortest first, until `target` vertices remain or the
    /// shortest edge is longer than `max_len`. Returns the number of collapses.
    fn run(&mut self, mut heap: EdgeHeap, target: usize, max_len: f32) -> usize {
        let mut done = 0;
        while self.alive > target {
            let Some(Reverse((key, a, b))) = heap.pop() else { break };
            if !self.v_alive[a as usize] || !self.v_alive[b as usize] || self.len_key(a, b) != key {
                continue;
            }
            if f32::from_bits(key) > max_len * max_len {
                break;
            }
            // Merge at the midpoint; when tidying, at either end if the midpoint is refused.
            let (pa, na, pb, nb) =
                (self.pos[a as usize], self.normals[a as usize], self.pos[b as usize], self.normals[b as usize]);
            let survivor = if self.collapse(a, b) || (self.tidying && self.collapse_to(a, b, pa, na)) {
                Some(a)
            } else if self.tidying && self.collapse_to(b, a, pb, nb) {
                Some(b)
            } else {
                None
            };
            if let Some(s) = survivor {
                done += 1;
                for w in self.neighbours(s) {
                    let (x, y) = (s.min(w), s.max(w));
                    heap.push(Reverse((self.len_key(x, y), x, y)));
                }
            }
        }
        done
    }

    /// Collapses each vertex with three neighbours into its nearest neighbour: such vertices
    /// block the collapse of short edges around them (the link condition). Returns the number of
    /// collapses.
    fn remove_valence_three(&mut self) -> usize {
        let mut done = 0;
        for v in 0..self.pos.len() as u32 {
            if !self.v_alive[v as usize] || self.vtris[v as usize].len() != 3 {
                continue;
            }
            let mut around = self.neighbours(v);
            around.sort_by_key(|&w| self.len_key(v, w));
            if around.iter().any(|&w| self.collapse_to(w, v, self.pos[w as usize], self.normals[w as usize])) {
                done += 1;
            }
        }
        done
    }

    /// Merges `b` into `a` if that is acceptable (see [`decimate`]).
    fn collapse(&mut self, a: u32, b: u32) -> bool {
        let p = (self.project)((self.pos[a as usize] + self.pos[b as usize]) * 0.5);
        let np = (self.normal)(p).normalize_or_zero();
        self.collapse_to(a, b, p, np)
    }

    /// Merges `b` into `a`, placed at `p` with normal `np`, if that is acceptable.
    fn collapse_to(&mut self, a: u32, b: u32, p: Vec3, np: Vec3) -> bool {
        let (au, bu) = (a as usize, b as usize);
        let shared: Vec<u32> = self.vtris[au].iter().copied().filter(|&t| self.tris[t as usize].contains(&b)).collect();
        if shared.len() != 2 {
            return false;
        }
        let nb = self.neighbours(b);
        if self.neighbours(a).iter().filter(|w| nb.binary_search(w).is_ok()).count() != 2 {
            return false;
        }
        let fans = || self.vtris[au].iter().chain(&self.vtris[bu]).copied();
        let corners = |t: u32, moved: bool| {
            self.tris[t as usize].map(|v| {
                if moved && (v == a || v == b) {
                    (p, np)
                } else {
                    (self.pos[v as usize], self.normals[v as usize])
                }
            })
        };
        let facing = |c: [(Vec3, Vec3); 3]| {
            let n = (c[1].0 - c[0].0).cross(c[2].0 - c[0].0);
            n.normalize_or_zero().dot((c[0].1 + c[1].1 + c[2].1).normalize_or_zero())
        };
        let q = |c: [(Vec3, Vec3); 3]| quality(c[0].0, c[1].0, c[2].0);
        // How much the surface turns across a triangle: the least cosine between its corners'
        // normals. Bounding it keeps triangles small where the surface bends sharply.
        let spread = |c: [(Vec3, Vec3); 3]| c[0].1.dot(c[1].1).min(c[1].1.dot(c[2].1)).min(c[2].1.dot(c[0].1));
        let worst_before = fans().map(|t| q(corners(t, false))).fold(f32::INFINITY, f32::min);
        let acceptable = fans().filter(|t| !shared.contains(t)).all(|t| {
            let after = corners(t, true);
            let long = after.iter().any(|c| c.0.distance_squared(p) > self.max2);
            let before = corners(t, false);
            !long
                && q(after) >= worst_before.min(0.15)
                && facing(after) >= facing(before).min(if self.tidying { 0.2 } else { 0.5 })
                && (self.tidying || spread(after) >= spread(before).min(MIN_SPREAD))
        });
        if !acceptable {
            return false;
        }
        for &t in &shared {
            self.tri_alive[t as usize] = false;
            for v in self.tris[t as usize] {
                self.vtris[v as usize].retain(|&x| x != t);
            }
        }
        let moved = std::mem::take(&mut self.vtris[bu]);
        for &t in &moved {
            for v in self.tris[t as usize].iter_mut() {
                if *v == b {
                    *v = a;
                }
            }
        }
        self.vtris[au].extend(moved);
        self.v_alive[bu] = false;
        self.alive -= 1;
        self.pos[au] = p;
        self.normals[au] = np;
        true
    }

    fn finish(self) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let mut remap = vec![u32::MAX; self.pos.len()];
        let mut pos = Vec::with_capacity(self.alive);
        for (v, &live) in self.v_alive.iter().enumerate() {
            if live {
                remap[v] = pos.len() as u32;
                pos.push(self.pos[v]);
            }
        }
        let tris = self
            .tris
            .iter()
            .zip(&self.tri_alive)
            .filter(|(_, &live)| live)
            .map(|(t, _)| t.map(|v| remap[v as usize]))
            .collect();
        (pos, tris)
    }
}

/// Edge flips that improve the worst of the two triangles' qualities (by 5% at least, so that
/// nothing cycles), repeated until none applies: decimation leaves some obtuse slivers that no
/// collapse can fix. A flip is refused when the new edge exists already (the manifold would
/// break) or when a new triangle would turn away from the field's `normal` at its vertices or
/// fold against its partner. Orientation is kept.
fn flip_edges(pos: &[Vec3], tris: &mut [[u32; 3]], normal: impl Fn(Vec3) -> Vec3) {
    let normals: Vec<Vec3> = pos.iter().map(|&p| normal(p).normalize_or_zero()).collect();
    let mut owner: HashMap<(u32, u32), u32> = HashMap::with_capacity(tris.len() * 3);
    for (t, tri) in tris.iter().enumerate() {
        for k in 0..3 {
            owner.insert((tri[k], tri[(k + 1) % 3]), t as u32);
        }
    }
    let at = |v: u32| pos[v as usize];
    let face_normal = |x: u32, y: u32, z: u32| (at(y) - at(x)).cross(at(z) - at(x)).normalize_or_zero();
    let facing = |x: u32, y: u32, z: u32| {
        let reference = normals[x as usize] + normals[y as usize] + normals[z as usize];
        face_normal(x, y, z).dot(reference.normalize_or_zero())
    };
    let q = |x: u32, y: u32, z: u32| quality(at(x), at(y), at(z));
    for _ in 0..20 {
        let mut flips = 0;
        for t1 in 0..tris.len() {
            for k in 0..3 {
                let tri = tris[t1];
                let (a, b, c) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
                let Some(&t2) = owner.get(&(b, a)) else { continue };
                let t2 = t2 as usize;
                let Some(d) = tris[t2].iter().copied().find(|&v| v != a && v != b) else { continue };
                if c == d || owner.contains_key(&(c, d)) || owner.contains_key(&(d, c)) {
                    continue;
                }
                let before = q(a, b, c).min(q(b, a, d));
                let after = q(c, a, d).min(q(d, b, c));
                if after <= before * 1.05
                    || facing(c, a, d) < 0.5
                    || facing(d, b, c) < 0.5
                    || face_normal(c, a, d).dot(face_normal(d, b, c)) < 0.5
                {
                    continue;
                }
                for e in [(a, b), (b, c), (c, a), (b, a), (a, d), (d, b)] {
                    owner.remove(&e);
                }
                tris[t1] = [c, a, d];
                tris[t2] = [d, b, c];
                for (e, t) in [((c, a), t1), ((a, d), t1), ((d, c), t1), ((d, b), t2), ((b, c), t2), ((c, d), t2)] {
                    owner.insert(e, t as u32);
                }
                flips += 1;
                break;
            }
        }
        if flips == 0 {
            break;
        }
    }
}

/// Up to four joints and weights for a vertex at `p`: each joint scores the smallest distance from
/// `p` to its primitives; joints more than two links away from the nearest one along the hierarchy,
/// or its siblings, are left out; the rest are weighted by `exp(−(d − d_min)² / σ²)`, the four
/// largest kept and normalised.
fn skin_weights(primitives: &[Primitive], p: Vec3) -> ([u16; 4], [f32; 4]) {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tetrahedra_orientation_signs_match_their_determinants() {
        // Guards the table in marching_tetrahedra.
        let corner = |c: usize| Vec3::new((c & 1) as f32, ((c >> 1) & 1) as f32, ((c >> 2) & 1) as f32);
        for (tet, positive) in [
            ([0, 1, 3, 7], true),
            ([0, 1, 5, 7], false),
            ([0, 2, 3, 7], false),
            ([0, 2, 6, 7], true),
            ([0, 4, 5, 7], true),
            ([0, 4, 6, 7], false),
        ] {
            let [a, b, c, d] = tet.map(corner);
            let det = (b - a).dot((c - a).cross(d - a));
            assert_eq!(det > 0.0, positive, "{tet:?}");
        }
    }

    #[test]
    fn sphere_polygonises_closed_and_outward() {
        let (p, t) = marching_tetrahedra(&|p: Vec3| p.length() - 0.1, Vec3::splat(-0.15), Vec3::splat(0.15));
        let volume: f32 = t.iter().map(|&[a, b, c]| p[a as usize].dot(p[b as usize].cross(p[c as usize])) / 6.0).sum();
        let exact = 4.0 / 3.0 * std::f32::consts::PI * 0.001;
        assert!((volume - exact).abs() < 0.05 * exact, "{volume} vs {exact}");
        let mesh = Mesh::new(p, t).unwrap();
        let topo = mesh.topology();
        assert!((0..topo.edges().len()).all(|e| topo.edge_faces(e).len() == 2));
    }

    #[test]
    fn joint_kinds_by_name() {
        assert_eq!(JointKind::of_name("Spine2"), JointKind::Spine);
        assert_eq!(JointKind::of_name("torso_joint_1"), JointKind::Spine);
        assert_eq!(JointKind::of_name("neck_joint_2"), JointKind::Neck);
        assert_eq!(JointKind::of_name("left_collar"), JointKind::Collar);
        assert_eq!(JointKind::of_name("left_hip"), JointKind::Limb);
        assert_eq!(JointKind::of_name("arm_joint_L_1"), JointKind::Limb);
        assert_eq!(JointKind::of_name("Head"), JointKind::Head);
    }
}
