//! `resolve` — CPU twin of `shaders/resolve.wgsl`: sample masks → pixel values.

use rayon::prelude::*;

use crate::mirror::RasterParams;

/// `I = p0 + (p1 − p0) · covered/F²` per pixel: exactly p0 with no sample covered, exactly p1
/// with all covered, and never outside [p0, p1] in between. Reads `masks`, writes `image`.
pub fn resolve(params: &RasterParams, masks: &[u32], image: &mut [f32]) {
    let wpp = params.words_per_pixel as usize;
    let samples = params.supersample * params.supersample;
    let (p0, p1) = (params.outside, params.inside);
    let (lo, hi) = (p0.min(p1), p0.max(p1));
    let value = |count: u32| {
        if count == 0 {
            p0
        } else if count == samples {
            p1
        } else {
            (p0 + (p1 - p0) * (count as f32 * params.inv_samples)).clamp(lo, hi)
        }
    };
    image.par_chunks_mut(4096).zip(masks.par_chunks(4096 * wpp)).for_each(|(image, masks)| {
        if wpp == 1 {
            for (v, m) in image.iter_mut().zip(masks) {
                *v = value(m.count_ones());
            }
        } else {
            for (v, m) in image.iter_mut().zip(masks.chunks_exact(wpp)) {
                *v = value(m.iter().map(|w| w.count_ones()).sum());
            }
        }
    });
}
