//! The coarse proxy of the blurred stages: a vertex subset of the skinned mesh, re-triangulated
//! by vertex clustering, that the blurred steps render instead of the whole mesh.
//!
//! A blurred stage compares silhouettes smoothed by a Gaussian of several pixels; detail below
//! a pixel does not change its energy much, yet its step cost grows with the mesh (every
//! contour edge's segments are scanned, since the blurred `∂L/∂I` is non-zero almost
//! everywhere). The proxy keeps one vertex of each cluster — the vertices of one cell of a grid
//! over the rest pose that share their dominant joint, so that two limbs near each other in the
//! rest pose never merge — and every triangle whose corners land in three different clusters.
//! Its vertices are vertices of the mesh, so skinning, shape and their gradients carry over
//! unchanged: the proxy's positions are gathered from the skinned vertices and its vertex
//! gradient is scattered back (zero on the vertices it dropped). The blurred steps' due
//! self-intersection checks run on the proxy too ([`Proxy::check`]). Any triangle soup works:
//! open, non-manifold or disconnected meshes included.

use std::collections::HashMap;
use std::sync::Arc;

use glam::Vec3;

use super::PoseFit;
use crate::pose::self_intersection::{SelfIntersection, SelfIntersectionChecker};
use crate::pose::skin::SkinnedMesh;
use crate::{Error, Mesh, Result, Topology};

/// A vertex subset of a skinned mesh and its triangles (see the module documentation).
#[derive(Clone, Debug)]
pub(in crate::pose::fit) struct Proxy {
    /// The mesh vertex each proxy vertex is, ascending.
    kept: Vec<u32>,
    /// The proxy's triangles over the kept vertices.
    topology: Arc<Topology>,
    /// Vertices of the full mesh.
    full_count: usize,
    /// The self-intersection checker of the proxy's triangles.
    checker: SelfIntersectionChecker,
}

impl Proxy {
    /// Clusters `model`'s rest-pose vertices on a grid of cubes of side `cell` (world units,
    /// finite and > 0; taken as 2⁻³² of the mesh's extent where it is smaller) by cube and
    /// dominant joint, keeps the vertex nearest each cluster's
    /// centroid (the lowest index on a tie) and the triangles whose corners fall in three
    /// clusters (each once, whatever its winding).
    pub fn cluster(model: &SkinnedMesh, cell: f32) -> Result<Proxy> {
        if !(cell.is_finite() && cell > 0.0) {
            return Err(Error::InvalidSettings(format!("proxy cell size {cell}: use a finite size > 0")));
        }
        let positions = model.mesh.positions();
        let origin = positions.iter().fold(Vec3::splat(f32::INFINITY), |a, p| a.min(*p));
        let extent = positions.iter().fold(Vec3::ZERO, |a, p| a.max(*p - origin)).max_element();
        // Below 2⁻³² of the extent every vertex is its own cluster anyway (f32 positions that
        // close are equal but for denormals); the cell indices then fit an i64.
        let cell = cell.max(extent * 2f32.powi(-32));
        let dominant = |i: usize| {
            let (w, j) = (model.weights[i], model.joints[i]);
            let k = (0..4).fold(0, |best, k| if w[k] > w[best] { k } else { best });
            j[k]
        };
        // Cluster of each vertex, in order of first appearance.
        let mut clusters: HashMap<([i64; 3], u16), usize> = HashMap::new();
        let mut cluster_of = Vec::with_capacity(positions.len());
        let mut sums: Vec<(glam::DVec3, u32)> = Vec::new();
        for (i, p) in positions.iter().enumerate() {
            let c = ((*p - origin) / cell).floor();
            let key = ([c.x as i64, c.y as i64, c.z as i64], dominant(i));
            let next = clusters.len();
            let k = *clusters.entry(key).or_insert(next);
            if k == sums.len() {
                sums.push((glam::DVec3::ZERO, 0));
            }
            sums[k].0 += p.as_dvec3();
            sums[k].1 += 1;
            cluster_of.push(k);
        }
        let mut representative: Vec<Option<(f64, u32)>> = vec![None; sums.len()];
        for (i, p) in positions.iter().enumerate() {
            let k = cluster_of[i];
            let centroid = sums[k].0 / f64::from(sums[k].1);
            let d = (p.as_dvec3() - centroid).length_squared();
            if representative[k].is_none_or(|(best, _)| d < best) {
                representative[k] = Some((d, i as u32));
            }
        }
        let mut kept: Vec<u32> = representative.iter().map(|r| r.expect("every cluster has a vertex").1).collect();
        kept.sort_unstable();
        let mut proxy_index = vec![u32::MAX; positions.len()];
        for (j, &v) in kept.iter().enumerate() {
            proxy_index[v as usize] = j as u32;
        }
        let corner = |v: u32| proxy_index[representative[cluster_of[v as usize]].expect("kept").1 as usize];
        let mut seen = std::collections::HashSet::new();
        let mut triangles = Vec::new();
        for t in model.mesh.triangles() {
            let [a, b, c] = t.map(corner);
            if a == b || b == c || a == c {
                continue;
            }
            let mut key = [a, b, c];
            key.sort_unstable();
            if seen.insert(key) {
                triangles.push([a, b, c]);
            }
        }
        let topology = Arc::new(Topology::new(kept.len(), triangles)?);
        let checker = SelfIntersectionChecker::new(&topology);
        Ok(Proxy { kept, topology, full_count: positions.len(), checker })
    }

    /// Vertices the proxy keeps.
    pub fn vertex_count(&self) -> usize {
        self.kept.len()
    }

    /// Triangles of the proxy.
    pub fn triangle_count(&self) -> usize {
        self.topology.triangles().len()
    }

    /// The kept vertices' positions among the full mesh's `vertices`.
    fn gather(&self, vertices: &[Vec3]) -> Result<Vec<Vec3>> {
        if vertices.len() != self.full_count {
            return Err(Error::InvalidSettings(format!(
                "proxy of a {}-vertex mesh given {} vertices",
                self.full_count,
                vertices.len()
            )));
        }
        Ok(self.kept.iter().map(|&v| vertices[v as usize]).collect())
    }

    /// The proxy mesh at the full mesh's `vertices` (its kept vertices' positions).
    pub fn mesh(&self, vertices: &[Vec3]) -> Result<Mesh> {
        Mesh::with_topology(self.gather(vertices)?, Arc::clone(&self.topology))
    }

    /// The self-intersection check of the proxy at the full mesh's `vertices`, in the full
    /// mesh's terms: the gradient scattered onto the kept vertices, the inside vertices as the
    /// mesh's indices. `penalty` and `surrogate` are the proxy's (means over its vertices, which
    /// stand for the mesh's).
    pub fn check(&mut self, vertices: &[Vec3]) -> Result<SelfIntersection> {
        let mut result = self.checker.check(&self.gather(vertices)?)?;
        result.grad = self.scatter(&result.grad);
        for v in &mut result.inside_vertices {
            *v = self.kept[*v as usize];
        }
        Ok(result)
    }

    /// The full mesh's vertex gradient from the proxy's: `d` on the kept vertices, zero elsewhere.
    pub fn scatter(&self, d: &[Vec3]) -> Vec<Vec3> {
        debug_assert_eq!(d.len(), self.kept.len());
        let mut full = vec![Vec3::ZERO; self.full_count];
        for (&v, g) in self.kept.iter().zip(d) {
            full[v as usize] = *g;
        }
        full
    }
}

/// The self-intersection check of the skinned `vertices`: on `proxy` when a step renders one,
/// else on the whole mesh with `checker`.
pub(super) fn check_self_intersection(
    proxy: Option<&mut Proxy>,
    checker: &mut SelfIntersectionChecker,
    vertices: &[Vec3],
) -> Result<SelfIntersection> {
    match proxy {
        Some(proxy) => proxy.check(vertices),
        None => checker.check(vertices),
    }
}

impl PoseFit {
    /// Makes the steps blurred by `min_blur` or more (a fraction of the image height, finite
    /// and ≥ 0; never an unblurred step) render a coarse proxy of the mesh, or every step the
    /// whole mesh again (`None`): the mesh's vertices clustered on a grid of cubes of side `cell`
    /// (world units, finite and > 0) in the rest pose, one vertex kept per cube and dominant
    /// joint, and the triangles between three kept vertices. The proxy's vertices are the mesh's
    /// own, so the skinning and its gradient are unchanged; such a step's silhouette gradient
    /// reaches only the kept vertices, and its self-intersection check (when due) runs on the
    /// proxy's triangles. Unblurred steps, [`PoseFit::energy`] and the renders always use the
    /// whole mesh. Returns the proxy's vertex and triangle counts (0, 0 for `None`).
    pub fn set_coarse_proxy(&mut self, cell: Option<f32>, min_blur: f32) -> Result<(usize, usize)> {
        if !(min_blur.is_finite() && min_blur >= 0.0) {
            return Err(Error::InvalidSettings(format!("the proxy's least blur must be ≥ 0, got {min_blur}")));
        }
        self.proxy = cell.map(|cell| Proxy::cluster(&self.model, cell)).transpose()?;
        self.proxy_min_blur = min_blur;
        Ok(self.proxy.as_ref().map_or((0, 0), |p| (p.vertex_count(), p.triangle_count())))
    }

    /// Takes the coarse proxy out, so that every step renders the whole mesh until it is put
    /// back ([`PoseFit::put_coarse_proxy`]); `None` where none is set.
    pub(in crate::pose::fit) fn take_coarse_proxy(&mut self) -> Option<Proxy> {
        self.proxy.take()
    }

    /// Puts back a proxy taken out with [`PoseFit::take_coarse_proxy`].
    pub(in crate::pose::fit) fn put_coarse_proxy(&mut self, proxy: Option<Proxy>) {
        self.proxy = proxy;
    }

    /// Whether the next step renders the proxy: one is set and the blur is on and at least the
    /// proxy's least blur.
    pub(super) fn proxy_in_use(&self) -> bool {
        self.proxy.is_some() && self.blur > 0.0 && self.blur >= self.proxy_min_blur
    }

    /// The proxy when the next step renders it.
    pub(super) fn active_proxy(&self) -> Option<&Proxy> {
        self.proxy.as_ref().filter(|_| self.proxy_in_use())
    }

    /// The mesh the next step renders: the proxy at the rendered positions while it is active,
    /// else the whole rendered mesh.
    pub(super) fn rendered_mesh(&self) -> Result<Mesh> {
        match self.active_proxy() {
            Some(proxy) => proxy.mesh(self.mesh.positions()),
            None => Ok(self.mesh.clone()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pose::figure::builtin_figure;

    fn height(model: &SkinnedMesh) -> f32 {
        let (lo, hi) = model.mesh.bounds().expect("a mesh with vertices");
        hi.y - lo.y
    }

    #[test]
    fn a_cell_smaller_than_any_edge_keeps_the_whole_mesh() {
        let body = crate::pose::makehuman_body().unwrap();
        for cell in [1e-5 * height(&body), 1e-30, f32::MIN_POSITIVE] {
            let proxy = Proxy::cluster(&body, cell).unwrap();
            assert_eq!(proxy.kept, (0..body.vertex_count() as u32).collect::<Vec<_>>(), "{cell}");
            assert_eq!(proxy.topology.triangles(), body.mesh.triangles(), "{cell}");
        }
    }

    #[test]
    fn the_proxy_is_a_vertex_subset_with_triangles_between_kept_vertices() {
        let body = crate::pose::makehuman_body().unwrap();
        let proxy = Proxy::cluster(&body, 0.02 * height(&body)).unwrap();
        let n = body.vertex_count();
        // The 7k body at 2% of its height: about a fifth of its vertices and a quarter of its
        // triangles.
        assert!(proxy.vertex_count() > n / 8 && proxy.vertex_count() < n / 3, "{}", proxy.vertex_count());
        assert!(proxy.triangle_count() > body.mesh.triangles().len() / 8);
        assert!(proxy.kept.windows(2).all(|w| w[0] < w[1]));
        let mesh = proxy.mesh(body.mesh.positions()).unwrap();
        for (j, &v) in proxy.kept.iter().enumerate() {
            assert_eq!(mesh.positions()[j], body.mesh.positions()[v as usize]);
        }
        let mut seen = std::collections::HashSet::new();
        for t in mesh.triangles() {
            assert!(t[0] != t[1] && t[1] != t[2] && t[0] != t[2], "{t:?}");
            let mut key = *t;
            key.sort_unstable();
            assert!(seen.insert(key), "{t:?} twice");
        }
        let d: Vec<Vec3> = (0..proxy.vertex_count()).map(|j| Vec3::splat(j as f32 + 1.0)).collect();
        let full = proxy.scatter(&d);
        assert_eq!(full.len(), n);
        for (v, g) in full.iter().enumerate() {
            match proxy.kept.binary_search(&(v as u32)) {
                Ok(j) => assert_eq!(*g, d[j]),
                Err(_) => assert_eq!(*g, Vec3::ZERO),
            }
        }
    }

    #[test]
    fn vertices_of_different_dominant_joints_never_merge() {
        let mut figure = builtin_figure();
        let n = figure.vertex_count();
        // One cell holds the whole figure: one vertex per dominant joint.
        let cell = 10.0 * height(&figure);
        for (i, (j, w)) in figure.joints.iter_mut().zip(&mut figure.weights).enumerate() {
            *j = [u16::from(i >= n / 2), 0, 0, 0];
            *w = [1.0, 0.0, 0.0, 0.0];
        }
        let proxy = Proxy::cluster(&figure, cell).unwrap();
        assert_eq!(proxy.vertex_count(), 2);
        assert!(proxy.kept[0] < (n / 2) as u32 && proxy.kept[1] >= (n / 2) as u32, "{:?}", proxy.kept);
        assert_eq!(proxy.triangle_count(), 0);
        for j in &mut figure.joints {
            *j = [0; 4];
        }
        assert_eq!(Proxy::cluster(&figure, cell).unwrap().vertex_count(), 1);
    }

    #[test]
    fn bad_cells_and_vertex_counts_are_errors() {
        let figure = builtin_figure();
        for cell in [0.0, -0.1, f32::NAN, f32::INFINITY] {
            assert!(matches!(Proxy::cluster(&figure, cell), Err(Error::InvalidSettings(_))), "{cell}");
        }
        let proxy = Proxy::cluster(&figure, 0.05).unwrap();
        let short = &figure.mesh.positions()[1..];
        assert!(matches!(proxy.mesh(short), Err(Error::InvalidSettings(_))));
    }
}
