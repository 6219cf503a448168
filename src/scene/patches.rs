//! Face patches: the triangles of a topology grouped into small connected pieces of surface.
//!
//! A patch is grown from a seed face by breadth-first search over faces that share a vertex, up
//! to [`FacePatches::SIZE`] faces. Being connected and small on the surface, a patch stays small
//! on screen under any camera and any pose, which a run of consecutive triangle indices does not
//! (a scanned mesh such as the Stanford bunny lists its triangles in no spatial order). The CPU
//! backward tests a patch's box before its triangles' boxes when it builds its occluder lists,
//! so that the mesh's parts far from the silhouette cost one test per patch.

use super::mesh::Topology;

/// The faces of a topology in patch order, and where each patch starts.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct FacePatches {
    /// Every face index exactly once, patch after patch.
    faces: Vec<u32>,
    /// `offsets[p]..offsets[p + 1]` indexes `faces` for patch `p` (length: patches + 1).
    offsets: Vec<u32>,
}

impl FacePatches {
    /// Most faces in a patch.
    pub const SIZE: usize = 32;

    /// Groups the faces of `topology`: seeds in increasing face order (the lowest face not yet
    /// in a patch), each patch grown breadth-first over faces that share a vertex with a face
    /// of it (through the vertex's edges), visited in edge and face order, until it holds
    /// [`FacePatches::SIZE`] faces or its connected piece is used up. Deterministic. A face with
    /// no edge (all three indices equal) is reached from no other face; it joins a patch only as
    /// its seed.
    pub fn new(topology: &Topology) -> FacePatches {
        let triangles = topology.triangles();
        let mut assigned = vec![false; triangles.len()];
        let mut faces = Vec::with_capacity(triangles.len());
        let mut offsets = vec![0u32];
        for seed in 0..triangles.len() {
            if assigned[seed] {
                continue;
            }
            let start = faces.len();
            assigned[seed] = true;
            faces.push(seed as u32);
            let mut next = start;
            'grow: while next < faces.len() {
                let face = faces[next] as usize;
                next += 1;
                for &v in &triangles[face] {
                    for &e in topology.vertex_edges(v as usize) {
                        for &g in topology.edge_faces(e as usize) {
                            if faces.len() - start == Self::SIZE {
                                break 'grow;
                            }
                            if !assigned[g as usize] {
                                assigned[g as usize] = true;
                                faces.push(g);
                            }
                        }
                    }
                }
            }
            offsets.push(faces.len() as u32);
        }
        FacePatches { faces, offsets }
    }

    /// Number of patches.
    pub fn len(&self) -> usize {
        self.offsets.len() - 1
    }

    /// Whether there is no patch (a topology without triangles).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The faces of patch `p`.
    ///
    /// # Panics
    ///
    /// When `p >= self.len()`.
    pub fn patch(&self, p: usize) -> &[u32] {
        &self.faces[self.offsets[p] as usize..self.offsets[p + 1] as usize]
    }

    /// Every face exactly once, in patch order.
    pub fn faces(&self) -> &[u32] {
        &self.faces
    }

    /// The patches, in order.
    pub fn iter(&self) -> impl ExactSizeIterator<Item = &[u32]> + '_ {
        self.offsets.windows(2).map(|w| &self.faces[w[0] as usize..w[1] as usize])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::shapes;

    /// Whether the faces of `patch` are connected through shared vertices.
    fn connected(triangles: &[[u32; 3]], patch: &[u32]) -> bool {
        let mut reached = vec![patch[0]];
        let mut changed = true;
        while changed {
            changed = false;
            for &f in patch {
                if !reached.contains(&f)
                    && reached.iter().any(|&r| triangles[r as usize].iter().any(|v| triangles[f as usize].contains(v)))
                {
                    reached.push(f);
                    changed = true;
                }
            }
        }
        reached.len() == patch.len()
    }

    #[test]
    fn every_face_once_in_small_connected_patches() {
        let sphere = shapes::icosphere(3);
        // Two spheres, one with its faces listed in a scrambled order, and a degenerate face.
        let n = sphere.positions().len() as u32;
        let mut triangles: Vec<[u32; 3]> = sphere.triangles().to_vec();
        let mut other: Vec<[u32; 3]> = sphere.triangles().iter().map(|t| t.map(|v| v + n)).collect();
        let count = other.len();
        for k in 0..count {
            other.swap(k, (k * 7919) % count);
        }
        triangles.extend(other);
        triangles.push([0, 0, 0]);
        let topology = Topology::new(2 * n as usize, triangles.clone()).unwrap();
        let patches = FacePatches::new(&topology);
        let mut seen = vec![0; triangles.len()];
        for patch in patches.iter() {
            assert!(!patch.is_empty() && patch.len() <= FacePatches::SIZE);
            assert!(connected(&triangles, patch), "{patch:?}");
            for &f in patch {
                seen[f as usize] += 1;
            }
        }
        assert!(seen.iter().all(|&s| s == 1));
        assert_eq!(patches.faces().len(), triangles.len());
        assert_eq!(patches.patch(patches.len() - 1), &[triangles.len() as u32 - 1]);
        // Mostly full patches: the greedy growth leaves few fragments on a closed surface.
        let full = patches.iter().filter(|p| p.len() == FacePatches::SIZE).count();
        assert!(full * FacePatches::SIZE * 2 > triangles.len(), "{full} full of {}", patches.len());
        assert_eq!(FacePatches::new(&topology), patches);
        let empty = Topology::new(0, Vec::new()).unwrap();
        assert!(FacePatches::new(&empty).is_empty());
    }
}
