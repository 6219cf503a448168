//! Marching tetrahedra: the zero set of a field sampled on a grid, as a closed, welded,
//! outward-oriented triangle surface.

use std::collections::HashMap;

use glam::Vec3;
use rayon::prelude::*;

use super::CELL;

/// The six tetrahedra [0, e_a, e_a + e_b, 7] of a grid cube (corner bit i = offset along axis i),
/// with the sign of each one's orientation (the parity of the axis permutation).
const TETS: [([usize; 4], bool); 6] = [
    ([0, 1, 3, 7], true),
    ([0, 1, 5, 7], false),
    ([0, 2, 3, 7], false),
    ([0, 2, 6, 7], true),
    ([0, 4, 5, 7], true),
    ([0, 4, 6, 7], false),
];

/// Marching tetrahedra over the box `[lo, hi]` with cells of side [`CELL`], each cube split into
/// the six tetrahedra around its main diagonal (a triangulation that matches across cube faces).
/// The zero set of the piecewise-linear interpolant is a closed 2-manifold as long as no grid
/// value is exactly zero, which the sampling guarantees by nudging tiny values outwards.
/// Vertices are shared per grid edge; triangles face from negative to positive values.
pub(super) fn marching_tetrahedra(
    sdf: &(impl Fn(Vec3) -> f32 + Sync),
    lo: Vec3,
    hi: Vec3,
) -> (Vec<Vec3>, Vec<[u32; 3]>) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Mesh;

    #[test]
    fn tetrahedra_orientation_signs_match_their_determinants() {
        // Guards the table marching_tetrahedra uses.
        let corner = |c: usize| Vec3::new((c & 1) as f32, ((c >> 1) & 1) as f32, ((c >> 2) & 1) as f32);
        for (tet, positive) in TETS {
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
}
