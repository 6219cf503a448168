//! What the `render`, `gradient_maps` and `fit_pose` examples share: the `--backend` option, the
//! checks of their numeric options (as clap value parsers, so a bad value is reported by clap
//! with the option's name), image sizes `N` or `WxH`, loading a mesh by its extension, and a median.

// Each example uses a part of this module.
#![allow(dead_code)]

use std::path::Path;

use diffsil::gpu::GpuOptions;
use diffsil::{Backend, Mesh};

/// The `--backend` option's values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum BackendName {
    /// The CPU engine.
    Cpu,
    /// The WGSL engine on wgpu; its adapter comes from DIFFSIL_ADAPTER / WGPU_BACKEND.
    Gpu,
    /// A hardware GPU if there is one, else the CPU.
    Auto,
}

impl BackendName {
    /// The renderer backend of this name.
    pub fn backend(self) -> Backend {
        match self {
            BackendName::Cpu => Backend::Cpu,
            BackendName::Gpu => Backend::Gpu(GpuOptions::from_env()),
            BackendName::Auto => Backend::Auto,
        }
    }
}

/// A finite number.
pub fn finite(value: &str) -> Result<f32, String> {
    let x: f32 = value.trim().parse().map_err(|e| format!("{e}"))?;
    if x.is_finite() {
        Ok(x)
    } else {
        Err("must be a finite number".into())
    }
}

/// A finite number > 0.
pub fn positive(value: &str) -> Result<f32, String> {
    let x = finite(value)?;
    if x > 0.0 {
        Ok(x)
    } else {
        Err("must be > 0".into())
    }
}

/// An elevation in degrees, strictly between -90 and 90 (at ±90 the camera's up vector is
/// parallel to its viewing direction).
pub fn elevation(value: &str) -> Result<f32, String> {
    let x = finite(value)?;
    if x.abs() < 90.0 {
        Ok(x)
    } else {
        Err("use a value strictly between -90 and 90 degrees".into())
    }
}

/// A mesh file, by extension (`.obj`, `.gltf`, `.glb`; a skinned glTF in its rest pose), and its
/// file name.
pub fn load_mesh(path: &Path) -> Result<(Mesh, String), diffsil::Error> {
    let mesh = diffsil::io::gltf::load_mesh(path)?;
    let name = path.file_name().map_or("mesh".into(), |s| s.to_string_lossy().into_owned());
    Ok((mesh, name))
}

/// Median of a list of numbers; NaN when empty.
pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Parses a size: `N` (square) or `WxH`. Ranges the renderer checks itself (resolution, F) are
/// left to it, so its messages apply.
pub fn size(value: &str) -> Result<(u32, u32), String> {
    let parse = |s: &str| s.trim().parse::<u32>().map_err(|e| format!("{e} (use N or WxH)"));
    match value.split_once(['x', 'X']) {
        Some((w, h)) => Ok((parse(w)?, parse(h)?)),
        None => parse(value).map(|n| (n, n)),
    }
}
