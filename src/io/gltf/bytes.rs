//! Loading a GLB held in memory.

use std::path::Path;

use super::container::{load_buffers, parse_document};
use super::read::read_model;
use super::{LoadInfo, Model};
use crate::{Error, Result};

/// [`load_gltf_with_info`](super::load_gltf_with_info) on the bytes of a self-contained GLB (or
/// a `.gltf` with embedded `data:` buffers) held in memory. `name` stands for the path in errors;
/// a buffer that refers to an external file is looked up relative to the current directory.
pub fn load_gltf_bytes(bytes: &[u8], name: &str) -> Result<(Model, LoadInfo)> {
    let path = Path::new(name);
    let format = |reason: String| Error::Format { path: path.to_path_buf(), reason };
    let (document, blob) = parse_document(bytes).map_err(format)?;
    let buffers = load_buffers(&document, path, blob)?;
    read_model(&document, &buffers).map_err(format)
}
