//! `resolve` — CPU twin of `shaders/resolve.wgsl`: sample masks → pixel values.

use rayon::prelude::*;

use crate::layout::RasterParams;

/// `I = p0 + (p1 − p0) · covered/F²` per pixel: exactly p0 with no sample covered, exactly p1
/// with all covered, and never outside [p0, p1] in between. Reads `masks`, writes `image`.
pub fn resolve(params: &RasterParams, masks: &[u32], image: &mut [f32]) {
    let wpp = params.words_per_pixel as usize;
    let samples = params.supersample * params.supersample;
    let (p0, p1) = (params.outside, params.inside);
    let (lo, hi) = (p0.min(p1), p0.max(p1));
    image.par_iter_mut().with_min_len(4096).enumerate().for_each(|(p, value)| {
        let count: u32 = masks[p * wpp..(p + 1) * wpp].iter().map(|w| w.count_ones()).sum();
        *value = if count == 0 {
            p0
        } else if count == samples {
            p1
        } else {
            (p0 + (p1 - p0) * (count as f32 * params.inv_samples)).clamp(lo, hi)
        };
    });
}
