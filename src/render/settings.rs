//! How pixels are formed, and which engine forms them.

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
