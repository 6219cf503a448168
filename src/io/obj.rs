//! Wavefront OBJ meshes.

use std::path::Path;

use glam::Vec3;

use super::{format_error, read_regular_file, weld_by_position, MAX_FILE_BYTES};
use crate::{Mesh, Result};

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
/// Errors: [`Error::Io`](crate::Error::Io) if the file cannot be opened or read;
/// [`Error::Format`](crate::Error::Format) if it is not a
/// regular file, is larger than [`MAX_FILE_BYTES`](crate::io::MAX_FILE_BYTES), cannot be parsed
/// (a face index out of range names the line, the index and the vertex count), holds no
/// triangle, or has a non-finite coordinate.
pub fn load_obj(path: impl AsRef<Path>) -> Result<Mesh> {
    let path = path.as_ref();
    let bytes = read_regular_file(path, MAX_FILE_BYTES, "an OBJ file", "split or decimate the mesh")?;
    let text = String::from_utf8(bytes).map_err(|e| {
        format_error(path, format!("not a text OBJ file: invalid UTF-8 at byte {}", e.utf8_error().valid_up_to()))
    })?;
    let text = positions_only(&text).map_err(|reason| format_error(path, reason))?;
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

/// The OBJ text with texture and normal indices removed from `f` and `l` lines (`7/3/5` → `7`),
/// after checking every face's position indices (the error names the line, the index and the
/// vertex count).
///
/// They are not used, and tobj indexes them with unchecked arithmetic (a texture index of 0 or a
/// relative index past the start overflows); position indices it checks, but its error names
/// neither the line nor the index. Dropping them also keeps tobj from splitting vertices at seams
/// in the first place.
fn positions_only(text: &str) -> std::result::Result<String, String> {
    let keyword = |line: &str| line.split_whitespace().next().map(str::to_string);
    let total = text.lines().filter(|line| keyword(line).as_deref() == Some("v")).count();
    let mut seen = 0usize;
    let mut out = String::with_capacity(text.len());
    for (number, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                seen += 1;
                out.push_str(line);
            }
            Some(keyword @ ("f" | "l")) => {
                out.push_str(keyword);
                for word in words {
                    out.push(' ');
                    // Keep a word with no position index (`/1`) whole: tobj rejects it.
                    match word.split('/').next() {
                        Some(v) if !v.is_empty() => {
                            if keyword == "f" {
                                check_face_index(v, number + 1, seen, total)?;
                            }
                            out.push_str(v)
                        }
                        _ => out.push_str(word),
                    }
                }
            }
            _ => out.push_str(line),
        }
        out.push('\n');
    }
    Ok(out)
}

/// Checks one face position index as tobj resolves it: `1..=total` counts from the first vertex
/// of the file, `-1` is the last vertex defined before the line (`seen` of them). A word that is
/// not a number is left to tobj's own error.
fn check_face_index(word: &str, line: usize, seen: usize, total: usize) -> std::result::Result<(), String> {
    let Ok(index) = word.parse::<i64>() else {
        return Ok(());
    };
    let valid = match index {
        0 => false,
        i if i > 0 => i as u64 <= total as u64,
        i => i.unsigned_abs() <= seen as u64,
    };
    if valid {
        return Ok(());
    }
    let range = if index < 0 {
        format!("a negative index counts back from the {seen} vertices defined before this line")
    } else {
        format!("the file defines {total} vertices (`v` lines) and OBJ indices start at 1")
    };
    Err(format!(
        "line {line}: face vertex index {index} is out of range: {range}; fix the `f` line or add the missing vertices"
    ))
}
