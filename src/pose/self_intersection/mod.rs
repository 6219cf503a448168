//! Self-intersection penalty (paper Eq. 19): which vertices of a posed mesh lie inside another
//! part of the same mesh, and a differentiable surrogate whose gradient pushes them back out.
//!
//! # What is computed
//!
//! The mesh is taken as a set of closed, consistently wound surfaces (each connected component is
//! oriented outward automatically from its signed volume, so either winding works). For a point
//! `x`, let `w(x)` be the winding number of the whole mesh: the number of enclosed volumes `x`
//! lies in. Where two parts of the body interpenetrate (a forearm folded into the torso), the
//! volume is covered twice. A vertex `v` lies on its own surface, so it is judged from just
//! outside that surface: `w⁺(v) = lim w(v + ε·n_v)`, with `n_v` its outward normal.
//!
//! - **Inside vertices** (the paper's "vertices inside the self-intersection region"): the
//!   vertices with `w⁺(v) ≥ 1`, i.e. those lying inside the volume of some other part of the
//!   mesh. On a mesh without self-intersections this set is empty.
//! - **Penalty** `E = |inside| / N`, `N` the vertex count: the paper's value, in `[0, 1]`.
//!   A count has no useful gradient, so the module also returns:
//! - **Surrogate** `E_s = (1/N) Σ_(v, B) depth(v, B)²` over the distinct pairs (vertex `v`,
//!   triangle `B`) such that a triangle containing `v` *crosses* `B` and `v` lies strictly behind
//!   `B`'s outward plane, where `depth(v, B) = −(v − b₀)·n̂_B > 0` (world units², like a squared
//!   distance). Its exact gradient (with respect to `v` and to `B`'s three vertices, through
//!   `n̂_B`) is [`SelfIntersection::grad`]. A descent step moves `v` along `+n̂_B`, out of the
//!   part `B` belongs to, and moves `B` back, away from `v`: the two parts are pushed apart.
//!   `E_s` is smooth while the set of crossing pairs stays the same (each term vanishes smoothly
//!   as `v` reaches `B`'s plane), and its gradient is checked against finite differences in the
//!   tests. It jumps where a crossing pair appears or disappears: as a limb slides out of the
//!   torso its value saw-tooths (new pairs keep appearing at the moving intersection curve) while
//!   its gradient keeps pointing outward, which is what a gradient-based fit needs. For pose
//!   fitting use `λ·E_s` and its gradient (through the skinning backward); report `E`. Plain
//!   per-vertex descent on `E_s` needs small steps: its curvature grows with the number of
//!   crossing pairs that share a vertex.
//!
//! Why this choice: the penalty is exactly the paper's quantity, defined globally (a forearm tip
//! buried deep in the torso counts, not only the vertices next to the intersection curve), while
//! the gradient only needs the local geometry of the triangles that actually cross, where the
//! other part's plane is a good first-order model of its surface. A part buried entirely inside
//! another without any crossing triangle is counted in `E` but gets no gradient (a continuous
//! motion only gets there through crossing states, where the gradient pushes back).
//!
//! # How
//!
//! 1. Triangle boxes go into a BVH from `obvhs` ([`BvhBuildParams::fast_build`](obvhs::BvhBuildParams::fast_build) with leaves of
//!    up to 12 triangles). [`SelfIntersectionChecker`] keeps it between calls and, by default,
//!    *refits* it to the new positions, rebuilding only when refitting has degraded it (see
//!    [`RebuildPolicy`]). For the built-in figure's 7.7k triangles a rebuild costs about 1 ms, a
//!    refit a few tens of µs: refitting wins, and stays good even over large motions (one
//!    rebuild in 206 checks along three fits).
//! 2. A simultaneous descent of the BVH against itself lists the overlapping box pairs. Pairs of
//!    triangles that share a vertex index are dropped (neighbours always touch; on a closed mesh
//!    almost every overlap is a neighbour). Within a pair of leaves, each triangle is tested
//!    against four of the other leaf's at once (their boxes and vertex indices laid out one
//!    array per bound and corner, the results as bit masks), without a branch per pair.
//! 3. Each remaining pair is classified by our own exact-style triangle–triangle test,
//!    [`triangle_contact`] (Möller's interval method in `f64` on the `f32` input): only
//!    [`TriangleContact::Crossing`] pairs, where the surfaces pass through each other, count.
//!    Touching (a vertex or edge resting on the other triangle, or two edges meeting) and coplanar
//!    overlap are contact, not penetration: they have no inside, happen only on a set of measure
//!    zero, and are not counted. Degenerate (zero-area) triangles never intersect anything.
//! 4. `w⁺` is constant along an edge that crosses no other triangle, so vertices joined by edges
//!    of triangles that cross nothing form *patches* with one value of `w⁺` (union–find). Each
//!    patch is classified by casting a ray from one vertex (three for patches of three vertices
//!    or more, majority vote) along its outward normal, through the same BVH, summing `±1` per
//!    crossed triangle (sign of the direction against the triangle's outward normal). A ray that
//!    grazes an edge or a vertex is re-cast in another direction. With no crossing pair at all,
//!    a mesh of one connected component has nothing inside and needs no ray; a mesh of several
//!    needs one patch per component (a component may sit entirely inside another).
//!
//! Cost (release, this project's shared 2-core machine, the meshes of 2026-11-27 fits replayed
//! check by check): about 1.4 ms per [`SelfIntersectionChecker::check`] with refitting for the
//! built-in figure (7.7k triangles; 2.4 ms rebuilding every call), about 3.3 ms for the
//! MakeHuman body (14k triangles); since the leaf pairs load a group's boxes once, the pose-fit
//! bench's checks take 0.88 and 2.8 ms (1.14 and 3.2 before). Single-threaded and
//! deterministic.
//!
//! # Limits
//!
//! - Each connected component should be a closed surface; on open surfaces `w` is not an integer
//!   and the inside test is approximate.
//! - Intersections between triangles that share a vertex (a fold within one vertex's ring) are
//!   ignored, by design.
//! - Degenerate configurations (touching, coplanar) count as no intersection; an arbitrarily
//!   small motion resolves them.
//!
//! ```
//! use diffsil::pose::self_intersection::self_intersection;
//! let sphere = diffsil::shapes::icosphere(2);
//! let r = self_intersection(sphere.positions(), sphere.triangles()).unwrap();
//! assert_eq!(r.penalty, 0.0);
//! assert_eq!(r.intersecting_pairs, 0);
//! ```

mod checker;
mod contact;
mod lanes;
mod pairs;
mod surrogate;
mod winding;

use glam::Vec3;

use crate::Result;

pub use checker::SelfIntersectionChecker;
pub use contact::{triangle_contact, triangles_intersect, TriangleContact};

/// The self-intersection penalty of one posed mesh (see the [module docs](self)).
#[derive(Clone, Debug, PartialEq)]
pub struct SelfIntersection {
    /// The paper's `E_spt`: the fraction of vertices inside the self-intersection region,
    /// `inside_vertices.len() / vertex_count` (0 for an empty mesh).
    pub penalty: f64,
    /// The differentiable surrogate `E_s = Σ depth² / N` (world units²) whose gradient is
    /// [`SelfIntersection::grad`].
    pub surrogate: f64,
    /// The vertices inside the self-intersection region, ascending.
    pub inside_vertices: Vec<u32>,
    /// Number of crossing triangle pairs (pairs sharing a vertex excluded).
    pub intersecting_pairs: usize,
    /// `∂E_s/∂v` for every vertex (zero where no crossing is involved).
    pub grad: Vec<Vec3>,
}

/// The self-intersection penalty of a mesh given as positions and triangles, for one-off use. In a
/// loop, keep a [`SelfIntersectionChecker`]: it reuses the BVH and the scratch buffers.
///
/// Errors: a triangle index out of range ([`Error::IndexOutOfRange`](crate::Error::IndexOutOfRange)), a NaN or infinite
/// coordinate ([`Error::NonFiniteVertex`](crate::Error::NonFiniteVertex)). An empty mesh has zero penalty.
pub fn self_intersection(positions: &[Vec3], triangles: &[[u32; 3]]) -> Result<SelfIntersection> {
    SelfIntersectionChecker::from_triangles(positions.len(), triangles)?.check(positions)
}

/// When [`SelfIntersectionChecker::check`] rebuilds its BVH rather than refitting it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RebuildPolicy {
    /// Build a new BVH on every call.
    Always,
    /// Refit the existing BVH to the new positions; rebuild when the refitted tree has become
    /// loose: when the self-traversal visits more than `factor` times the node pairs it visited
    /// right after the last rebuild (the cost of the next call is then predicted to exceed a
    /// rebuild's). `factor = 1.5` is the default.
    Refit {
        /// Growth of the traversal work that triggers a rebuild (values below 1 act as 1).
        factor: f32,
    },
}

impl Default for RebuildPolicy {
    fn default() -> Self {
        RebuildPolicy::Refit { factor: 1.5 }
    }
}
