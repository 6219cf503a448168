//! Imperfect target masks: a silhouette grown or shrunk by one pixel, or with pixels flipped.

use diffsil::random::SplitMix64;
use diffsil::Image;

/// What is done to the target masks (`--mask-noise`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum MaskNoise {
    /// Exact masks.
    None,
    /// Grown by one pixel: each pixel the maximum of its 3×3 neighbourhood.
    Dilate,
    /// Shrunk by one pixel: each pixel the minimum of its 3×3 neighbourhood.
    Erode,
    /// A fraction (`--flip-fraction`) of the pixels, drawn at random, replaced by `1 − value`.
    Flip,
}

/// `image` with `noise` applied; `fraction` and `seed` drive [`MaskNoise::Flip`].
pub fn apply(noise: MaskNoise, image: &Image, fraction: f64, seed: u64) -> Image {
    let (w, h) = (image.width(), image.height());
    let neighbourhood = |pick: fn(f32, f32) -> f32, start: f32| {
        let mut out = image.clone();
        for i in 0..h {
            for j in 0..w {
                let mut v = start;
                for di in -1i64..=1 {
                    for dj in -1i64..=1 {
                        let (r, c) = (i as i64 + di, j as i64 + dj);
                        // Outside the image counts as background.
                        let x = if r < 0 || c < 0 || r >= h as i64 || c >= w as i64 {
                            0.0
                        } else {
                            image.get(r as u32, c as u32)
                        };
                        v = pick(v, x);
                    }
                }
                out.data_mut()[(i * w + j) as usize] = v;
            }
        }
        out
    };
    match noise {
        MaskNoise::None => image.clone(),
        MaskNoise::Dilate => neighbourhood(f32::max, 0.0),
        MaskNoise::Erode => neighbourhood(f32::min, 1.0),
        MaskNoise::Flip => {
            let mut out = image.clone();
            let mut rng = SplitMix64::new(seed);
            for v in out.data_mut() {
                if ((rng.next_u64() >> 11) as f64) / ((1u64 << 53) as f64) < fraction {
                    *v = 1.0 - *v;
                }
            }
            out
        }
    }
}
