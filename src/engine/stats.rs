//! Numbers the engines report, the same on both.

/// Per-view numbers from a forward.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RenderStats {
    /// Triangles dropped, drawing nothing and getting no gradient: those wholly at or behind the
    /// near plane or at or beyond the far plane, those with a non-finite camera-space vertex, and
    /// those (clipped or not) with a vertex projected beyond [`COORD_LIMIT`](crate::COORD_LIMIT).
    pub culled_triangles: u32,
    /// Triangles crossing the near or far plane, drawn clipped to the part between them (their
    /// new vertices chained to the originals in the backward). Views given in screen space have
    /// no depth and are never clipped.
    pub clipped_triangles: u32,
    /// Edges that may lie on the silhouette (contour, boundary or one-sided non-manifold).
    pub candidate_edges: u32,
    /// Tile side in pixels chosen for binning.
    pub tile_size: u32,
}

/// Per-view counts of the (edge, pixel) segments a backward looked at.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BackwardStats {
    /// Segments of candidate edges in pixels with a non-zero incoming gradient.
    pub segments: u64,
    /// Those with a visible (unoccluded) part.
    pub visible_segments: u64,
}

impl std::ops::Add for BackwardStats {
    type Output = BackwardStats;
    fn add(self, o: BackwardStats) -> BackwardStats {
        BackwardStats {
            segments: self.segments + o.segments,
            visible_segments: self.visible_segments + o.visible_segments,
        }
    }
}

/// The GPU time one stage (one compute pass) took, or the host time of one part of a submission.
#[derive(Clone, Debug, PartialEq)]
pub struct StageTiming {
    /// The stage, named like its shader (`coverage`, `edge_grad`, …), or `host: …` for the CPU
    /// side of a submission (recording and uploads, submitting, waiting for the results), timed
    /// on the host's clock.
    pub stage: &'static str,
    /// Microseconds between the pass's start and end timestamps.
    pub microseconds: f64,
}
