//! How pixels are formed, which engine forms them, and the memory budget of a render.

use crate::mirror::RasterParams;
use crate::{Error, Result};

/// Most memory the per-pixel buffers of one render call may take, summed over its views: 4 GiB.
///
/// Each view holds its coverage masks (⌈F²/32⌉ 32-bit words per pixel for F×F samples) and its
/// f32 image, see [`frame_bytes`]: 16384² at F ≤ 5 takes 2 GiB and fits; 16384² at F = 16 takes
/// 9 GiB and is refused with [`Error::MemoryLimit`] before anything is allocated, on the CPU and
/// on the GPU engine alike (a GPU's own buffer limits may refuse sooner, [`Error::GpuLimit`]).
pub const MAX_FRAME_BYTES: u64 = 4 << 30;

/// Bytes of per-pixel buffers one `width × height` view takes at `supersample` F: the coverage
/// masks (⌈F²/32⌉ 32-bit words per pixel) and the f32 image.
pub fn frame_bytes(width: u32, height: u32, supersample: u32) -> u64 {
    let words = u64::from(supersample).pow(2).div_ceil(32);
    u64::from(width) * u64::from(height) * (4 * words + 4)
}

/// [`Error::MemoryLimit`] when the views' [`frame_bytes`] sum to more than [`MAX_FRAME_BYTES`].
pub(crate) fn check_frame_memory(params: &[RasterParams]) -> Result<()> {
    let needed: u64 = params.iter().map(|p| frame_bytes(p.width, p.height, p.supersample)).sum();
    if needed <= MAX_FRAME_BYTES {
        return Ok(());
    }
    let largest = params.iter().max_by_key(|p| u64::from(p.width) * u64::from(p.height));
    let what = match largest {
        Some(p) => format!(
            "rendering {} view(s), the largest {}x{}, at supersampling F = {}",
            params.len(),
            p.width,
            p.height,
            p.supersample
        ),
        None => "this render".into(),
    };
    Err(Error::MemoryLimit { what, needed, limit: MAX_FRAME_BYTES })
}

/// How pixels are formed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    /// Samples per pixel side, F (F×F samples per pixel); 1 means no anti-aliasing. 1 to 16.
    pub supersample: u32,
    /// Value inside the silhouette (p1).
    pub inside: f32,
    /// Value outside the silhouette (p0).
    pub outside: f32,
}

/// Largest magnitude of [`RenderSettings::inside`] and [`RenderSettings::outside`]: 1e18. Images,
/// losses and gradients scale with these values (and their difference), so values near the f32
/// limit would overflow.
pub const MAX_PIXEL_VALUE: f32 = 1e18;

impl RenderSettings {
    /// Checks the pixel values: finite and within ±[`MAX_PIXEL_VALUE`]. (The resolution and the
    /// supersampling factor are checked per view.)
    pub fn validate(&self) -> Result<()> {
        for (name, value) in [("inside", self.inside), ("outside", self.outside)] {
            if !value.is_finite() || value.abs() > MAX_PIXEL_VALUE {
                return Err(Error::InvalidSettings(format!(
                    "RenderSettings::{name} is {value:e}: pixel values must be finite and within \
                     ±{MAX_PIXEL_VALUE:e} (images and gradients scale with them); use e.g. 1 and 0"
                )));
            }
        }
        Ok(())
    }
}

impl Default for RenderSettings {
    /// F = 4, inside 1, outside 0.
    fn default() -> Self {
        RenderSettings { supersample: 4, inside: 1.0, outside: 0.0 }
    }
}

/// Which engine a [`crate::Renderer`] runs on.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum Backend {
    /// The CPU engine (Rust, parallel with rayon).
    Cpu,
    /// The WGSL engine on the GPU adapter these options choose (e.g.
    /// [`GpuOptions::from_env`](crate::gpu::GpuOptions::from_env)); a software adapter such as
    /// lavapipe is used when it is the one chosen. Fails with [`crate::Error::NoAdapter`] when
    /// there is none.
    #[cfg(feature = "gpu")]
    Gpu(crate::gpu::GpuOptions),
    /// A hardware GPU when there is one, else the CPU engine: a software GPU (lavapipe,
    /// llvmpipe, SwiftShader) emulates the GPU on the CPU and is slower than the CPU engine, so
    /// it is only used when asked for, by name or backend, through `DIFFSIL_ADAPTER` (or with
    /// `Backend::Gpu`). If the GPU cannot be opened, the CPU engine is used. Without the `gpu`
    /// feature, the CPU engine.
    #[default]
    Auto,
}
