//! Back faces that the CPU backward's occluder lists may leave out ([`BackFaces`]) and the
//! boundary boxes that decide it ([`back_face_boundary`]).

use crate::cpu::coverage::BackFaceSkip;
use crate::scene::mesh::Topology;

/// The negative triangles (back faces) that [`bin_tiles`](super::bin_tiles) may leave out of
/// the occluder lists without changing which points they cover, and so without changing a
/// visible interval.
///
/// Why. The occluder test of `edge_grad` asks whether a point just outside a segment is covered
/// by a triangle of non-zero float area. As for the forward's [`BackFaceSkip`] (whose
/// documentation has the identity), `N₊(p) − N₋(p)`, the numbers of positive and negative
/// triangles covering a point, is the winding number of the mesh's oriented boundary, zero
/// outside the boundary's boxes. There a point covered by a negative triangle is covered by a
/// positive one, so a negative triangle whose float box misses every boundary box covers
/// nothing the positive ones do not (away from edges and vertices, which have no length on a
/// segment). Two exceptions keep a negative triangle in the lists:
/// - its snapped box, grown by two units, meets a boundary box: the identity may not hold there.
///   Snapping (`floor(x·units + 0.5)` in `f32`) moves a vertex by less than one unit within
///   ±2²² units ([`back_face_boundary`] gives no boundary beyond), so two snapped boxes at least
///   three units apart hold float boxes that do not meet;
/// - it is the rank face of a candidate edge (`kept`): the coincident-edge rule of `edge_grad`
///   gives a stretch of boundary lying on several edges to the one whose lowest face of
///   non-zero orientation (its rank) has the lowest index, and a segment learns that another
///   edge ranks first by finding that face in its lists. A candidate's faces all lie on its
///   inside, so its rank face decides alone; a positive one is listed anyway. An edge that is
///   no candidate has faces on both sides, and the one across covers the stretch's outside.
///
/// The identity needs every triangle in the sum: the backward uses this only when no triangle is
/// culled. A closed, consistently oriented mesh has no boundary box, so about half of its
/// triangles (those facing away) drop out of the lists.
#[derive(Clone, Copy, Debug)]
pub struct BackFaces<'a> {
    /// The boxes of the mesh's oriented boundary in this view (snapped units).
    pub boundary: &'a BackFaceSkip,
    /// One bit per triangle (bit `t % 64` of word `t / 64`): set for the negative rank faces of
    /// candidate edges.
    pub kept: &'a [u64],
}

impl BackFaces<'_> {
    /// Whether the negative triangle `t`, whose snapped box is `b`, may be left out.
    #[inline]
    pub fn leaves_out(&self, t: u32, b: &[i32; 4]) -> bool {
        let kept = self.kept[t as usize / 64] >> (t % 64) & 1 != 0;
        let grown = [b[0].saturating_sub(2), b[1].saturating_sub(2), b[2].saturating_add(2), b[3].saturating_add(2)];
        !kept && self.boundary.skips(grown)
    }
}

/// The boxes of the oriented boundary of `topology` seen with these snapped vertices, for
/// [`BackFaces`]; `None` when the back faces must stay in the lists: when a triangle is culled
/// (`culled_triangles`; the identity needs every triangle), or when a boundary box reaches
/// ±2²² units or beyond (there `x·units` rounds in `f32`, and snapping can move a vertex by a
/// unit or more).
pub fn back_face_boundary(topology: &Topology, snapped: &[[i32; 2]], culled_triangles: u32) -> Option<BackFaceSkip> {
    const LIMIT: i32 = 1 << 22;
    if culled_triangles != 0 {
        return None;
    }
    let boundary = BackFaceSkip::of_boundary(topology, snapped);
    boundary.boxes.iter().flatten().all(|c| c.abs() < LIMIT).then_some(boundary)
}
