//! `resolve` — CPU twin of `shaders/resolve.wgsl`: sample masks → pixel values.

use rayon::prelude::*;

use crate::layout::RasterParams;

/// `I = p0 + (p1 − p0) · covered/F²` per pixel. Reads `masks`, writes `image`.
pub fn resolve(params: &RasterParams, masks: &[u32], image: &mut [f32]) {
    let wpp = params.words_per_pixel as usize;
    image.par_iter_mut().with_min_len(4096).enumerate().for_each(|(p, value)| {
        let count: u32 = masks[p * wpp..(p + 1) * wpp].iter().map(|w| w.count_ones()).sum();
        let coverage = count as f32 * params.inv_samples;
        *value = params.outside + (params.inside - params.outside) * coverage;
    });
}
