//! Files in and out: meshes (Wavefront OBJ; glTF/GLB with the `pose` feature), silhouette targets
//! and rendered images (PNG).
//!
//! Every function returns [`Error::Io`] when the file cannot be opened, read or written, and
//! [`Error::Format`] (naming the file and what is wrong with it) when its content cannot be used.
//! None of them panics on malformed input.

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
pub use png::{load_png_target, save_png, TargetMode};
pub use weld::weld_by_position;
#[cfg(feature = "pose")]
pub(crate) use weld::weld_map;

/// An [`Error::Format`] naming `path`.
pub(crate) fn format_error(path: &Path, reason: String) -> Error {
    Error::Format { path: PathBuf::from(path), reason }
}
