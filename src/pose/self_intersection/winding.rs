//! The inside vertices: patches of vertices that no crossing separates (union–find), each
//! classified by the winding number just outside it, counted along rays through the BVH.

use glam::{DVec3, Vec3, Vec3A};
use obvhs::ray::Ray;

use super::checker::SelfIntersectionChecker;
use super::contact::dvec;
use crate::scene::mesh::{find, union};

impl SelfIntersectionChecker {
    /// The vertices with `w⁺ ≥ 1`, ascending.
    pub(super) fn classify_vertices(&mut self, positions: &[Vec3]) -> Vec<u32> {
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
