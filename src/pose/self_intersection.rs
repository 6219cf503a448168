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
//! 1. Triangle boxes go into a BVH from `obvhs` ([`BvhBuildParams::fastest_build`] with leaves of
//!    up to 4 triangles). [`SelfIntersectionChecker`] keeps it between calls and, by default,
//!    *refits* it to the new positions, rebuilding only when refitting has degraded it (see
//!    [`RebuildPolicy`]). For ~5k triangles a refit costs ~20 µs and a rebuild ~0.4 ms, against
//!    ~1 ms for the whole check: refitting wins, and stays good even over large motions.
//! 2. A simultaneous descent of the BVH against itself lists the overlapping box pairs. Pairs of
//!    triangles that share a vertex index are dropped (neighbours always touch; on a closed mesh
//!    almost every overlap is a neighbour).
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
//! Cost (release, this project's shared 2-core machine, 5,440 triangles: an ellipsoid torso with
//! an arm through it): ~1.2–1.5 ms per [`SelfIntersectionChecker::check`] with refitting,
//! ~2 ms rebuilding every call, ~3 ms for the one-off [`self_intersection`]. Single-threaded
//! and deterministic.
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

use std::time::Duration;

use glam::{DVec3, Vec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::bvh2::builder::build_bvh2;
use obvhs::bvh2::Bvh2;
use obvhs::ray::Ray;
use obvhs::BvhBuildParams;

use crate::scene::mesh::Topology;
use crate::{Error, Result};

// ------------------------------------------------------------------------------------------------
// Triangle–triangle test
// ------------------------------------------------------------------------------------------------

/// How two triangles meet, from [`triangle_contact`]. Triangles are closed point sets.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TriangleContact {
    /// No common point.
    Disjoint,
    /// At least one triangle has (numerically) zero area: degenerate triangles never intersect.
    Degenerate,
    /// The triangles share points but do not pass through each other: a vertex or an edge rests on
    /// the other triangle, or two edges meet. Not penetration.
    Touching,
    /// The surfaces pass through each other: each triangle has vertices strictly on both sides of
    /// the other's plane, and they share a segment of positive length. The only contact the
    /// self-intersection penalty counts.
    Crossing,
    /// Both triangles lie in one plane and overlap (even at a single point). Not counted by the
    /// penalty: coplanar contact has no inside.
    Coplanar,
}

impl TriangleContact {
    /// Whether the closed triangles share at least one point (`Touching`, `Crossing` or
    /// `Coplanar`).
    pub fn intersects(self) -> bool {
        matches!(self, TriangleContact::Touching | TriangleContact::Crossing | TriangleContact::Coplanar)
    }
}

/// A triangle is degenerate when `|e₁ × e₂| ≤ DEGENERATE · max|eᵢ|²`: its smallest angle is below
/// about `1e-10` rad (or it has repeated or collinear vertices). Its plane is then meaningless.
const DEGENERATE: f64 = 1e-10;

#[inline]
fn dvec(v: Vec3) -> DVec3 {
    DVec3::new(v.x as f64, v.y as f64, v.z as f64)
}

/// The normal `(b−a)×(c−a)` of a triangle, or `None` when it is degenerate.
#[inline]
fn plane_normal(t: &[DVec3; 3]) -> Option<DVec3> {
    let e0 = t[1] - t[0];
    let e1 = t[2] - t[0];
    let e2 = t[2] - t[1];
    let n = e0.cross(e1);
    let longest = e0.length_squared().max(e1.length_squared()).max(e2.length_squared());
    let len = n.length();
    if len > DEGENERATE * longest && len.is_finite() {
        Some(n)
    } else {
        None
    }
}

/// Classifies how triangles `a` and `b` meet. Exact for inputs whose coordinate differences and
/// their products are exact in `f64` (e.g. coordinates on a grid of dyadic fractions); otherwise
/// correct up to `f64` rounding, which can only blur configurations within ~1e-16 (relative) of
/// touching.
///
/// Möller's method: the signed distances of each triangle's vertices to the other's plane reject
/// separated pairs; otherwise each triangle meets the line common to both planes in an interval,
/// and the triangles meet iff the intervals do. Coplanar pairs are tested in 2D (edge crossings,
/// then containment). The penalty uses only [`TriangleContact::Crossing`].
pub fn triangle_contact(a: [Vec3; 3], b: [Vec3; 3]) -> TriangleContact {
    let a = a.map(dvec);
    let b = b.map(dvec);
    let (Some(na), Some(nb)) = (plane_normal(&a), plane_normal(&b)) else {
        return TriangleContact::Degenerate;
    };
    contact_f64(&a, na, &b, nb)
}

/// Whether the closed triangles `a` and `b` share a point (see [`triangle_contact`]): `true` for
/// touching, crossing and overlapping coplanar triangles, `false` for disjoint or degenerate ones.
pub fn triangles_intersect(a: [Vec3; 3], b: [Vec3; 3]) -> bool {
    triangle_contact(a, b).intersects()
}

#[inline]
fn signs(d: &[f64; 3]) -> (bool, bool) {
    let pos = d.iter().any(|&x| x > 0.0);
    let neg = d.iter().any(|&x| x < 0.0);
    (pos, neg)
}

fn contact_f64(a: &[DVec3; 3], na: DVec3, b: &[DVec3; 3], nb: DVec3) -> TriangleContact {
    // Signed (unnormalised) distances of a's vertices to b's plane, and conversely.
    let da = [(a[0] - b[0]).dot(nb), (a[1] - b[0]).dot(nb), (a[2] - b[0]).dot(nb)];
    let (a_pos, a_neg) = signs(&da);
    if !a_pos && !a_neg {
        return coplanar_contact(a, b, na);
    }
    if !(a_pos && a_neg) && da.iter().all(|&x| x != 0.0) {
        return TriangleContact::Disjoint;
    }
    let db = [(b[0] - a[0]).dot(na), (b[1] - a[0]).dot(na), (b[2] - a[0]).dot(na)];
    let (b_pos, b_neg) = signs(&db);
    if !b_pos && !b_neg {
        return coplanar_contact(a, b, na);
    }
    if !(b_pos && b_neg) && db.iter().all(|&x| x != 0.0) {
        return TriangleContact::Disjoint;
    }
    let dir = na.cross(nb);
    if dir == DVec3::ZERO {
        // Parallel planes with vertices on both sides can only come from rounding.
        return TriangleContact::Disjoint;
    }
    let origin = a[0];
    let (Some((a_lo, a_hi)), Some((b_lo, b_hi))) =
        (line_interval(a, &da, dir, origin), line_interval(b, &db, dir, origin))
    else {
        return TriangleContact::Disjoint;
    };
    let lo = a_lo.max(b_lo);
    let hi = a_hi.min(b_hi);
    if lo > hi {
        TriangleContact::Disjoint
    } else if a_pos && a_neg && b_pos && b_neg && lo < hi {
        TriangleContact::Crossing
    } else {
        TriangleContact::Touching
    }
}

/// The interval, along `dir` (measured from `origin`), of the points of triangle `t` that lie on
/// the other triangle's plane, given the signed distances `d` of `t`'s vertices to that plane.
fn line_interval(t: &[DVec3; 3], d: &[f64; 3], dir: DVec3, origin: DVec3) -> Option<(f64, f64)> {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    let mut add = |p: DVec3| {
        let s = (p - origin).dot(dir);
        lo = lo.min(s);
        hi = hi.max(s);
    };
    for i in 0..3 {
        if d[i] == 0.0 {
            add(t[i]);
        }
        let j = (i + 1) % 3;
        if (d[i] > 0.0 && d[j] < 0.0) || (d[i] < 0.0 && d[j] > 0.0) {
            let s = d[i] / (d[i] - d[j]);
            add(t[i] + (t[j] - t[i]) * s);
        }
    }
    (lo <= hi).then_some((lo, hi))
}

/// Closed-triangle overlap of two coplanar triangles, in the coordinate plane where `n` is largest.
fn coplanar_contact(a: &[DVec3; 3], b: &[DVec3; 3], n: DVec3) -> TriangleContact {
    let an = n.abs();
    let (i, j) = if an.x >= an.y && an.x >= an.z {
        (1, 2)
    } else if an.y >= an.z {
        (2, 0)
    } else {
        (0, 1)
    };
    let p = a.map(|v| [v[i], v[j]]);
    let q = b.map(|v| [v[i], v[j]]);
    let overlap = (0..3).any(|k| (0..3).any(|l| segments_meet(p[k], p[(k + 1) % 3], q[l], q[(l + 1) % 3])))
        || point_in_triangle(p[0], &q)
        || point_in_triangle(q[0], &p);
    if overlap {
        TriangleContact::Coplanar
    } else {
        TriangleContact::Disjoint
    }
}

#[inline]
fn orient2d(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// Closed segments `ab` and `cd` share a point.
fn segments_meet(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> bool {
    let d1 = orient2d(c, d, a);
    let d2 = orient2d(c, d, b);
    let d3 = orient2d(a, b, c);
    let d4 = orient2d(a, b, d);
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0)) && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0)) {
        return true;
    }
    let on = |p: [f64; 2], q: [f64; 2], r: [f64; 2]| {
        r[0] >= p[0].min(q[0]) && r[0] <= p[0].max(q[0]) && r[1] >= p[1].min(q[1]) && r[1] <= p[1].max(q[1])
    };
    (d1 == 0.0 && on(c, d, a)) || (d2 == 0.0 && on(c, d, b)) || (d3 == 0.0 && on(a, b, c)) || (d4 == 0.0 && on(a, b, d))
}

/// `p` lies in the closed (non-degenerate) triangle `t`.
fn point_in_triangle(p: [f64; 2], t: &[[f64; 2]; 3]) -> bool {
    let d = [orient2d(t[0], t[1], p), orient2d(t[1], t[2], p), orient2d(t[2], t[0], p)];
    let (pos, neg) = signs(&d);
    !(pos && neg)
}

// ------------------------------------------------------------------------------------------------
// The penalty
// ------------------------------------------------------------------------------------------------

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
/// Errors: a triangle index out of range ([`Error::IndexOutOfRange`]), a NaN or infinite
/// coordinate ([`Error::NonFiniteVertex`]). An empty mesh has zero penalty.
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

/// Per-topology state for repeated self-intersection checks: the triangles, vertex → triangle
/// adjacency, connected components, the BVH (refitted between calls) and scratch buffers.
#[derive(Clone)]
pub struct SelfIntersectionChecker {
    vertex_count: usize,
    triangles: Vec<[u32; 3]>,
    /// CSR vertex → incident triangles.
    vt_offsets: Vec<u32>,
    vt_list: Vec<u32>,
    /// Connected component of each triangle (through shared vertex indices).
    tri_component: Vec<u32>,
    component_count: usize,
    policy: RebuildPolicy,
    bvh: Option<Bvh2>,
    /// Node pairs visited by the self-traversal right after the last rebuild.
    baseline_work: usize,
    rebuilds: usize,
    // Scratch.
    pos: Vec<DVec3>,
    aabbs: Vec<Aabb>,
    normals: Vec<DVec3>,
    degenerate: Vec<bool>,
    flip: Vec<bool>,
    stack: Vec<(u32, u32)>,
    ordered_boxes: Vec<Aabb>,
    ordered_tris: Vec<[u32; 3]>,
    candidates: Vec<[u32; 2]>,
    pairs: Vec<[u32; 2]>,
    cut: Vec<bool>,
    parent: Vec<u32>,
    terms: Vec<(u32, u32)>,
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
        if vertex_count > u32::MAX as usize / 2 || triangles.len() > u32::MAX as usize / 4 {
            return Err(Error::LengthMismatch {
                what: "mesh size (vertices, triangles) must fit 32-bit indices",
                expected: u32::MAX as usize / 4,
                got: vertex_count.max(triangles.len()),
            });
        }
        for (triangle, tri) in triangles.iter().enumerate() {
            if let Some(&index) = tri.iter().find(|&&i| i as usize >= vertex_count) {
                return Err(Error::IndexOutOfRange { triangle, index, vertex_count });
            }
        }
        Ok(Self::build(vertex_count, triangles.to_vec()))
    }

    fn build(vertex_count: usize, triangles: Vec<[u32; 3]>) -> SelfIntersectionChecker {
        let mut vt_offsets = vec![0u32; vertex_count + 1];
        for tri in &triangles {
            for (k, &v) in tri.iter().enumerate() {
                if !tri[..k].contains(&v) {
                    vt_offsets[v as usize + 1] += 1;
                }
            }
        }
        for v in 0..vertex_count {
            vt_offsets[v + 1] += vt_offsets[v];
        }
        let mut cursor = vt_offsets.clone();
        let mut vt_list = vec![0u32; vt_offsets[vertex_count] as usize];
        for (t, tri) in triangles.iter().enumerate() {
            for (k, &v) in tri.iter().enumerate() {
                if !tri[..k].contains(&v) {
                    vt_list[cursor[v as usize] as usize] = t as u32;
                    cursor[v as usize] += 1;
                }
            }
        }
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
            ordered_boxes: Vec::new(),
            ordered_tris: Vec::new(),
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
    /// [module docs](self)).
    ///
    /// Errors: wrong number of positions ([`Error::LengthMismatch`]), a NaN or infinite coordinate
    /// ([`Error::NonFiniteVertex`]).
    pub fn check(&mut self, positions: &[Vec3]) -> Result<SelfIntersection> {
        if positions.len() != self.vertex_count {
            return Err(Error::LengthMismatch {
                what: "vertex positions",
                expected: self.vertex_count,
                got: positions.len(),
            });
        }
        if let Some(vertex) = positions.iter().position(|p| !p.is_finite()) {
            return Err(Error::NonFiniteVertex { vertex, value: positions[vertex].to_array() });
        }
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
            let p = tri.map(|v| positions[v as usize]);
            let lo = p[0].min(p[1]).min(p[2]);
            let hi = p[0].max(p[1]).max(p[2]);
            // A little slack so that f32 box tests never miss a contact that f64 sees.
            let pad = Vec3::splat((hi - lo).max_element() * 1e-5 + lo.abs().max(hi.abs()).max_element() * 1e-6);
            let (lo, hi) = ((lo - pad).max(Vec3::splat(-f32::MAX)), (hi + pad).min(Vec3::splat(f32::MAX)));
            self.aabbs.push(Aabb::new(Vec3A::from(lo), Vec3A::from(hi)));
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

    fn rebuild_bvh(&mut self) {
        let mut time = Duration::ZERO;
        // The fastest preset, with leaves of up to 4 triangles: fewer node pairs to visit in the
        // self-traversal, for a few more (cheap) triangle pairs per leaf pair.
        let params =
            BvhBuildParams { max_prims_per_leaf: 4, collapse_traversal_cost: 3.0, ..BvhBuildParams::fastest_build() };
        let bvh = build_bvh2(&self.aabbs, params, &mut time);
        self.bvh = Some(bvh);
        self.rebuilds += 1;
        self.baseline_work = 0;
    }

    /// Self-traversal of the BVH, shared-vertex filter, exact test.
    fn find_crossing_pairs(&mut self) {
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
        // Boxes and triangles in the BVH's primitive order: a leaf's primitives are contiguous.
        self.ordered_boxes.clear();
        self.ordered_boxes.extend(prims.iter().map(|&p| self.aabbs[p as usize]));
        self.ordered_tris.clear();
        self.ordered_tris.extend(prims.iter().map(|&p| self.triangles[p as usize]));
        let (boxes, tris) = (&self.ordered_boxes, &self.ordered_tris);
        let candidates = &mut self.candidates;
        // Hot path: box overlap and the shared-vertex filter only; exact tests come after.
        let mut consider = |k: u32, l: u32| {
            let (ti, tj) = (&tris[k as usize], &tris[l as usize]);
            if !share_vertex(ti, tj) && boxes[k as usize].intersect_aabb(&boxes[l as usize]) {
                candidates.push([k, l]);
            }
        };
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
                        for l in k + 1..end {
                            consider(k, l);
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
                    for k in na.first_index..na.first_index + na.prim_count {
                        for l in nb.first_index..nb.first_index + nb.prim_count {
                            consider(k, l);
                        }
                    }
                }
                (a_leaf, b_leaf) => {
                    let split_a = !a_leaf && (b_leaf || na.aabb().half_area() >= nb.aabb().half_area());
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

    /// The vertices with `w⁺ ≥ 1`, ascending.
    fn classify_vertices(&mut self, positions: &[Vec3]) -> Vec<u32> {
        let n = self.vertex_count;
        if self.pairs.is_empty() && self.component_count <= 1 {
            return Vec::new();
        }
        // Patches: vertices joined by the edges of triangles that cross nothing.
        self.cut.clear();
        self.cut.resize(self.triangles.len(), false);
        for &[i, j] in &self.pairs {
            self.cut[i as usize] = true;
            self.cut[j as usize] = true;
        }
        self.parent.clear();
        self.parent.extend(0..n as u32);
        for (t, tri) in self.triangles.iter().enumerate() {
            if !self.cut[t] {
                union(&mut self.parent, tri[0], tri[1]);
                union(&mut self.parent, tri[0], tri[2]);
            }
        }
        // Group the vertices that belong to some triangle by patch.
        let mut patch_of_root = vec![u32::MAX; n];
        let mut patch_members: Vec<Vec<u32>> = Vec::new();
        for v in 0..n {
            if self.vt_offsets[v] == self.vt_offsets[v + 1] {
                continue;
            }
            let root = find(&mut self.parent, v as u32) as usize;
            if patch_of_root[root] == u32::MAX {
                patch_of_root[root] = patch_members.len() as u32;
                patch_members.push(Vec::new());
            }
            patch_members[patch_of_root[root] as usize].push(v as u32);
        }
        let mut inside = Vec::new();
        for members in &patch_members {
            let samples: &[usize] = if members.len() >= 3 { &[0, members.len() / 2, members.len() - 1] } else { &[0] };
            let votes = samples.iter().filter(|&&k| self.winding_outside(positions, members[k]) >= 1).count();
            if 2 * votes > samples.len() {
                inside.extend_from_slice(members);
            }
        }
        inside.sort_unstable();
        inside
    }

    /// `w⁺(v)`: the winding number just outside vertex `v`, by a ray along its outward normal.
    fn winding_outside(&self, positions: &[Vec3], v: u32) -> i32 {
        let Some(bvh) = &self.bvh else { return 0 };
        let incident = &self.vt_list[self.vt_offsets[v as usize] as usize..self.vt_offsets[v as usize + 1] as usize];
        let mut normal = DVec3::ZERO;
        for &t in incident {
            let n = self.normals[t as usize];
            let len = n.length();
            if len > 0.0 {
                normal += n / len * angle_at(&self.pos, &self.triangles[t as usize], v);
            }
        }
        let normal = normal.try_normalize().unwrap_or(DVec3::new(0.267, 0.535, 0.802));
        // Fixed, generic perturbations so rays do not run along the mesh's symmetry planes.
        const JITTER: [[f64; 3]; 4] = [
            [0.0317, -0.0219, 0.0127],
            [-0.0613, 0.0451, 0.0297],
            [0.0523, 0.0731, -0.0667],
            [-0.0871, -0.0389, 0.0911],
        ];
        let origin = positions[v as usize];
        let o = dvec(origin);
        let mut last = 0;
        for jitter in JITTER {
            let mut d = normal + DVec3::from_array(jitter);
            // Keep components away from 0 so obvhs's f32 slab test stays exact enough.
            for c in 0..3 {
                if d[c].abs() < 1e-3 {
                    d[c] = 1e-3;
                }
            }
            let d = d.normalize();
            let dir = Vec3A::new(d.x as f32, d.y as f32, d.z as f32);
            let d = DVec3::new(dir.x as f64, dir.y as f64, dir.z as f64);
            let mut winding = 0i32;
            let mut ambiguous = false;
            bvh.ray_traverse_anyhit(Ray::new_inf(Vec3A::from(origin), dir), |_, prim| {
                let t = bvh.primitive_indices[prim] as usize;
                let tri = &self.triangles[t];
                if self.degenerate[t] || tri.contains(&v) {
                    return;
                }
                match ray_triangle(o, d, &tri.map(|k| self.pos[k as usize])) {
                    RayHit::Miss => {}
                    RayHit::Ambiguous => ambiguous = true,
                    RayHit::Hit => winding += if d.dot(self.normals[t]) > 0.0 { 1 } else { -1 },
                }
            });
            last = winding;
            if !ambiguous {
                break;
            }
        }
        last
    }

    /// `E_s` and its gradient.
    fn surrogate(&mut self) -> (f64, Vec<Vec3>) {
        let n = self.vertex_count;
        let pos = &self.pos;
        self.terms.clear();
        for &[i, j] in &self.pairs {
            for (a, b) in [(i, j), (j, i)] {
                let nb = self.normals[b as usize];
                let b0 = pos[self.triangles[b as usize][0] as usize];
                for &v in &self.triangles[a as usize] {
                    if (pos[v as usize] - b0).dot(nb) < 0.0 {
                        self.terms.push((v, b));
                    }
                }
            }
        }
        self.terms.sort_unstable();
        self.terms.dedup();
        let mut grad = vec![DVec3::ZERO; n];
        let mut total = 0.0;
        let scale = if n == 0 { 0.0 } else { 1.0 / n as f64 };
        for &(v, b) in &self.terms {
            let tri = self.triangles[b as usize];
            let [b0, b1, b2] = tri.map(|k| pos[k as usize]);
            let nrm = self.normals[b as usize];
            let len = nrm.length();
            let nh = nrm / len;
            let u = pos[v as usize] - b0;
            let s = u.dot(nh); // < 0: depth = −s
            total += s * s;
            // ∂(s²)/∂x = 2 s ∂s/∂x; s = u·n/|n|, n = ±(e1 × e2) (sign folded into nrm).
            let c = 2.0 * s * scale;
            let g_n = (u - nh * s) / len; // ∂s/∂nrm
            let sign = if self.flip[self.tri_component[b as usize] as usize] { -1.0 } else { 1.0 };
            let g_n = g_n * sign; // ∂s/∂(e1 × e2)
            let (e1, e2) = (b1 - b0, b2 - b0);
            let g_b1 = e2.cross(g_n);
            let g_b2 = g_n.cross(e1);
            grad[v as usize] += nh * c;
            grad[tri[1] as usize] += g_b1 * c;
            grad[tri[2] as usize] += g_b2 * c;
            grad[tri[0] as usize] -= (nh + g_b1 + g_b2) * c;
        }
        // Saturate rather than overflow to infinity near f32::MAX.
        let to_f32 = |x: f64| x.clamp(-f32::MAX as f64, f32::MAX as f64) as f32;
        let grad = grad.iter().map(|g| Vec3::new(to_f32(g.x), to_f32(g.y), to_f32(g.z))).collect();
        (total * scale, grad)
    }
}

/// Whether two triangles share a vertex index (branch-free).
#[inline(always)]
fn share_vertex(a: &[u32; 3], b: &[u32; 3]) -> bool {
    (a[0] == b[0])
        | (a[0] == b[1])
        | (a[0] == b[2])
        | (a[1] == b[0])
        | (a[1] == b[1])
        | (a[1] == b[2])
        | (a[2] == b[0])
        | (a[2] == b[1])
        | (a[2] == b[2])
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

/// The interior angle of triangle `tri` at its vertex `v`.
fn angle_at(pos: &[DVec3], tri: &[u32; 3], v: u32) -> f64 {
    let k = tri.iter().position(|&x| x == v).unwrap_or(0);
    let p = pos[tri[k] as usize];
    let a = pos[tri[(k + 1) % 3] as usize] - p;
    let b = pos[tri[(k + 2) % 3] as usize] - p;
    let angle = a.cross(b).length().atan2(a.dot(b));
    if angle.is_finite() {
        angle
    } else {
        0.0
    }
}

enum RayHit {
    Miss,
    Hit,
    /// Too close to an edge, a vertex or the ray's origin to decide robustly.
    Ambiguous,
}

/// Ray `o + t·d` (`t > 0`) against a non-degenerate triangle (Möller–Trumbore, f64).
fn ray_triangle(o: DVec3, d: DVec3, t: &[DVec3; 3]) -> RayHit {
    const TOL: f64 = 1e-9;
    let e1 = t[1] - t[0];
    let e2 = t[2] - t[0];
    let p = d.cross(e2);
    let det = e1.dot(p);
    let scale = e1.length() * e2.length();
    if det.abs() <= 1e-12 * scale {
        return RayHit::Miss; // parallel to the plane
    }
    let inv = 1.0 / det;
    let s = o - t[0];
    let u = s.dot(p) * inv;
    let q = s.cross(e1);
    let w = d.dot(q) * inv;
    let dist = e2.dot(q) * inv;
    if u < -TOL || w < -TOL || u + w > 1.0 + TOL {
        return RayHit::Miss;
    }
    let size = e1.length().max(e2.length());
    if dist < -TOL * size {
        return RayHit::Miss;
    }
    if dist <= TOL * size || u <= TOL || w <= TOL || u + w >= 1.0 - TOL {
        return RayHit::Ambiguous;
    }
    RayHit::Hit
}

fn find(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        let p = parent[x as usize];
        parent[x as usize] = parent[p as usize];
        x = p;
    }
    x
}

fn union(parent: &mut [u32], a: u32, b: u32) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        // Smaller index as root: deterministic.
        let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
        parent[hi as usize] = lo;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
