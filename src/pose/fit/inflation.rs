//! The inflation nuisance parameter of a [`PoseFit`](super::PoseFit): one scalar `d` (world
//! units) that moves every rendered vertex along its normal, `v_i + d·n_i`, so that a target
//! mask uniformly too fat (`d > 0`) or too thin (`d < 0`) is explained by `d` rather than by a
//! twisted pose. The reported pose and vertices never include it.

use glam::Vec3;

/// Unit area-weighted vertex normals of a triangle mesh: each vertex sums the (unnormalised)
/// cross products `(b − a) × (c − a)` of its triangles, i.e. twice their area times their unit
/// normal, and the sum is normalised; zero for a vertex with no triangle or a degenerate fan.
pub fn vertex_normals(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Vec3> {
    let mut normals = vec![Vec3::ZERO; positions.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| i as usize);
        let n = (positions[b] - positions[a]).cross(positions[c] - positions[a]);
        for i in [a, b, c] {
            normals[i] += n;
        }
    }
    for n in &mut normals {
        *n = n.normalize_or_zero();
    }
    normals
}

/// The positions `v_i + d·n_i`.
pub(crate) fn inflate(positions: &[Vec3], normals: &[Vec3], d: f32) -> Vec<Vec3> {
    positions.iter().zip(normals).map(|(v, n)| *v + d * *n).collect()
}

/// `∂E/∂d = Σ_i ∂E/∂v_i · n_i`, the normals held constant.
pub(crate) fn gradient(d_vertices: &[Vec3], normals: &[Vec3]) -> f64 {
    d_vertices.iter().zip(normals).map(|(g, n)| f64::from(g.dot(*n))).sum()
}
