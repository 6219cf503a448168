//! Procedural closed meshes for tests, benchmarks and examples (no files needed).

use std::collections::HashMap;

use glam::Vec3;

use crate::Mesh;

/// A unit icosphere: the icosahedron with each triangle split `subdivisions` times into four,
/// vertices pushed onto the unit sphere. `20·4^subdivisions` triangles, closed and welded.
pub fn icosphere(subdivisions: u32) -> Mesh {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut positions: Vec<Vec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|p| Vec3::from_array(*p).normalize())
    .collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut midpoints: HashMap<(u32, u32), u32> = HashMap::new();
        let mut midpoint = |a: u32, b: u32, positions: &mut Vec<Vec3>| {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                positions.push(((positions[a as usize] + positions[b as usize]) * 0.5).normalize());
                positions.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(triangles.len() * 4);
        for [a, b, c] in triangles {
            let ab = midpoint(a, b, &mut positions);
            let bc = midpoint(b, c, &mut positions);
            let ca = midpoint(c, a, &mut positions);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = next;
    }
    Mesh::new(positions, triangles).expect("icosphere is valid")
}

/// A closed, lumpy, non-convex blob: a UV sphere of `rings × segments` quads
/// (`2·segments·(rings − 1)` triangles) with its radius modulated by a few low-frequency lobes and
/// fine bumps, so its contour folds over itself like a scanned object's. Deterministic.
pub fn blob(rings: u32, segments: u32) -> Mesh {
    let rings = rings.max(2);
    let segments = segments.max(3);
    let radius = |theta: f32, phi: f32| {
        1.0 + 0.18 * (3.0 * phi).sin() * theta.sin()
            + 0.12 * (2.0 * theta).cos() * (2.0 * phi + 0.7).cos()
            + 0.015 * (23.0 * theta).sin() * (29.0 * phi).sin()
    };
    let mut positions = vec![Vec3::new(0.0, radius(0.0, 0.0), 0.0)];
    for r in 1..rings {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..segments {
            let phi = std::f32::consts::TAU * s as f32 / segments as f32;
            let d = Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
            positions.push(d * radius(theta, phi));
        }
    }
    positions.push(Vec3::new(0.0, -radius(std::f32::consts::PI, 0.0), 0.0));
    let south = positions.len() as u32 - 1;
    let ring = |r: u32, s: u32| 1 + (r - 1) * segments + s % segments;
    let mut triangles = Vec::new();
    for s in 0..segments {
        triangles.push([0, ring(1, s + 1), ring(1, s)]);
        triangles.push([south, ring(rings - 1, s), ring(rings - 1, s + 1)]);
    }
    for r in 1..rings - 1 {
        for s in 0..segments {
            let (a, b, c, d) = (ring(r, s), ring(r, s + 1), ring(r + 1, s), ring(r + 1, s + 1));
            triangles.push([a, b, d]);
            triangles.push([a, d, c]);
        }
    }
    Mesh::new(positions, triangles).expect("blob is valid")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn is_closed(mesh: &Mesh) -> bool {
        let t = mesh.topology();
        (0..t.edges().len()).all(|e| t.edge_faces(e).len() == 2)
    }

    #[test]
    fn icosphere_counts_and_closed() {
        let m = icosphere(2);
        assert_eq!(m.triangles().len(), 320);
        assert_eq!(m.positions().len(), 162);
        assert!(is_closed(&m));
    }

    #[test]
    fn blob_counts_and_closed() {
        let m = blob(132, 264);
        assert_eq!(m.triangles().len(), 2 * 264 * 131);
        assert!(is_closed(&m));
    }
}
