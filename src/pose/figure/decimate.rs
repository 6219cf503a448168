//! Decimation of the polygonised surface: shortest-edge collapses that keep it a closed
//! 2-manifold, then edge flips that improve the worst triangles.

use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap};

use glam::Vec3;

use super::CELL;

/// Decimation keeps the normals at a triangle's corners within about 45° of each other.
const MIN_SPREAD: f32 = 0.7;

/// Triangle quality: 1 for equilateral, 0 for degenerate.
fn quality(a: Vec3, b: Vec3, c: Vec3) -> f32 {
    let area2 = (b - a).cross(c - a).length();
    let sum = (b - a).length_squared() + (c - b).length_squared() + (a - c).length_squared();
    if sum > 0.0 {
        2.0 * 3f32.sqrt() * area2 / sum
    } else {
        0.0
    }
}

/// Collapses the shortest edges of a closed, oriented 2-manifold until `target` vertices remain
/// (or no edge shorter than `max_edge` can go), then collapses what is left of the very short
/// edges (under a fifth of a cell) that marching tetrahedra makes near grid nodes. A collapse
/// merges the two vertices at their midpoint moved by `project`, and is refused when it would
/// break the manifold (the link condition: the two vertices share exactly the two opposite
/// vertices of their two triangles), turn a triangle away from the field's `normal` (fold-over),
/// make the worst triangle of the two fans worse than quality 0.15, or create an edge longer than
/// `max_edge`. Orientation is kept. Returns the compacted vertices and triangles.
pub(super) fn decimate(
    pos: Vec<Vec3>,
    tris: Vec<[u32; 3]>,
    target: usize,
    max_edge: f32,
    project: impl Fn(Vec3) -> Vec3,
    normal: impl Fn(Vec3) -> Vec3,
) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let n = pos.len();
    let mut vtris: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (t, tri) in tris.iter().enumerate() {
        for &v in tri {
            vtris[v as usize].push(t as u32);
        }
    }
    let normals = pos.iter().map(|&p| normal(p).normalize_or_zero()).collect();
    let mut d = Decimator {
        tri_alive: vec![true; tris.len()],
        v_alive: vec![true; n],
        alive: n,
        pos,
        tris,
        vtris,
        normals,
        max2: max_edge * max_edge,
        tidying: false,
        project,
        normal,
    };
    d.run(d.edges(max_edge), target, max_edge);
    let short = 0.2 * CELL;
    d.tidying = true;
    for _ in 0..5 {
        if d.run(d.edges(short), 0, short) + d.remove_valence_three() == 0 {
            break;
        }
    }
    d.finish()
}

struct Decimator<P, N> {
    pos: Vec<Vec3>,
    tris: Vec<[u32; 3]>,
    vtris: Vec<Vec<u32>>,
    normals: Vec<Vec3>,
    tri_alive: Vec<bool>,
    v_alive: Vec<bool>,
    alive: usize,
    max2: f32,
    /// Collapsing only very short edges: the surface's bend across a triangle is not checked.
    tidying: bool,
    project: P,
    normal: N,
}

type EdgeHeap = BinaryHeap<Reverse<(u32, u32, u32)>>;

impl<P: Fn(Vec3) -> Vec3, N: Fn(Vec3) -> Vec3> Decimator<P, N> {
    fn len_key(&self, a: u32, b: u32) -> u32 {
        self.pos[a as usize].distance_squared(self.pos[b as usize]).to_bits()
    }

    /// Every live edge shorter than `max_len`, once, shortest first.
    fn edges(&self, max_len: f32) -> EdgeHeap {
        let mut heap = BinaryHeap::new();
        for (tri, _) in self.tris.iter().zip(&self.tri_alive).filter(|(_, &live)| live) {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                let key = self.len_key(a, b);
                if a < b && f32::from_bits(key) < max_len * max_len {
                    heap.push(Reverse((key, a, b)));
                }
            }
        }
        heap
    }

    fn neighbours(&self, v: u32) -> Vec<u32> {
        let mut out: Vec<u32> =
            self.vtris[v as usize].iter().flat_map(|&t| self.tris[t as usize]).filter(|&w| w != v).collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// Collapses edges from the heap, shortest first, until `target` vertices remain or the
    /// shortest edge is longer than `max_len`. Returns the number of collapses.
    fn run(&mut self, mut heap: EdgeHeap, target: usize, max_len: f32) -> usize {
        let mut done = 0;
        while self.alive > target {
            let Some(Reverse((key, a, b))) = heap.pop() else { break };
            if !self.v_alive[a as usize] || !self.v_alive[b as usize] || self.len_key(a, b) != key {
                continue;
            }
            if f32::from_bits(key) > max_len * max_len {
                break;
            }
            // Merge at the midpoint; when tidying, at either end if the midpoint is refused.
            let (pa, na, pb, nb) =
                (self.pos[a as usize], self.normals[a as usize], self.pos[b as usize], self.normals[b as usize]);
            let survivor = if self.collapse(a, b) || (self.tidying && self.collapse_to(a, b, pa, na)) {
                Some(a)
            } else if self.tidying && self.collapse_to(b, a, pb, nb) {
                Some(b)
            } else {
                None
            };
            if let Some(s) = survivor {
                done += 1;
                for w in self.neighbours(s) {
                    let (x, y) = (s.min(w), s.max(w));
                    heap.push(Reverse((self.len_key(x, y), x, y)));
                }
            }
        }
        done
    }

    /// Collapses each vertex with three neighbours into its nearest neighbour: such vertices
    /// block the collapse of short edges around them (the link condition). Returns the number of
    /// collapses.
    fn remove_valence_three(&mut self) -> usize {
        let mut done = 0;
        for v in 0..self.pos.len() as u32 {
            if !self.v_alive[v as usize] || self.vtris[v as usize].len() != 3 {
                continue;
            }
            let mut around = self.neighbours(v);
            around.sort_by_key(|&w| self.len_key(v, w));
            if around.iter().any(|&w| self.collapse_to(w, v, self.pos[w as usize], self.normals[w as usize])) {
                done += 1;
            }
        }
        done
    }

    /// Merges `b` into `a` if that is acceptable (see [`decimate`]).
    fn collapse(&mut self, a: u32, b: u32) -> bool {
        let p = (self.project)((self.pos[a as usize] + self.pos[b as usize]) * 0.5);
        let np = (self.normal)(p).normalize_or_zero();
        self.collapse_to(a, b, p, np)
    }

    /// Merges `b` into `a`, placed at `p` with normal `np`, if that is acceptable.
    fn collapse_to(&mut self, a: u32, b: u32, p: Vec3, np: Vec3) -> bool {
        let (au, bu) = (a as usize, b as usize);
        let shared: Vec<u32> = self.vtris[au].iter().copied().filter(|&t| self.tris[t as usize].contains(&b)).collect();
        if shared.len() != 2 {
            return false;
        }
        let nb = self.neighbours(b);
        if self.neighbours(a).iter().filter(|w| nb.binary_search(w).is_ok()).count() != 2 {
            return false;
        }
        let fans = || self.vtris[au].iter().chain(&self.vtris[bu]).copied();
        let corners = |t: u32, moved: bool| {
            self.tris[t as usize].map(|v| {
                if moved && (v == a || v == b) {
                    (p, np)
                } else {
                    (self.pos[v as usize], self.normals[v as usize])
                }
            })
        };
        let facing = |c: [(Vec3, Vec3); 3]| {
            let n = (c[1].0 - c[0].0).cross(c[2].0 - c[0].0);
            n.normalize_or_zero().dot((c[0].1 + c[1].1 + c[2].1).normalize_or_zero())
        };
        let q = |c: [(Vec3, Vec3); 3]| quality(c[0].0, c[1].0, c[2].0);
        // How much the surface turns across a triangle: the least cosine between its corners'
        // normals. Bounding it keeps triangles small where the surface bends sharply.
        let spread = |c: [(Vec3, Vec3); 3]| c[0].1.dot(c[1].1).min(c[1].1.dot(c[2].1)).min(c[2].1.dot(c[0].1));
        let worst_before = fans().map(|t| q(corners(t, false))).fold(f32::INFINITY, f32::min);
        let acceptable = fans().filter(|t| !shared.contains(t)).all(|t| {
            let after = corners(t, true);
            let long = after.iter().any(|c| c.0.distance_squared(p) > self.max2);
            let before = corners(t, false);
            !long
                && q(after) >= worst_before.min(0.15)
                && facing(after) >= facing(before).min(if self.tidying { 0.2 } else { 0.5 })
                && (self.tidying || spread(after) >= spread(before).min(MIN_SPREAD))
        });
        if !acceptable {
            return false;
        }
        for &t in &shared {
            self.tri_alive[t as usize] = false;
            for v in self.tris[t as usize] {
                self.vtris[v as usize].retain(|&x| x != t);
            }
        }
        let moved = std::mem::take(&mut self.vtris[bu]);
        for &t in &moved {
            for v in self.tris[t as usize].iter_mut() {
                if *v == b {
                    *v = a;
                }
            }
        }
        self.vtris[au].extend(moved);
        self.v_alive[bu] = false;
        self.alive -= 1;
        self.pos[au] = p;
        self.normals[au] = np;
        true
    }

    fn finish(self) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let mut remap = vec![u32::MAX; self.pos.len()];
        let mut pos = Vec::with_capacity(self.alive);
        for (v, &live) in self.v_alive.iter().enumerate() {
            if live {
                remap[v] = pos.len() as u32;
                pos.push(self.pos[v]);
            }
        }
        let tris = self
            .tris
            .iter()
            .zip(&self.tri_alive)
            .filter(|(_, &live)| live)
            .map(|(t, _)| t.map(|v| remap[v as usize]))
            .collect();
        (pos, tris)
    }
}

/// Edge flips that improve the worst of the two triangles' qualities (by 5% at least, so that
/// nothing cycles), repeated until none applies: decimation leaves some obtuse slivers that no
/// collapse can fix. A flip is refused when the new edge exists already (the manifold would
/// break) or when a new triangle would turn away from the field's `normal` at its vertices or
/// fold against its partner. Orientation is kept.
pub(super) fn flip_edges(pos: &[Vec3], tris: &mut [[u32; 3]], normal: impl Fn(Vec3) -> Vec3) {
    let normals: Vec<Vec3> = pos.iter().map(|&p| normal(p).normalize_or_zero()).collect();
    let mut owner: HashMap<(u32, u32), u32> = HashMap::with_capacity(tris.len() * 3);
    for (t, tri) in tris.iter().enumerate() {
        for k in 0..3 {
            owner.insert((tri[k], tri[(k + 1) % 3]), t as u32);
        }
    }
    let at = |v: u32| pos[v as usize];
    let face_normal = |x: u32, y: u32, z: u32| (at(y) - at(x)).cross(at(z) - at(x)).normalize_or_zero();
    let facing = |x: u32, y: u32, z: u32| {
        let reference = normals[x as usize] + normals[y as usize] + normals[z as usize];
        face_normal(x, y, z).dot(reference.normalize_or_zero())
    };
    let q = |x: u32, y: u32, z: u32| quality(at(x), at(y), at(z));
    for _ in 0..20 {
        let mut flips = 0;
        for t1 in 0..tris.len() {
            for k in 0..3 {
                let tri = tris[t1];
                let (a, b, c) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
                let Some(&t2) = owner.get(&(b, a)) else { continue };
                let t2 = t2 as usize;
                let Some(d) = tris[t2].iter().copied().find(|&v| v != a && v != b) else { continue };
                if c == d || owner.contains_key(&(c, d)) || owner.contains_key(&(d, c)) {
                    continue;
                }
                let before = q(a, b, c).min(q(b, a, d));
                let after = q(c, a, d).min(q(d, b, c));
                if after <= before * 1.05
                    || facing(c, a, d) < 0.5
                    || facing(d, b, c) < 0.5
                    || face_normal(c, a, d).dot(face_normal(d, b, c)) < 0.5
                {
                    continue;
                }
                for e in [(a, b), (b, c), (c, a), (b, a), (a, d), (d, b)] {
                    owner.remove(&e);
                }
                tris[t1] = [c, a, d];
                tris[t2] = [d, b, c];
                for (e, t) in [((c, a), t1), ((a, d), t1), ((d, c), t1), ((d, b), t2), ((b, c), t2), ((c, d), t2)] {
                    owner.insert(e, t as u32);
                }
                flips += 1;
                break;
            }
        }
        if flips == 0 {
            break;
        }
    }
}
