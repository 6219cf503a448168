//! Loading meshes (Wavefront OBJ) and silhouette targets (PNG), and saving rendered images (PNG).
//!
//! Every function returns [`Error::Io`] when the file cannot be opened, read or written, and
//! [`Error::Format`] (naming the file and what is wrong with it) when its content cannot be used.
//! None of them panics on malformed input.

use std::collections::HashMap;
use std::fs::File;
use std::io::{BufReader, BufWriter, Write};
use std::path::{Path, PathBuf};

use glam::Vec3;
use image::{DynamicImage, ImageEncoder};

use crate::{Error, Image, Mesh, Result};

/// Loads a Wavefront OBJ file as one triangle mesh.
///
/// - Polygons are triangulated (as fans); points and lines are ignored; materials, texture
///   coordinates and normals (and their indices in `f` lines) are ignored.
/// - All objects/groups in the file are merged into one mesh; vertices no face uses are dropped.
/// - A vertex is never split where its texture coordinate or normal changes (UV seams, hard
///   edges), and vertices are welded by exact position with [`weld_by_position`] (some exporters
///   write one `v` line per face corner). Left split, every seam edge would have one face on each
///   side only and count as an open boundary, i.e. a silhouette edge.
///
/// Errors: [`Error::Io`] if the file cannot be opened or read; [`Error::Format`] if it cannot be
/// parsed (e.g. a face index out of range), holds no triangle, or has a non-finite coordinate.
pub fn load_obj(path: impl AsRef<Path>) -> Result<Mesh> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
    let text = String::from_utf8(bytes).map_err(|e| {
        format_error(path, format!("not a text OBJ file: invalid UTF-8 at byte {}", e.utf8_error().valid_up_to()))
    })?;
    let text = positions_only(&text);
    // `..Default::default()` covers the fields tobj adds under its optional features.
    #[allow(clippy::needless_update)]
    let options = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    };
    // Materials are not needed: never open .mtl files. The catch is only a second line of
    // defence: `positions_only` already keeps tobj off its unchecked index arithmetic.
    let parsed = std::panic::catch_unwind(|| {
        tobj::load_obj_buf(&mut text.as_bytes(), &options, |_| Err(tobj::LoadError::OpenFileFailed))
    });
    let models = match parsed {
        Ok(Ok((models, _materials))) => models,
        Ok(Err(e)) => return Err(format_error(path, format!("not a valid OBJ file: {e}"))),
        Err(_) => return Err(format_error(path, "not a valid OBJ file: malformed face indices".into())),
    };

    let mut positions: Vec<Vec3> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    for model in &models {
        let mesh = &model.mesh;
        let base = positions.len();
        if mesh.positions.len() % 3 != 0 || mesh.indices.len() % 3 != 0 {
            return Err(format_error(path, format!("object `{}` has incomplete vertex or face data", model.name)));
        }
        for p in mesh.positions.chunks_exact(3) {
            let v = Vec3::new(p[0], p[1], p[2]);
            if !v.is_finite() {
                return Err(format_error(
                    path,
                    format!(
                        "object `{}` has a vertex with a non-finite coordinate {:?}; every coordinate must be a finite number",
                        model.name,
                        v.to_array()
                    ),
                ));
            }
            positions.push(v);
        }
        let count = mesh.positions.len() / 3;
        for t in mesh.indices.chunks_exact(3) {
            if let Some(&bad) = t.iter().find(|&&i| i as usize >= count) {
                return Err(format_error(
                    path,
                    format!("object `{}` has a face index {bad} beyond its {count} vertices", model.name),
                ));
            }
            let offset = |i: u32| u32::try_from(base + i as usize).ok();
            match (offset(t[0]), offset(t[1]), offset(t[2])) {
                (Some(a), Some(b), Some(c)) => triangles.push([a, b, c]),
                _ => return Err(format_error(path, "too many vertices for 32-bit indices".into())),
            }
        }
    }
    if triangles.is_empty() {
        return Err(format_error(
            path,
            "contains no triangles: an OBJ mesh needs `v` lines and `f` lines with at least 3 vertices".into(),
        ));
    }
    let (positions, triangles) = weld_by_position(&positions, &triangles);
    Mesh::new(positions, triangles)
}

/// The OBJ text with texture and normal indices removed from `f` and `l` lines (`7/3/5` → `7`).
///
/// They are not used, and tobj indexes them with unchecked arithmetic (a texture index of 0 or a
/// relative index past the start overflows); position indices it checks. Dropping them also keeps
/// tobj from splitting vertices at seams in the first place.
fn positions_only(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for line in text.lines() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some(keyword @ ("f" | "l")) => {
                out.push_str(keyword);
                for word in words {
                    out.push(' ');
                    // Keep a word with no position index (`/1`) whole: tobj rejects it.
                    match word.split('/').next() {
                        Some(v) if !v.is_empty() => out.push_str(v),
                        _ => out.push_str(word),
                    }
                }
            }
            _ => out.push_str(line),
        }
        out.push('\n');
    }
    out
}

/// Merges vertices with exactly equal positions and remaps the triangles.
///
/// Deterministic: the output keeps the order of first occurrences (vertex k of the output is the
/// k-th distinct position met in `positions`), so an input without duplicates comes back
/// unchanged. `0.0` and `-0.0` count as equal. Triangles that become degenerate (an index
/// repeated) are kept: the renderer handles them. Unused vertices are kept. An index that is out
/// of range for `positions` becomes `u32::MAX`, which [`Mesh::new`] rejects.
pub fn weld_by_position(positions: &[Vec3], triangles: &[[u32; 3]]) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut first: HashMap<[u32; 3], u32> = HashMap::with_capacity(positions.len());
    let mut welded: Vec<Vec3> = Vec::with_capacity(positions.len());
    let remap: Vec<u32> = positions
        .iter()
        .map(|p| {
            // `+ 0.0` turns -0.0 into +0.0 so both weld; other values keep their bits.
            let key = [(p.x + 0.0).to_bits(), (p.y + 0.0).to_bits(), (p.z + 0.0).to_bits()];
            *first.entry(key).or_insert_with(|| {
                welded.push(*p);
                (welded.len() - 1) as u32
            })
        })
        .collect();
    let triangles = triangles.iter().map(|t| t.map(|i| remap.get(i as usize).copied().unwrap_or(u32::MAX))).collect();
    (welded, triangles)
}

/// Saves an image as an 8-bit grayscale PNG: each value is clamped to [0, 1], scaled by 255 and
/// rounded (NaN is written as 0).
///
/// Errors: [`Error::Io`] if the file cannot be written; [`Error::Format`] for an image with a
/// zero side, which PNG cannot store.
pub fn save_png(image: &Image, path: impl AsRef<Path>) -> Result<()> {
    let path = path.as_ref();
    if image.width() == 0 || image.height() == 0 {
        return Err(format_error(
            path,
            format!("cannot save a {}x{} image as PNG: both sides must be at least 1", image.width(), image.height()),
        ));
    }
    let bytes: Vec<u8> = image.data().iter().map(|&v| (unit(v) * 255.0).round() as u8).collect();
    let io_error = |source| Error::Io { path: path.to_path_buf(), source };
    let file = File::create(path).map_err(io_error)?;
    let mut writer = BufWriter::new(file);
    image::codecs::png::PngEncoder::new(&mut writer)
        .write_image(&bytes, image.width(), image.height(), image::ExtendedColorType::L8)
        .map_err(|e| image_error(path, e))?;
    writer.flush().map_err(io_error)
}

/// How [`load_png_target`] turns a PNG's pixels into target values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TargetMode {
    /// The pixel's value in [0, 1] (see [`load_png_target`]), kept as soft coverage.
    Coverage,
    /// A hard silhouette: 1.0 where the pixel's value is strictly greater than the threshold,
    /// else 0.0. The threshold must not be NaN.
    Threshold(f32),
}

/// Loads a PNG silhouette as a target image (row 0 at the top).
///
/// Accepts 8- and 16-bit grayscale, grayscale + alpha, RGB, RGBA and palette PNGs. A pixel's
/// value is, with every channel normalised to [0, 1]:
/// - grayscale: the gray value;
/// - RGB: the Rec. 709 luma `0.2126 R + 0.7152 G + 0.0722 B` (no gamma decoding: a silhouette
///   PNG is white on black, so this is only a tie-break for coloured masks);
/// - with alpha, the above times alpha, so transparent pixels are background. (A mask stored
///   only in the alpha channel of a black image therefore loads as all zero: convert it first.)
///
/// [`TargetMode`] then keeps that value or thresholds it to 0/1.
///
/// Errors: [`Error::Io`] if the file cannot be read; [`Error::Format`] if it is not a PNG the
/// decoder accepts; [`Error::InvalidSettings`] for a NaN threshold.
pub fn load_png_target(path: impl AsRef<Path>, mode: TargetMode) -> Result<Image> {
    let path = path.as_ref();
    if let TargetMode::Threshold(t) = mode {
        if t.is_nan() {
            return Err(Error::InvalidSettings("the target threshold is NaN: use a number such as 0.5".into()));
        }
    }
    let file = File::open(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
    let decoded = image::load(BufReader::new(file), image::ImageFormat::Png).map_err(|e| image_error(path, e))?;
    let (width, height) = (decoded.width(), decoded.height());
    let mut values = match &decoded {
        DynamicImage::ImageLuma8(b) => pixel_values(b.as_raw(), 1, u8::MAX.into()),
        DynamicImage::ImageLumaA8(b) => pixel_values(b.as_raw(), 2, u8::MAX.into()),
        DynamicImage::ImageRgb8(b) => pixel_values(b.as_raw(), 3, u8::MAX.into()),
        DynamicImage::ImageRgba8(b) => pixel_values(b.as_raw(), 4, u8::MAX.into()),
        DynamicImage::ImageLuma16(b) => pixel_values(b.as_raw(), 1, u16::MAX.into()),
        DynamicImage::ImageLumaA16(b) => pixel_values(b.as_raw(), 2, u16::MAX.into()),
        DynamicImage::ImageRgb16(b) => pixel_values(b.as_raw(), 3, u16::MAX.into()),
        DynamicImage::ImageRgba16(b) => pixel_values(b.as_raw(), 4, u16::MAX.into()),
        DynamicImage::ImageRgb32F(b) => pixel_values(b.as_raw(), 3, 1.0),
        DynamicImage::ImageRgba32F(b) => pixel_values(b.as_raw(), 4, 1.0),
        other => pixel_values(other.to_rgba32f().as_raw(), 4, 1.0),
    };
    if let TargetMode::Threshold(t) = mode {
        for v in &mut values {
            *v = if *v > t { 1.0 } else { 0.0 };
        }
    }
    Image::from_vec(width, height, values)
}

/// Per-pixel values in [0, 1] from interleaved samples with `channels` channels (1: gray,
/// 2: gray + alpha, 3: RGB, 4: RGBA) whose full scale is `max`.
fn pixel_values<T: Copy + Into<f32>>(samples: &[T], channels: usize, max: f32) -> Vec<f32> {
    let norm = |s: T| unit(s.into() / max);
    samples
        .chunks_exact(channels)
        .map(|p| {
            let colour = |p: &[T]| match p.len() {
                1 => norm(p[0]),
                _ => 0.2126 * norm(p[0]) + 0.7152 * norm(p[1]) + 0.0722 * norm(p[2]),
            };
            match channels {
                1 => norm(p[0]),
                2 => norm(p[0]) * norm(p[1]),
                3 => colour(p),
                _ => colour(&p[..3]) * norm(p[3]),
            }
        })
        .map(unit)
        .collect()
}

/// Clamps to [0, 1], mapping NaN to 0.
fn unit(v: f32) -> f32 {
    if v.is_nan() {
        0.0
    } else {
        v.clamp(0.0, 1.0)
    }
}

fn format_error(path: &Path, reason: String) -> Error {
    Error::Format { path: PathBuf::from(path), reason }
}

fn image_error(path: &Path, e: image::ImageError) -> Error {
    match e {
        image::ImageError::IoError(source) => Error::Io { path: path.to_path_buf(), source },
        other => format_error(path, format!("not a usable PNG image: {other}")),
    }
}
