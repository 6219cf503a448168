//! The glTF container: GLB header and chunks, JSON validation, buffers.

use std::path::{Component, Path, PathBuf};

use super::read::LoadOptions;
use super::Reason;
use crate::io::read_regular_file;
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
    check_position_accessors(&root)?;
    // gltf-json's validation indexes arrays unchecked in places; the check above covers the one
    // known (a POSITION accessor out of range). Any other panic in it is caught and reported as
    // an invalid file rather than taking the caller down.
    let validated = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| gltf::Document::from_json(root)));
    let document = match validated {
        Ok(result) => result.map_err(|e| format!("not a valid glTF file: {e}"))?,
        Err(_) => return Err("not a valid glTF file: its JSON structure failed validation".into()),
    };
    Ok((document, blob))
}

/// Checks that every primitive's `POSITION` accessor exists (gltf-json's validation indexes it
/// unchecked and panics otherwise).
fn check_position_accessors(root: &gltf::json::Root) -> Reason<()> {
    let positions = gltf::json::validation::Checked::Valid(gltf::json::mesh::Semantic::Positions);
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            if let Some(accessor) = primitive.attributes.get(&positions) {
                if accessor.value() >= root.accessors.len() {
                    return Err(format!(
                        "not a valid glTF file: mesh {m} primitive {p} names POSITION accessor {}, but the file has \
                         only {} accessors; fix the index or re-export the model",
                        accessor.value(),
                        root.accessors.len()
                    ));
                }
            }
        }
    }
    Ok(())
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
    let bytes = &bytes[..length];
    // Walk the chunks: the `gltf` crate's own errors print the chunk type with its NUL padding.
    let mut offset = 12;
    let mut chunk = 0;
    while offset < length {
        if length - offset < 8 {
            return Err(format!("truncated GLB: chunk {chunk} header at byte {offset} is cut off"));
        }
        let declared = word(offset) as usize;
        let kind = chunk_name(&bytes[offset + 4..offset + 8]);
        let available = length - offset - 8;
        if declared > available {
            return Err(format!(
                "truncated GLB: chunk {chunk} (`{kind}`) declares {declared} bytes but only {available} remain in the \
                 file; re-export or re-download it"
            ));
        }
        offset += 8 + declared;
        chunk += 1;
    }
    Ok(bytes)
}

/// A GLB chunk type for messages: `JSON`, `BIN` (trailing NUL padding dropped), or hex bytes.
fn chunk_name(kind: &[u8]) -> String {
    let trimmed: &[u8] = match kind.iter().rposition(|&b| b != 0) {
        Some(last) => &kind[..=last],
        None => &[],
    };
    if !trimmed.is_empty() && trimmed.iter().all(|b| b.is_ascii_graphic()) {
        String::from_utf8_lossy(trimmed).into_owned()
    } else {
        kind.iter().map(|b| format!("{b:02x}")).collect()
    }
}

/// The data of every buffer: the GLB binary chunk, a base64 `data:` URI, or a file relative to
/// the glTF file, inside its folder unless `options` allow more (see [`resolve_buffer_file`]).
pub(super) fn load_buffers(
    document: &gltf::Document,
    path: &Path,
    mut blob: Option<Vec<u8>>,
    options: &LoadOptions,
) -> Result<Vec<Vec<u8>>> {
    let format = |reason: String| Error::Format { path: path.to_path_buf(), reason };
    let mut buffers = Vec::new();
    let mut total = 0u64;
    for buffer in document.buffers() {
        let index = buffer.index();
        if buffer.length() as u64 > options.max_file_bytes {
            return Err(format(format!(
                "buffer {index} declares a byteLength of {} bytes, above the limit of {} bytes \
                 (LoadOptions::max_file_bytes); raise it if the file is trusted",
                buffer.length(),
                options.max_file_bytes
            )));
        }
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
                let file = resolve_buffer_file(path, &relative, options)
                    .map_err(|reason| format(format!("buffer {index} has the URI `{uri}`: {reason}")))?;
                read_regular_file(&file, options.max_file_bytes, "a glTF buffer", super::read::TRUSTED)?
            }
        };
        total += data.len() as u64;
        if total > options.max_total_bytes {
            return Err(format(format!(
                "the buffers hold more than {} bytes together (LoadOptions::max_total_bytes); raise the limit if \
                 the file is trusted",
                options.max_total_bytes
            )));
        }
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

/// The file a relative buffer URI names, refused (with the reason) when it lies outside the folder
/// of the glTF file: an absolute path, a `..` that climbs above the folder, or a symbolic link
/// (of the file or a folder on its way) that points out of it. With
/// [`LoadOptions::allow_outside_folder`] any path is followed.
pub(super) fn resolve_buffer_file(gltf_path: &Path, relative: &str, options: &LoadOptions) -> Reason<PathBuf> {
    let folder = match gltf_path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if options.allow_outside_folder {
        return Ok(folder.join(relative));
    }
    let outside = "lies outside the model's folder; only files inside it are read (set \
                   LoadOptions::allow_outside_folder for a trusted file)";
    let mut normal = PathBuf::new();
    for component in Path::new(relative).components() {
        match component {
            Component::Normal(part) => normal.push(part),
            Component::CurDir => {}
            Component::ParentDir => {
                if !normal.pop() {
                    return Err(format!("climbs above the model's folder with `..` and {outside}"));
                }
            }
            Component::RootDir | Component::Prefix(_) => {
                return Err(format!("is an absolute path and {outside}"));
            }
        }
    }
    if normal.as_os_str().is_empty() {
        return Err("names the model's folder itself, not a file".into());
    }
    let file = folder.join(&normal);
    let canonical_folder = folder.canonicalize().map_err(|e| format!("cannot resolve the model's folder: {e}"))?;
    let canonical_file = match file.canonicalize() {
        Ok(f) => f,
        // A missing file: the read reports it, naming the file (a dangling link is refused here).
        Err(_) if !std::fs::symlink_metadata(&file).is_ok_and(|m| m.file_type().is_symlink()) => return Ok(file),
        Err(e) => return Err(format!("is a symbolic link that cannot be resolved ({e})")),
    };
    if !canonical_file.starts_with(&canonical_folder) {
        return Err(format!("resolves through a symbolic link to {} and {outside}", canonical_file.display()));
    }
    Ok(canonical_file)
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
