//! The glTF container: GLB header and chunks, JSON validation, buffers.

use std::path::Path;

use super::Reason;
use crate::{Error, Result};

/// Parses and validates the JSON (from a GLB or a `.gltf`), returning the document and the GLB
/// binary chunk if any.
pub(super) fn parse_document(bytes: &[u8]) -> Reason<(gltf::Document, Option<Vec<u8>>)> {
    let bytes = if bytes.starts_with(b"glTF") {
        check_glb_header(bytes)?
    } else {
        let text = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
        if text.iter().find(|b| !b.is_ascii_whitespace()) != Some(&b'{') {
            return Err("not a glTF file: it neither starts with the GLB magic `glTF` nor holds a JSON object".into());
        }
        text
    };
    let gltf::Gltf { document, blob } =
        gltf::Gltf::from_slice_without_validation(bytes).map_err(|e| format!("not a valid glTF file: {e}"))?;
    let mut root = document.into_json();
    let unsupported: Vec<&str> =
        root.extensions_required.iter().map(String::as_str).filter(|e| !is_appearance_extension(e)).collect();
    if !unsupported.is_empty() {
        return Err(format!(
            "the file requires the glTF extension(s) {}, which diffsil does not support \
             (compressed or quantized geometry: decompress it first, e.g. `gltf-transform copy`)",
            unsupported.join(", ")
        ));
    }
    // The remaining required extensions only change materials or textures, which are not read.
    root.extensions_required.clear();
    let document = gltf::Document::from_json(root).map_err(|e| format!("not a valid glTF file: {e}"))?;
    Ok((document, blob))
}

/// Extensions that only affect appearance (materials, textures, lights): safe to ignore.
fn is_appearance_extension(name: &str) -> bool {
    ["KHR_materials_", "KHR_texture_", "EXT_texture_", "MSFT_texture_"].iter().any(|p| name.starts_with(p))
        || name == "KHR_lights_punctual"
}

/// Checks the GLB header (the `gltf` crate trusts its length field) and returns the bytes it
/// declares.
fn check_glb_header(bytes: &[u8]) -> Reason<&[u8]> {
    if bytes.len() < 12 {
        return Err(format!("truncated GLB: the 12-byte header is cut off after {} bytes", bytes.len()));
    }
    let word = |i: usize| u32::from_le_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
    let version = word(4);
    if version != 2 {
        return Err(format!("GLB version {version} is not supported: only glTF 2.0 (GLB version 2) is"));
    }
    let length = word(8) as usize;
    if length < 20 {
        return Err(format!(
            "invalid GLB: the header declares a total length of {length} bytes, too short for a chunk"
        ));
    }
    if length > bytes.len() {
        return Err(format!("truncated GLB: the header declares {length} bytes but the file has {}", bytes.len()));
    }
    Ok(&bytes[..length])
}

/// The data of every buffer: the GLB binary chunk, a base64 `data:` URI, or a file relative to
/// the glTF file.
pub(super) fn load_buffers(document: &gltf::Document, path: &Path, mut blob: Option<Vec<u8>>) -> Result<Vec<Vec<u8>>> {
    let format = |reason: String| Error::Format { path: path.to_path_buf(), reason };
    let mut buffers = Vec::new();
    for buffer in document.buffers() {
        let index = buffer.index();
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => blob
                .take()
                .ok_or_else(|| format(format!("buffer {index} refers to the GLB binary chunk, which is missing")))?,
            source @ gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
                gltf::buffer::Data::from_source(source, None)
                    .map_err(|e| format(format!("buffer {index}: cannot decode its data URI: {e}")))?
                    .0
            }
            gltf::buffer::Source::Uri(uri) if uri.contains(':') => {
                return Err(format(format!(
                    "buffer {index} has the URI `{uri}`: only data URIs and paths relative to the glTF file are supported"
                )));
            }
            gltf::buffer::Source::Uri(uri) => {
                let relative =
                    percent_decode(uri).ok_or_else(|| format(format!("buffer {index} has a malformed URI `{uri}`")))?;
                let file = path.parent().unwrap_or(Path::new("")).join(relative);
                std::fs::read(&file).map_err(|source| Error::Io { path: file, source })?
            }
        };
        if data.len() < buffer.length() {
            return Err(format(format!(
                "buffer {index} holds {} bytes, but its byteLength is {}",
                data.len(),
                buffer.length()
            )));
        }
        buffers.push(data);
    }
    Ok(buffers)
}

/// Decodes `%XX` escapes of a relative URI; `None` if malformed or not UTF-8.
fn percent_decode(uri: &str) -> Option<String> {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = std::str::from_utf8(bytes.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}
