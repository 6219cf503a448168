//! Wavefront OBJ meshes.

use std::path::Path;

use glam::Vec3;

use super::{format_error, weld_by_position};
use crate::{Error, Mesh, Result};

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
