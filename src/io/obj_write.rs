//! Writing a mesh as Wavefront OBJ.

use std::fmt::Write as _;
use std::path::Path;

use crate::{Error, Mesh, Result};

/// Writes a mesh as a Wavefront OBJ file: one `v x y z` line per vertex (the shortest decimal
/// that reads back to the same `f32`), then one `f a b c` line per triangle (1-based indices,
/// the mesh's winding). [`crate::io::load_obj`] reads it back to the same positions and
/// triangles. Errors: [`Error::Io`] when the file cannot be written; [`Error::Format`] when a
/// position is not finite.
pub fn save_obj(path: impl AsRef<Path>, mesh: &Mesh) -> Result<()> {
    let path = path.as_ref();
    let positions = mesh.positions();
    if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
        return Err(super::format_error(path, format!("cannot save: vertex {i} is {:?}, not finite", positions[i])));
    }
    let mut text = String::with_capacity(32 * (positions.len() + mesh.triangles().len()) + 64);
    text.push_str(concat!("# diffsil ", env!("CARGO_PKG_VERSION"), "\n"));
    for p in positions {
        // Writing to a String cannot fail.
        let _ = writeln!(text, "v {} {} {}", p.x, p.y, p.z);
    }
    for t in mesh.triangles() {
        let _ = writeln!(text, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    std::fs::write(path, text).map_err(|source| Error::Io { path: path.to_path_buf(), source })
}
