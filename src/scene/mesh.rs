//! Triangle meshes and the per-topology data the renderer reuses across frames.

use std::sync::Arc;

use glam::Vec3;

use crate::{Error, Result};

/// A triangle mesh: vertex positions and triangles indexing them.
///
/// Validated on construction (indices in range, coordinates finite). The [`Topology`] is built once
/// and shared (cheaply cloned) when positions change with [`Mesh::set_positions`], so an optimisation
/// loop pays for it once. Winding does not matter: silhouettes ignore facing.
#[derive(Clone, Debug)]
pub struct Mesh {
    positions: Vec<Vec3>,
    topology: Arc<Topology>,
}

impl Mesh {
    /// Builds a mesh, checking that every index is in range and every coordinate is finite.
    pub fn new(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Result<Mesh> {
        check_finite(&positions)?;
        let topology = Topology::new(positions.len(), triangles)?;
        Ok(Mesh { positions, topology: Arc::new(topology) })
    }

    /// A mesh with new positions on an existing topology (no rebuild of the edge tables).
    pub fn with_topology(positions: Vec<Vec3>, topology: Arc<Topology>) -> Result<Mesh> {
        check_positions(topology.vertex_count(), &positions)?;
        Ok(Mesh { positions, topology })
    }

    /// Replaces the vertex positions, keeping the topology. The count must not change.
    pub fn set_positions(&mut self, positions: &[Vec3]) -> Result<()> {
        check_positions(self.positions.len(), positions)?;
        self.positions.copy_from_slice(positions);
        Ok(())
    }

    /// Vertex positions.
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    /// Triangles as vertex index triples.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.topology.triangles
    }

    /// The shared per-topology tables.
    pub fn topology(&self) -> &Arc<Topology> {
        &self.topology
    }

    /// The axis-aligned bounding box of the vertices: its lowest and highest corner, `None` for a
    /// mesh without vertices ([`bounding_box`]).
    ///
    /// ```
    /// use diffsil::{Mesh, Vec3};
    ///
    /// let corners = vec![Vec3::new(0.0, 2.0, -1.0), Vec3::new(1.0, 0.0, 3.0), Vec3::new(-2.0, 1.0, 0.0)];
    /// let triangle = Mesh::new(corners, vec![[0, 1, 2]])?;
    /// assert_eq!(triangle.bounds(), Some((Vec3::new(-2.0, 0.0, -1.0), Vec3::new(1.0, 2.0, 3.0))));
    /// # Ok::<(), diffsil::Error>(())
    /// ```
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        bounding_box(&self.positions)
    }

    /// The mesh scaled and translated so that its bounding-box centre is at the origin and its
    /// farthest vertex at distance `radius` (the benchmarks' normalisation). An empty or single-point
    /// mesh is returned centred but unscaled.
    pub fn normalized(&self, radius: f32) -> Mesh {
        let Some((lo, hi)) = self.bounds() else { return self.clone() };
        let centre = (lo + hi) * 0.5;
        let far = self.positions.iter().map(|p| (*p - centre).length()).fold(0.0f32, f32::max);
        let scale = if far > 0.0 { radius / far } else { 1.0 };
        let positions = self.positions.iter().map(|p| (*p - centre) * scale).collect();
        Mesh { positions, topology: self.topology.clone() }
    }
}

/// The axis-aligned bounding box of `points`: its lowest and highest corner, `None` for no points.
pub fn bounding_box(points: &[Vec3]) -> Option<(Vec3, Vec3)> {
    let first = *points.first()?;
    Some(points.iter().fold((first, first), |(lo, hi), p| (lo.min(*p), hi.max(*p))))
}

/// Checks vertex positions for a mesh of `expected` vertices: as many as that
/// ([`Error::LengthMismatch`]), every coordinate finite ([`Error::NonFiniteVertex`]). Shared by
/// [`Mesh`] and the self-intersection checker.
pub(crate) fn check_positions(expected: usize, positions: &[Vec3]) -> Result<()> {
    if positions.len() != expected {
        return Err(Error::LengthMismatch { what: "vertex positions", expected, got: positions.len() });
    }
    check_finite(positions)
}

/// Checks that every coordinate is finite ([`Error::NonFiniteVertex`], naming the first vertex
/// that is not).
fn check_finite(positions: &[Vec3]) -> Result<()> {
    match positions.iter().position(|p| !p.is_finite()) {
        Some(vertex) => Err(Error::NonFiniteVertex { vertex, value: positions[vertex].to_array() }),
        None => Ok(()),
    }
}

/// Per-topology tables, built once and reused for every frame and view.
///
/// - the triangles;
/// - the undirected edges `[a, b]` (`a < b`), each with its adjacent faces (CSR `edge_faces`);
/// - a static vertex → incident edges CSR (`vertex_edges`), which the `gather` stage walks to sum
///   per-edge gradient slots into per-vertex gradients in a fixed order (deterministic, atomic-free).
///
/// Triangles that repeat an index (zero-length edges) are kept for coverage, which is zero for them,
/// but contribute no edges.
#[derive(Clone, Debug)]
pub struct Topology {
    vertex_count: usize,
    triangles: Vec<[u32; 3]>,
    edges: Vec<[u32; 2]>,
    edge_face_offsets: Vec<u32>,
    edge_faces: Vec<u32>,
    vertex_edge_offsets: Vec<u32>,
    vertex_edges: Vec<u32>,
    edge_face_forward: Vec<bool>,
    edge_wings: Vec<[u32; 2]>,
    irregular_edges: Vec<u32>,
    boundary_offsets: Vec<u32>,
    boundary_vertices: Vec<u32>,
}

impl Topology {
    /// Builds the tables for `vertex_count` vertices and these triangles.
    pub fn new(vertex_count: usize, triangles: Vec<[u32; 3]>) -> Result<Topology> {
        check_triangles(vertex_count, &triangles)?;
        // Every (edge, face) incidence, sorted by edge: equal edges become runs.
        let mut incidences: Vec<([u32; 2], u32)> = Vec::with_capacity(triangles.len() * 3);
        for (face, tri) in triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                if a != b {
                    incidences.push(([a.min(b), a.max(b)], face as u32));
                }
            }
        }
        incidences.sort_unstable();
        incidences.dedup(); // a face listing the same edge twice (a, b, a) counts once
        let mut edges = Vec::new();
        let mut edge_face_offsets = vec![0u32];
        let mut edge_faces = Vec::with_capacity(incidences.len());
        for (k, &(edge, face)) in incidences.iter().enumerate() {
            if k == 0 || incidences[k - 1].0 != edge {
                if k > 0 {
                    edge_face_offsets.push(edge_faces.len() as u32);
                }
                edges.push(edge);
            }
            edge_faces.push(face);
        }
        if !edges.is_empty() {
            edge_face_offsets.push(edge_faces.len() as u32);
        }
        let (vertex_edge_offsets, vertex_edges) = vertex_csr(vertex_count, &edges);
        let mut edge_face_forward = Vec::with_capacity(edge_faces.len());
        for (e, &[a, b]) in edges.iter().enumerate() {
            let faces = &edge_faces[edge_face_offsets[e] as usize..edge_face_offsets[e + 1] as usize];
            edge_face_forward.extend(faces.iter().map(|&f| runs_forward(triangles[f as usize], a, b)));
        }
        let edge_wings = (0..edges.len())
            .map(|e| {
                let range = edge_face_offsets[e] as usize..edge_face_offsets[e + 1] as usize;
                match (&edge_faces[range.clone()], &edge_face_forward[range]) {
                    (&[f, g], &[true, false]) => [f, g],
                    (&[f, g], &[false, true]) => [g, f],
                    _ => [u32::MAX; 2],
                }
            })
            .collect::<Vec<_>>();
        let irregular_edges = (0..edges.len() as u32).filter(|&e| edge_wings[e as usize][0] == u32::MAX).collect();
        let (boundary_offsets, boundary_vertices) = boundary_components(vertex_count, &triangles);
        Ok(Topology {
            vertex_count,
            triangles,
            edges,
            edge_face_offsets,
            edge_faces,
            vertex_edge_offsets,
            vertex_edges,
            edge_face_forward,
            edge_wings,
            irregular_edges,
            boundary_offsets,
            boundary_vertices,
        })
    }

    /// For each entry of [`Topology::edge_face_list`]: whether that face runs along its edge
    /// `[a, b]` from `a` to `b` (has `a` followed by `b` in its cyclic order).
    pub fn edge_face_forward(&self) -> &[bool] {
        &self.edge_face_forward
    }

    /// For each edge `[a, b]` with exactly two faces, one running `a → b` and the other `b → a`
    /// (the usual case in a consistently oriented manifold mesh): `[the first, the second]`;
    /// `[u32::MAX; 2]` for every other edge.
    pub fn edge_wings(&self) -> &[[u32; 2]] {
        &self.edge_wings
    }

    /// The edges that [`Topology::edge_wings`] marks `[u32::MAX; 2]` (open boundary,
    /// non-manifold or inconsistently oriented ones), in increasing order.
    pub(crate) fn irregular_edges(&self) -> &[u32] {
        &self.irregular_edges
    }

    /// Whether the triangles form an oriented closed surface: every undirected edge is run as
    /// often from `a` to `b` as from `b` to `a`, counted over all triangles (a closed,
    /// consistently oriented manifold is one; so is any union of them). See
    /// [`Topology::boundary_components`].
    pub fn is_closed(&self) -> bool {
        self.boundary_vertices.is_empty()
    }

    /// The vertex sets of the connected components of the mesh's oriented boundary.
    ///
    /// The boundary is the set of directed edges that the triangles run more often one way than
    /// the other (as a chain: the sum of the triangles' directed edges, where opposite edges cancel),
    /// e.g. the rims of holes, or both sides of an edge whose faces disagree in orientation. Every
    /// vertex of it has as many boundary edges in as out, so each component is a closed loop. The
    /// CPU coverage uses them to skip back faces exactly (see `cpu::coverage`).
    pub fn boundary_components(&self) -> impl ExactSizeIterator<Item = &[u32]> + '_ {
        self.boundary_offsets.windows(2).map(|w| &self.boundary_vertices[w[0] as usize..w[1] as usize])
    }

    /// Number of vertices the triangles index into.
    pub fn vertex_count(&self) -> usize {
        self.vertex_count
    }

    /// The triangles.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// Undirected edges `[a, b]` with `a < b`, sorted.
    pub fn edges(&self) -> &[[u32; 2]] {
        &self.edges
    }

    /// Faces adjacent to edge `e` (one for an open boundary, two for a manifold edge, more for a
    /// non-manifold one).
    ///
    /// # Panics
    ///
    /// When `e` is not an edge index (`e >= edges().len()`); use [`Topology::checked_edge_faces`]
    /// for indices that may be out of range.
    pub fn edge_faces(&self, e: usize) -> &[u32] {
        match self.checked_edge_faces(e) {
            Some(faces) => faces,
            None => {
                panic!("Topology::edge_faces: edge {e} does not exist; the topology has {} edges", self.edges.len())
            }
        }
    }

    /// Faces adjacent to edge `e`, or `None` when there is no edge `e`.
    pub fn checked_edge_faces(&self, e: usize) -> Option<&[u32]> {
        let start = *self.edge_face_offsets.get(e)? as usize;
        let end = *self.edge_face_offsets.get(e.checked_add(1)?)? as usize;
        self.edge_faces.get(start..end)
    }

    /// CSR offsets of [`Topology::edge_face_list`] (length `edges + 1`).
    pub fn edge_face_offsets(&self) -> &[u32] {
        &self.edge_face_offsets
    }

    /// All edge → face lists, concatenated in edge order.
    pub fn edge_face_list(&self) -> &[u32] {
        &self.edge_faces
    }

    /// CSR offsets of [`Topology::vertex_edge_list`] (length `vertex_count + 1`).
    pub fn vertex_edge_offsets(&self) -> &[u32] {
        &self.vertex_edge_offsets
    }

    /// All vertex → incident edge lists, concatenated in vertex order, each list in edge order.
    pub fn vertex_edge_list(&self) -> &[u32] {
        &self.vertex_edges
    }

    /// Edges incident to vertex `v`.
    pub fn vertex_edges(&self, v: usize) -> &[u32] {
        &self.vertex_edges[self.vertex_edge_offsets[v] as usize..self.vertex_edge_offsets[v + 1] as usize]
    }
}

/// Checks triangles over `vertex_count` vertices: sizes that fit 32-bit indices
/// ([`Error::LengthMismatch`]) and every index in range ([`Error::IndexOutOfRange`], naming the
/// first triangle with one that is not). Shared by [`Topology::new`] and the self-intersection
/// checker.
pub(crate) fn check_triangles(vertex_count: usize, triangles: &[[u32; 3]]) -> Result<()> {
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
    Ok(())
}

/// Whether triangle `tri` has `a` followed by `b` in its cyclic order.
fn runs_forward(tri: [u32; 3], a: u32, b: u32) -> bool {
    (0..3).any(|k| tri[k] == a && tri[(k + 1) % 3] == b)
}

/// CSR (offsets, vertices) of the connected components of the oriented boundary of `triangles`
/// (see [`Topology::boundary_components`]); components in order of their smallest vertex, each
/// listing its vertices in increasing order.
fn boundary_components(vertex_count: usize, triangles: &[[u32; 3]]) -> (Vec<u32>, Vec<u32>) {
    // Net number of times each undirected edge [a, b] (a < b) is run from a to b.
    let mut directed: Vec<([u32; 2], i32)> = Vec::with_capacity(triangles.len() * 3);
    for tri in triangles {
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            if a != b {
                directed.push(([a.min(b), a.max(b)], if a < b { 1 } else { -1 }));
            }
        }
    }
    directed.sort_unstable_by_key(|d| d.0);
    // Union–find over the vertices of the unbalanced edges.
    let mut parent: Vec<u32> = (0..vertex_count as u32).collect();
    let mut on_boundary = vec![false; vertex_count];
    for run in directed.chunk_by(|x, y| x.0 == y.0) {
        if run.iter().map(|d| d.1).sum::<i32>() != 0 {
            let [a, b] = run[0].0;
            on_boundary[a as usize] = true;
            on_boundary[b as usize] = true;
            union(&mut parent, a, b);
        }
    }
    // Group the boundary vertices by root (a root is its component's smallest vertex).
    let mut members: Vec<(u32, u32)> =
        (0..vertex_count as u32).filter(|&v| on_boundary[v as usize]).map(|v| (find(&mut parent, v), v)).collect();
    members.sort_unstable();
    let mut offsets = vec![0u32];
    let mut vertices = Vec::with_capacity(members.len());
    for (k, &(r, v)) in members.iter().enumerate() {
        if k > 0 && members[k - 1].0 != r {
            offsets.push(vertices.len() as u32);
        }
        vertices.push(v);
    }
    if !vertices.is_empty() {
        offsets.push(vertices.len() as u32);
    }
    (offsets, vertices)
}

/// Union–find over vertex indices, `parent[v] == v` at roots: the root of `x`'s set, splitting the
/// path on the way (each node passed points to its grandparent). Roots are always their set's
/// smallest index (see [`union`]).
pub(crate) fn find(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        let p = parent[x as usize];
        parent[x as usize] = parent[p as usize];
        x = p;
    }
    x
}

/// Joins the sets of `a` and `b` (see [`find`]), the smaller root becoming the root: which vertex
/// ends up the root does not depend on the order of the joins.
pub(crate) fn union(parent: &mut [u32], a: u32, b: u32) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
        parent[hi as usize] = lo;
    }
}

/// CSR (offsets, items) of vertex → the items (edges, triangles) that use it: offsets of length
/// `vertex_count + 1`; each vertex's list in item order, an item listed once per vertex even where
/// it repeats the vertex.
pub(crate) fn vertex_csr<const N: usize>(vertex_count: usize, items: &[[u32; N]]) -> (Vec<u32>, Vec<u32>) {
    let mut offsets = vec![0u32; vertex_count + 1];
    for item in items {
        for (k, &v) in item.iter().enumerate() {
            if !item[..k].contains(&v) {
                offsets[v as usize + 1] += 1;
            }
        }
    }
    for v in 0..vertex_count {
        offsets[v + 1] += offsets[v];
    }
    let mut cursor = offsets.clone();
    let mut list = vec![0u32; offsets[vertex_count] as usize];
    for (k, item) in items.iter().enumerate() {
        for (i, &v) in item.iter().enumerate() {
            if !item[..i].contains(&v) {
                list[cursor[v as usize] as usize] = k as u32;
                cursor[v as usize] += 1;
            }
        }
    }
    (offsets, list)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quad_has_five_edges_and_one_shared() {
        let t = Topology::new(4, vec![[0, 1, 2], [0, 2, 3]]).unwrap();
        assert_eq!(t.edges().len(), 5);
        let shared = t.edges().iter().position(|e| *e == [0, 2]).unwrap();
        assert_eq!(t.edge_faces(shared), &[0, 1]);
        assert_eq!(t.vertex_edges(0).len(), 3);
        assert_eq!(t.vertex_edges(1).len(), 2);
    }

    #[test]
    fn boundary_components_of_open_and_closed_meshes() {
        // A tetrahedron, consistently oriented: closed.
        let tet = vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]];
        let t = Topology::new(4, tet.clone()).unwrap();
        assert!(t.is_closed());
        assert_eq!(t.boundary_components().len(), 0);
        // One face flipped: its three edges are boundary (run twice the same way).
        let mut flipped = tet.clone();
        flipped[0] = [0, 1, 2];
        let t = Topology::new(4, flipped).unwrap();
        assert!(!t.is_closed());
        assert_eq!(t.boundary_components().collect::<Vec<_>>(), vec![&[0, 1, 2][..]]);
        // Two separate quads: two rims. A degenerate face adds nothing.
        let t = Topology::new(9, vec![[0, 1, 2], [0, 2, 3], [5, 6, 7], [5, 7, 8], [4, 4, 1]]).unwrap();
        assert_eq!(t.boundary_components().collect::<Vec<_>>(), vec![&[0, 1, 2, 3][..], &[5, 6, 7, 8][..]]);
        // A doubled face (both windings) closes itself.
        assert!(Topology::new(3, vec![[0, 1, 2], [0, 2, 1]]).unwrap().is_closed());
        // Forward flags follow the faces' cyclic order.
        let t = Topology::new(4, vec![[0, 1, 2], [0, 2, 3]]).unwrap();
        let shared = t.edges().iter().position(|e| *e == [0, 2]).unwrap();
        let at = t.edge_face_offsets()[shared] as usize;
        assert_eq!(&t.edge_face_forward()[at..at + 2], &[false, true]);
        assert_eq!(t.edge_wings()[shared], [1, 0]);
        let outer = t.edges().iter().position(|e| *e == [0, 1]).unwrap();
        assert_eq!(t.edge_wings()[outer], [u32::MAX; 2]);
    }

    #[test]
    fn out_of_range_index_is_an_error() {
        let err = Topology::new(3, vec![[0, 1, 3]]).unwrap_err();
        assert!(matches!(err, Error::IndexOutOfRange { triangle: 0, index: 3, vertex_count: 3 }));
    }
}
