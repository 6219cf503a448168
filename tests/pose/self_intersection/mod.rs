//! Self-intersection penalty (paper Eq. 19): the triangle–triangle test, the inside-vertex
//! classification, the surrogate's gradient, and that descending it separates interpenetrating
//! parts.

use diffsil::pose::self_intersection::{
    self_intersection, triangle_contact, triangles_intersect, RebuildPolicy, SelfIntersection, SelfIntersectionChecker,
    TriangleContact,
};
use diffsil::{Error, Vec3};

use crate::common::rng::{Draws, Rng};

fn v(x: f32, y: f32, z: f32) -> Vec3 {
    Vec3::new(x, y, z)
}

/// A point with coordinates uniform in [-1, 1) (`common::rng`'s xorshift64*, 24-bit draws).
fn random_point(rng: &mut Rng) -> Vec3 {
    v(rng.signed_f32(), rng.signed_f32(), rng.signed_f32())
}

mod meshes;
mod triangle_pairs;
