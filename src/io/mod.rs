//! Files in and out: meshes (Wavefront OBJ; glTF/GLB with the `pose` feature), silhouette targets
//! and rendered images (PNG).
//!
//! Every function returns [`Error::Io`] when the file cannot be opened, read or written, and
//! [`Error::Format`] (naming the file and what is wrong with it) when its content cannot be used.
//! None of them panics or hangs on malformed input, and none reads more than
//! [`MAX_FILE_BYTES`] from one file: see the README's "Untrusted input" section.

use std::io::Read;
use std::path::{Path, PathBuf};

use crate::Error;

#[cfg(feature = "pose")]
pub mod gltf;
mod obj;
mod obj_write;
mod png;
mod weld;

pub use obj::load_obj;
pub use obj_write::save_obj;
pub use png::{load_png_target, save_png, TargetMode, MAX_PNG_DECODE_BYTES};
pub use weld::weld_by_position;
#[cfg(feature = "pose")]
pub(crate) use weld::weld_map;

/// An [`Error::Format`] naming `path`.
pub(crate) fn format_error(path: &Path, reason: String) -> Error {
    Error::Format { path: PathBuf::from(path), reason }
}

/// Largest file a loader reads (an OBJ, PNG, glTF or GLB file, or one external glTF buffer):
/// 1 GiB. Larger files are refused before anything is read ([`Error::Format`]).
pub const MAX_FILE_BYTES: u64 = 1 << 30;

/// The bytes of `path`, refusing anything but a regular file (a directory, device, FIFO or socket
/// could block forever or never end) and files above `max` bytes, before reading. `what` names the
/// file in errors (e.g. "an OBJ file"), `fix` says what to do about a file above the limit.
pub(crate) fn read_regular_file(path: &Path, max: u64, what: &str, fix: &str) -> crate::Result<Vec<u8>> {
    let io = |source| Error::Io { path: path.to_path_buf(), source };
    let check = |meta: &std::fs::Metadata| {
        if !meta.is_file() {
            let kind = if meta.is_dir() { "a directory" } else { "a device, pipe or socket" };
            return Err(format_error(
                path,
                format!("is {kind}, not a regular file: {what} must be a plain file on disk"),
            ));
        }
        if meta.len() > max {
            return Err(format_error(
                path,
                format!("the file has {} bytes, above the limit of {max} bytes for {what}; {fix}", meta.len()),
            ));
        }
        Ok(())
    };
    // Checked before opening: opening a FIFO for reading blocks until a writer appears.
    check(&std::fs::metadata(path).map_err(io)?)?;
    let file = std::fs::File::open(path).map_err(io)?;
    // Checked again on the opened handle, in case the path was swapped in between.
    let meta = file.metadata().map_err(io)?;
    check(&meta)?;
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    file.take(max.saturating_add(1)).read_to_end(&mut bytes).map_err(io)?;
    if bytes.len() as u64 > max {
        return Err(format_error(path, format!("the file grew beyond the limit of {max} bytes for {what} while read")));
    }
    Ok(bytes)
}
