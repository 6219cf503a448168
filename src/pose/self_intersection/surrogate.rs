//! The differentiable surrogate `E_s = (1/N) Σ depth²` over the crossing pairs and its exact
//! gradient.

use glam::{DVec3, Vec3};

use super::checker::SelfIntersectionChecker;

impl SelfIntersectionChecker {
    /// `E_s` and its gradient.
    pub(super) fn surrogate(&mut self) -> (f64, Vec<Vec3>) {
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
