//! Buffer structs shared by the CPU stages and the WGSL stages (`#[repr(C)]`, bytemuck).
//! Keep each in sync with its twin in `shaders/shared/layout.wgsl`; `tests/layout.rs` checks sizes.

use crate::{Error, Result};

/// A projected vertex: pixel coordinates and whether it may be used (see [`crate::ViewParams`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ScreenVertex {
    /// Pixel coordinates (x right, y down); zero when not valid.
    pub position: [f32; 2],
    /// 1 when the vertex is in front of the camera and within the coordinate limit, else 0.
    pub valid: u32,
    /// Padding to 16 bytes.
    pub pad: u32,
}

/// Per-view raster constants (keep in sync with `RasterParams` in `shaders/shared/layout.wgsl`).
///
/// Coverage runs on a fixed-point grid of `units` per pixel. Sample column `sx` of the image sits
/// at `(2·sx + 1)·half_step` units (likewise rows), i.e. sample `a` of pixel column `j` at
/// `j + (a + ½)/F` pixels. Vertices are snapped with `round(x·units)`; edge functions are exact
/// integers, so CPU and GPU agree bit for bit.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct RasterParams {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Samples per pixel side (F).
    pub supersample: u32,
    /// Fixed-point units per pixel (`2·F·half_step`).
    pub units: u32,
    /// Half the distance between samples, in units.
    pub half_step: u32,
    /// 32-bit mask words per pixel (`ceil(F²/32)`).
    pub words_per_pixel: u32,
    /// Tile side, pixels (a power of two).
    pub tile_size: u32,
    /// Tiles per row.
    pub tiles_x: u32,
    /// Tile rows.
    pub tiles_y: u32,
    /// Value of a covered pixel (p1).
    pub inside: f32,
    /// Value of an uncovered pixel (p0).
    pub outside: f32,
    /// `1 / F²`.
    pub inv_samples: f32,
}

/// The snapped position of a clipped vertex (never a real position: snapped coordinates are
/// within ±2^29).
pub const INVALID_SNAPPED: [i32; 2] = [i32::MIN, i32::MIN];

/// Largest supported supersampling factor.
pub const MAX_SUPERSAMPLE: u32 = 16;

impl RasterParams {
    /// Raster constants for a `width × height` image with `supersample`² samples per pixel.
    /// The tile size is chosen later by the `bin` stage; here it is 1.
    pub fn new(width: u32, height: u32, supersample: u32, inside: f32, outside: f32) -> Result<RasterParams> {
        use crate::camera::MAX_RESOLUTION;
        if width == 0 || height == 0 || width > MAX_RESOLUTION || height > MAX_RESOLUTION {
            return Err(Error::InvalidResolution { width, height, max: MAX_RESOLUTION });
        }
        if supersample == 0 || supersample > MAX_SUPERSAMPLE {
            return Err(Error::InvalidSupersample(supersample));
        }
        if !(inside.is_finite() && outside.is_finite()) {
            return Err(Error::InvalidSettings(format!(
                "pixel values must be finite, got inside {inside} outside {outside}"
            )));
        }
        let half_step = 128u32.div_ceil(supersample);
        let samples = supersample * supersample;
        let mut params = RasterParams {
            width,
            height,
            supersample,
            units: 2 * supersample * half_step,
            half_step,
            words_per_pixel: samples.div_ceil(32),
            tile_size: 1,
            tiles_x: width,
            tiles_y: height,
            inside,
            outside,
            inv_samples: 1.0 / samples as f32,
        };
        params.set_tile_size(1);
        Ok(params)
    }

    /// Sets the tile side (a power of two) and the tile counts.
    pub fn set_tile_size(&mut self, tile_size: u32) {
        self.tile_size = tile_size;
        self.tiles_x = self.width.div_ceil(tile_size);
        self.tiles_y = self.height.div_ceil(tile_size);
    }

    /// Number of pixels.
    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Number of tiles.
    pub fn tile_count(&self) -> usize {
        self.tiles_x as usize * self.tiles_y as usize
    }

    /// Snaps a pixel coordinate to the fixed-point grid: `floor(x·units + 0.5)` in f32, the same
    /// arithmetic as WGSL's `snap` (exact for |x| < [`COORD_LIMIT`](crate::COORD_LIMIT)).
    #[inline]
    pub fn snap(&self, x: f32) -> i32 {
        let y = x * self.units as f32 + 0.5;
        let t = y as i32; // truncation toward zero, then down for negative non-integers
        t - (y < t as f32) as i32
    }

    /// Snaps a screen vertex; clipped vertices become [`INVALID_SNAPPED`].
    #[inline]
    pub fn snap_vertex(&self, v: &ScreenVertex) -> [i32; 2] {
        if v.valid == 0 {
            INVALID_SNAPPED
        } else {
            [self.snap(v.position[0]), self.snap(v.position[1])]
        }
    }
}

/// The gradient slot of one edge `[a, b]`: `∂L/∂a` and `∂L/∂b` in pixel coordinates.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct EdgeGrad {
    /// Gradient with respect to the edge's first vertex.
    pub a: [f32; 2],
    /// Gradient with respect to the edge's second vertex.
    pub b: [f32; 2],
}
