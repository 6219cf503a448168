//! glTF 2.0 meshes: loading static and skinned meshes from `.gltf` / `.glb`, and writing skinned
//! meshes as `.glb`.
//!
//! # What [`load_gltf`] reads
//!
//! - **The mesh**: the first mesh (in file order) with a triangle primitive. All its triangle
//!   primitives are merged into one mesh; `TRIANGLE_STRIP` and `TRIANGLE_FAN` primitives are
//!   converted to triangles, `POINTS` and `LINE*` primitives are skipped (counted in
//!   [`LoadInfo::skipped_primitives`]). Attributes read: `POSITION` (float), indices (unsigned
//!   byte, short or int; none = sequential), and for a skinned mesh `JOINTS_0` (unsigned byte or
//!   short) and `WEIGHTS_0` (float, or normalized unsigned byte or short). Normals, texture
//!   coordinates, materials, images, morph targets and animations are ignored.
//! - **The node**: the first node (in file order) that instantiates that mesh. If it has a skin the
//!   result is [`Model::Skinned`], otherwise [`Model::Static`].
//! - **Static meshes** get the node's world transform (its own and its ancestors') applied to the
//!   positions. A mesh no node instantiates is read as is.
//! - **Skinned meshes** keep the bind-pose positions as stored; the mesh node's own transform (and
//!   its ancestors') is ignored, as the glTF spec says for skinned meshes. The skeleton is the
//!   skin's joints with:
//!   - a joint's parent = its nearest ancestor node that is also a joint of the skin; joints are
//!     reordered so parents come before children (keeping the file's order where it already is),
//!     and `JOINTS_0` is remapped to the new order;
//!   - rest translation / rotation / scale = the joint node's TRS (a `matrix` is decomposed, and a
//!     matrix with shear is rejected). Non-joint nodes *between* a joint and its parent joint have
//!     their transform folded into the child's rest transform;
//!   - `root_parent` of a root joint = world transform of its non-joint ancestors;
//!   - inverse bind matrices from `inverseBindMatrices`. A skin without them is **rejected**: the
//!     spec allows implicit identity matrices, but a real rig always has them and a missing
//!     accessor is far more often a broken export.
//!   - Weights must be finite, non-negative and sum to 1 within 1e-3; they are renormalised when
//!     the sum is off by more than 1e-6 (so already-normalised weights come back bit-exact). A
//!     zero-weight influence whose joint index is out of range gets joint 0; a non-zero one is an
//!     error. Non-zero `WEIGHTS_1` (more than 4 influences) is rejected.
//! - **Welding**: exporters split vertices at UV and normal seams. Silhouette rendering needs one
//!   vertex per position (a split seam is an open boundary, i.e. a false silhouette edge), so
//!   vertices with exactly equal positions are merged, keeping the order of first occurrences
//!   (like [`crate::io::weld_by_position`]). A merged vertex keeps the skin influences of its first
//!   occurrence; duplicates whose influences differ from it by more than 1e-4 (per joint) are
//!   counted in [`LoadInfo::weight_conflicts`].
//!
//! # Errors
//!
//! [`Error::Io`] when the file (or an external buffer file) cannot be read; [`Error::Format`],
//! naming the file and what is wrong, for anything malformed or unsupported: not glTF, truncated
//! GLB, invalid JSON or glTF structure, required extensions that change geometry
//! (`KHR_draco_mesh_compression`, `KHR_mesh_quantization`, `EXT_meshopt_compression`, …), sparse
//! accessors, accessors that overrun their buffers, indices out of range, non-finite positions,
//! no triangles, bad weights, a skin without inverse bind matrices. Nothing panics on bad input.
//!
//! # Writing
//!
//! [`save_glb`] writes a [`SkinnedMesh`] as a self-contained GLB 2.0 that [`load_gltf`] (and other
//! glTF tools) read back to the same data.

use std::collections::HashMap;
use std::path::Path;

use glam::{Mat4, Quat, Vec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::{Mode, Semantic};
use gltf::scene::Transform;

use crate::skin::{JointRest, Pose, Skeleton, SkinnedMesh};
use crate::{Error, Mesh, Result};

/// What [`load_gltf`] found in a glTF file.
#[derive(Clone, Debug)]
pub enum Model {
    /// A mesh whose node has no skin, in world space (the node's world transform is applied).
    Static(Mesh),
    /// A skinned mesh: bind-pose positions as stored, its skeleton and per-vertex influences.
    Skinned(SkinnedMesh),
}

impl Model {
    /// The mesh: world-space positions for [`Model::Static`], bind-pose positions (as stored in
    /// the file, before skinning) for [`Model::Skinned`].
    pub fn mesh(&self) -> &Mesh {
        match self {
            Model::Static(mesh) => mesh,
            Model::Skinned(skinned) => &skinned.mesh,
        }
    }
}

/// Facts about one [`load_gltf_with_info`] call, for reports and diagnostics.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LoadInfo {
    /// Index of the mesh that was read.
    pub mesh: usize,
    /// Its name, if it has one.
    pub mesh_name: Option<String>,
    /// Index of the node that instantiates it (`None` if no node does).
    pub node: Option<usize>,
    /// Vertices over the merged triangle primitives, before welding.
    pub file_vertices: usize,
    /// Vertices after welding equal positions.
    pub welded_vertices: usize,
    /// Triangles (after converting strips and fans).
    pub triangles: usize,
    /// Duplicate vertices whose skin influences differed from the kept first occurrence by more
    /// than 1e-4; always 0 for a static mesh.
    pub weight_conflicts: usize,
    /// Primitives of the mesh that were skipped because they are points or lines.
    pub skipped_primitives: usize,
}

/// Loads the first triangle mesh of a `.gltf` (embedded or external buffers) or `.glb` file, with
/// its skin if its node has one. See the [module docs](self) for what is read and how.
pub fn load_gltf(path: impl AsRef<Path>) -> Result<Model> {
    load_gltf_with_info(path).map(|(model, _)| model)
}

/// [`load_gltf`], also returning what was read and how much welding merged.
pub fn load_gltf_with_info(path: impl AsRef<Path>) -> Result<(Model, LoadInfo)> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
    let format = |reason: String| Error::Format { path: path.to_path_buf(), reason };
    let (document, blob) = parse_document(&bytes).map_err(format)?;
    let buffers = load_buffers(&document, path, blob)?;
    read_model(&document, &buffers).map_err(format)
}

/// Loads a mesh for rendering, choosing the reader by extension: `.obj` with
/// [`crate::io::load_obj`]; `.gltf` / `.glb` with [`load_gltf`]. A skinned glTF mesh comes back in
/// its rest pose (linear-blend skinning with every joint at its rest transform), which is where
/// glTF viewers show it; with the usual inverse bind matrices that is the bind pose, placed by
/// the skeleton's root transform.
pub fn load_mesh(path: impl AsRef<Path>) -> Result<Mesh> {
    let path = path.as_ref();
    let extension = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    match extension.as_deref() {
        Some("obj") => crate::io::load_obj(path),
        Some("gltf" | "glb") => match load_gltf(path)? {
            Model::Static(mesh) => Ok(mesh),
            Model::Skinned(skinned) => {
                Mesh::with_topology(skinned.skin(&Pose::rest(skinned.joint_count()))?, skinned.mesh.topology().clone())
            }
        },
        _ => Err(Error::Format {
            path: path.to_path_buf(),
            reason: "unknown mesh format: the file name must end in .obj, .gltf or .glb".into(),
        }),
    }
}

/// Inner results carry the reason only; the public functions add the path.
type Reason<T> = std::result::Result<T, String>;

// ---------------------------------------------------------------------------------------------
// Container and document
// ---------------------------------------------------------------------------------------------

/// Parses and validates the JSON (from a GLB or a `.gltf`), returning the document and the GLB
/// binary chunk if any.
fn parse_document(bytes: &[u8]) -> Reason<(gltf::Document, Option<Vec<u8>>)> {
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
fn load_buffers(document: &gltf::Document, path: &Path, mut blob: Option<Vec<u8>>) -> Result<Vec<Vec<u8>>> {
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

// ---------------------------------------------------------------------------------------------
// Accessors
// ---------------------------------------------------------------------------------------------

/// Reads an accessor's components (`count × components` values, exact as f64 for every component
/// type), after checking its type and that it lies inside its buffer view and buffer.
fn read_accessor(
    accessor: &gltf::Accessor,
    buffers: &[Vec<u8>],
    what: &str,
    dimensions: Dimensions,
    types: &[DataType],
) -> Reason<(DataType, Vec<f64>)> {
    let index = accessor.index();
    if accessor.sparse().is_some() {
        return Err(format!("{what} uses a sparse accessor (accessor {index}), which diffsil does not support"));
    }
    if accessor.dimensions() != dimensions {
        return Err(format!("{what}: accessor {index} has type {:?}, expected {dimensions:?}", accessor.dimensions()));
    }
    let data_type = accessor.data_type();
    if !types.contains(&data_type) {
        return Err(format!("{what}: accessor {index} has component type {data_type:?}, expected one of {types:?}"));
    }
    let count = accessor.count();
    if count == 0 {
        return Ok((data_type, Vec::new()));
    }
    let view = accessor.view().ok_or_else(|| format!("{what}: accessor {index} has no buffer view"))?;
    let buffer = view.buffer().index();
    let view_bytes = view
        .offset()
        .checked_add(view.length())
        .and_then(|end| buffers.get(buffer)?.get(view.offset()..end))
        .ok_or_else(|| {
            format!(
                "{what}: buffer view {} ({} bytes at offset {}) lies outside buffer {buffer}",
                view.index(),
                view.length(),
                view.offset()
            )
        })?;
    let components = dimensions.multiplicity();
    let size = data_type.size();
    let element = components * size;
    let stride = view.stride().unwrap_or(element);
    if stride < element {
        return Err(format!(
            "{what}: buffer view {} has a byte stride of {stride}, less than the {element}-byte elements",
            view.index()
        ));
    }
    let end = stride
        .checked_mul(count - 1)
        .and_then(|x| x.checked_add(element))
        .and_then(|x| x.checked_add(accessor.offset()));
    if end.is_none_or(|end| end > view_bytes.len()) {
        return Err(format!(
            "{what}: accessor {index} ({count} elements of {element} bytes, stride {stride}, offset {}) overruns \
             its buffer view {} of {} bytes",
            accessor.offset(),
            view.index(),
            view_bytes.len()
        ));
    }
    let mut values = Vec::with_capacity(count * components);
    for e in 0..count {
        let start = accessor.offset() + e * stride;
        for c in 0..components {
            let b = &view_bytes[start + c * size..start + (c + 1) * size];
            values.push(match data_type {
                DataType::I8 => f64::from(b[0] as i8),
                DataType::U8 => f64::from(b[0]),
                DataType::I16 => f64::from(i16::from_le_bytes([b[0], b[1]])),
                DataType::U16 => f64::from(u16::from_le_bytes([b[0], b[1]])),
                DataType::U32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
                DataType::F32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            });
        }
    }
    Ok((data_type, values))
}

/// Float vectors (`N` components): `F32`, or also normalized unsigned byte / short when
/// `normalized_ok` (mapped to [0, 1]).
fn read_floats<const N: usize>(
    accessor: &gltf::Accessor,
    buffers: &[Vec<u8>],
    what: &str,
    dimensions: Dimensions,
    normalized_ok: bool,
) -> Reason<Vec<[f32; N]>> {
    let types: &[DataType] =
        if normalized_ok { &[DataType::F32, DataType::U8, DataType::U16] } else { &[DataType::F32] };
    let (data_type, values) = read_accessor(accessor, buffers, what, dimensions, types)?;
    let scale = match data_type {
        DataType::U8 => 1.0 / 255.0,
        DataType::U16 => 1.0 / 65535.0,
        _ => 1.0,
    };
    if data_type != DataType::F32 && !accessor.normalized() {
        return Err(format!("{what}: integer accessor {} must be normalized", accessor.index()));
    }
    Ok(values.chunks_exact(N).map(|c| std::array::from_fn(|k| (c[k] * scale) as f32)).collect())
}

/// Triangle indices: unsigned byte, short or int scalars.
fn read_indices(accessor: &gltf::Accessor, buffers: &[Vec<u8>], what: &str) -> Reason<Vec<u32>> {
    let types = [DataType::U8, DataType::U16, DataType::U32];
    let (_, values) = read_accessor(accessor, buffers, what, Dimensions::Scalar, &types)?;
    Ok(values.into_iter().map(|v| v as u32).collect())
}

/// Joint indices: four unsigned bytes or shorts per vertex.
fn read_joints(accessor: &gltf::Accessor, buffers: &[Vec<u8>], what: &str) -> Reason<Vec<[u16; 4]>> {
    let (_, values) = read_accessor(accessor, buffers, what, Dimensions::Vec4, &[DataType::U8, DataType::U16])?;
    Ok(values.chunks_exact(4).map(|c| std::array::from_fn(|k| c[k] as u16)).collect())
}

// ---------------------------------------------------------------------------------------------
// Nodes and skin
// ---------------------------------------------------------------------------------------------

/// The node tree: parents, local matrices and (for TRS nodes) the TRS as written.
struct NodeGraph {
    parent: Vec<Option<usize>>,
    local: Vec<Mat4>,
    trs: Vec<Option<JointRest>>,
    names: Vec<String>,
}

impl NodeGraph {
    fn new(document: &gltf::Document) -> Reason<NodeGraph> {
        let count = document.nodes().len();
        let mut parent = vec![None; count];
        let (mut local, mut trs, mut names) = (Vec::new(), Vec::new(), Vec::new());
        for node in document.nodes() {
            let i = node.index();
            for child in node.children() {
                let c = child.index();
                if c == i || parent[c].is_some() {
                    return Err(format!(
                        "node {c} has more than one parent or is its own child: the node hierarchy must be a tree"
                    ));
                }
                parent[c] = Some(i);
            }
            let (matrix, rest) = match node.transform() {
                Transform::Matrix { matrix } => (Mat4::from_cols_array_2d(&matrix), None),
                Transform::Decomposed { translation, rotation, scale } => {
                    let rest = JointRest {
                        translation: Vec3::from(translation),
                        rotation: unit_quaternion(rotation).ok_or_else(|| {
                            format!("node {i} has a rotation {rotation:?} that is not a unit quaternion")
                        })?,
                        scale: Vec3::from(scale),
                    };
                    (Mat4::from_scale_rotation_translation(rest.scale, rest.rotation, rest.translation), Some(rest))
                }
            };
            if !matrix.is_finite() {
                return Err(format!("node {i} has a non-finite transform"));
            }
            local.push(matrix);
            trs.push(rest);
            names.push(node.name().unwrap_or_default().to_string());
        }
        for start in 0..count {
            let (mut node, mut steps) = (start, 0);
            while let Some(p) = parent[node] {
                node = p;
                steps += 1;
                if steps > count {
                    return Err(format!("the node hierarchy has a cycle through node {start}"));
                }
            }
        }
        Ok(NodeGraph { parent, local, trs, names })
    }

    /// World transform of a node (its local transform under all its ancestors').
    fn world(&self, node: usize) -> Mat4 {
        let mut world = self.local[node];
        let mut up = self.parent[node];
        while let Some(p) = up {
            world = self.local[p] * world;
            up = self.parent[p];
        }
        world
    }
}

/// A quaternion normalised if it is off unit length by more than rounding; `None` if it cannot be.
fn unit_quaternion(xyzw: [f32; 4]) -> Option<Quat> {
    let q = Quat::from_array(xyzw);
    let length_squared = q.length_squared();
    if !q.is_finite() || length_squared < 1e-12 {
        None
    } else if (length_squared - 1.0).abs() > 1e-6 {
        Some(q.normalize())
    } else {
        Some(q)
    }
}

/// A matrix as translation / rotation / scale, if it has no shear.
fn decompose(m: Mat4) -> Option<JointRest> {
    let (scale, rotation, translation) = m.to_scale_rotation_translation();
    let back = Mat4::from_scale_rotation_translation(scale, rotation, translation);
    let magnitude = m.to_cols_array().iter().fold(1.0f32, |a, x| a.max(x.abs()));
    let exact = back.abs_diff_eq(m, 1e-5 * magnitude) && scale.is_finite() && rotation.is_finite();
    exact.then(|| JointRest { translation, rotation: rotation.normalize(), scale })
}

/// The skin's skeleton (joints reordered parents-first) and the map from the file's joint index
/// to the skeleton's.
fn read_skin(skin: &gltf::Skin, graph: &NodeGraph, buffers: &[Vec<u8>]) -> Reason<(Skeleton, Vec<u16>)> {
    let s = skin.index();
    let nodes: Vec<usize> = skin.joints().map(|n| n.index()).collect();
    if nodes.is_empty() {
        return Err(format!("skin {s} has no joints"));
    }
    if nodes.len() > 1 << 16 {
        return Err(format!("skin {s} has {} joints; at most 65536 are supported", nodes.len()));
    }
    let mut joint_of_node = HashMap::with_capacity(nodes.len());
    for (k, &node) in nodes.iter().enumerate() {
        if joint_of_node.insert(node, k).is_some() {
            return Err(format!("skin {s} lists node {node} twice among its joints"));
        }
    }
    let accessor = skin.inverse_bind_matrices().ok_or_else(|| {
        format!(
            "skin {s}: missing inverseBindMatrices; the implicit identity matrices the spec allows are not supported \
             (re-export the rig with inverse bind matrices)"
        )
    })?;
    let ibm: Vec<[f32; 16]> =
        read_floats(&accessor, buffers, &format!("skin {s} inverse bind matrices"), Dimensions::Mat4, false)?;
    if ibm.len() < nodes.len() {
        return Err(format!("skin {s} has {} joints but only {} inverse bind matrices", nodes.len(), ibm.len()));
    }
    if ibm.iter().flatten().any(|x| !x.is_finite()) {
        return Err(format!("skin {s} has a non-finite inverse bind matrix"));
    }

    // In the file's joint order: parent joint, rest transform, root transform.
    let mut parents = Vec::with_capacity(nodes.len());
    let mut rest = Vec::with_capacity(nodes.len());
    let mut root_parent = Vec::with_capacity(nodes.len());
    for &node in &nodes {
        // Walk up to the nearest joint, accumulating the non-joint nodes passed on the way.
        let (mut between, mut up, mut parent) = (Mat4::IDENTITY, graph.parent[node], None);
        while let Some(p) = up {
            if let Some(&j) = joint_of_node.get(&p) {
                parent = Some(j);
                break;
            }
            between = graph.local[p] * between;
            up = graph.parent[p];
        }
        let folded = parent.is_some() && between != Mat4::IDENTITY;
        let joint_rest = match graph.trs[node] {
            Some(trs) if !folded => Some(trs),
            _ if folded => decompose(between * graph.local[node]),
            _ => decompose(graph.local[node]),
        };
        let joint_rest = joint_rest.ok_or_else(|| {
            format!(
                "joint node {node} (`{}`): its transform{} has shear or is singular, so it cannot be written as \
                 translation, rotation and scale",
                graph.names[node],
                if folded { ", combined with the non-joint nodes above it," } else { "" }
            )
        })?;
        parents.push(parent);
        rest.push(joint_rest);
        root_parent.push(if parent.is_none() { between } else { Mat4::IDENTITY });
    }

    let order = parents_first(&parents);
    let mut new_index = vec![0u16; nodes.len()];
    for (new, &old) in order.iter().enumerate() {
        new_index[old] = new as u16;
    }
    let skeleton = Skeleton {
        names: order.iter().map(|&j| graph.names[nodes[j]].clone()).collect(),
        parents: order.iter().map(|&j| parents[j].map(|p| usize::from(new_index[p]))).collect(),
        rest: order.iter().map(|&j| rest[j]).collect(),
        root_parent: order.iter().map(|&j| root_parent[j]).collect(),
        inverse_bind: order.iter().map(|&j| Mat4::from_cols_array(&ibm[j])).collect(),
    };
    Ok((skeleton, new_index))
}

/// An order of the joints in which parents come before children, keeping the given order where
/// it already is so (a joint is moved only after ancestors that came later).
fn parents_first(parents: &[Option<usize>]) -> Vec<usize> {
    let mut placed = vec![false; parents.len()];
    let mut order = Vec::with_capacity(parents.len());
    for joint in 0..parents.len() {
        let mut chain = Vec::new();
        let mut next = Some(joint);
        while let Some(j) = next.filter(|&j| !placed[j]) {
            chain.push(j);
            next = parents[j];
        }
        for &j in chain.iter().rev() {
            placed[j] = true;
            order.push(j);
        }
    }
    order
}

// ---------------------------------------------------------------------------------------------
// Geometry
// ---------------------------------------------------------------------------------------------

fn is_triangle_mode(mode: Mode) -> bool {
    matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan)
}

/// The merged triangle primitives of a mesh, before welding.
#[derive(Default)]
struct Geometry {
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    joints: Vec<[u16; 4]>,
    weights: Vec<[f32; 4]>,
    skipped_primitives: usize,
}

/// How the primitives' skin data is checked and remapped: the file's joint count and the map from
/// its joint indices to the skeleton's.
struct SkinMap<'a> {
    joint_count: usize,
    new_index: &'a [u16],
}

fn read_geometry(mesh: &gltf::Mesh, buffers: &[Vec<u8>], skin: Option<&SkinMap>) -> Reason<Geometry> {
    let m = mesh.index();
    let mut geometry = Geometry::default();
    for primitive in mesh.primitives() {
        let mode = primitive.mode();
        if !is_triangle_mode(mode) {
            geometry.skipped_primitives += 1;
            continue;
        }
        let at = format!("mesh {m} primitive {}", primitive.index());
        let accessor = primitive.get(&Semantic::Positions).ok_or_else(|| format!("{at} has no POSITION attribute"))?;
        let positions: Vec<[f32; 3]> =
            read_floats(&accessor, buffers, &format!("{at} POSITION"), Dimensions::Vec3, false)?;
        if let Some((v, p)) = positions.iter().enumerate().find(|(_, p)| !p.iter().all(|x| x.is_finite())) {
            return Err(format!("{at}: vertex {v} has a non-finite position {p:?}"));
        }
        let count = positions.len();
        let indices = match primitive.indices() {
            Some(accessor) => read_indices(&accessor, buffers, &format!("{at} indices"))?,
            None => (0..count as u32).collect(),
        };
        if let Some((k, bad)) = indices.iter().enumerate().find(|(_, &i)| i as usize >= count) {
            return Err(format!("{at}: index {k} is {bad}, out of range for its {count} vertices"));
        }
        let base = u32::try_from(geometry.positions.len())
            .ok()
            .filter(|&b| u32::try_from(count).is_ok_and(|c| b.checked_add(c).is_some()))
            .ok_or_else(|| format!("{at}: too many vertices for 32-bit indices"))?;
        let corner = |k: usize| indices[k] + base;
        let n = indices.len();
        match mode {
            Mode::TriangleStrip => geometry.triangles.extend((2..n).map(|k| {
                if k % 2 == 0 {
                    [corner(k - 2), corner(k - 1), corner(k)]
                } else {
                    [corner(k - 1), corner(k - 2), corner(k)]
                }
            })),
            Mode::TriangleFan => geometry.triangles.extend((2..n).map(|k| [corner(0), corner(k - 1), corner(k)])),
            _ if n % 3 != 0 => return Err(format!("{at}: {n} triangle indices is not a multiple of 3")),
            _ => geometry.triangles.extend((0..n / 3).map(|t| [corner(3 * t), corner(3 * t + 1), corner(3 * t + 2)])),
        }
        geometry.positions.extend(positions.iter().map(|&p| Vec3::from(p)));
        if let Some(skin) = skin {
            read_influences(&primitive, buffers, &at, count, skin, &mut geometry)?;
        }
    }
    if geometry.triangles.is_empty() {
        return Err(format!("mesh {m} has no triangles"));
    }
    Ok(geometry)
}

/// Reads, checks, renormalises and remaps `JOINTS_0` / `WEIGHTS_0` of one primitive.
fn read_influences(
    primitive: &gltf::Primitive,
    buffers: &[Vec<u8>],
    at: &str,
    count: usize,
    skin: &SkinMap,
    geometry: &mut Geometry,
) -> Reason<()> {
    let missing = |name: &str| format!("{at} has no {name} attribute, but its node has a skin");
    let joints_accessor = primitive.get(&Semantic::Joints(0)).ok_or_else(|| missing("JOINTS_0"))?;
    let weights_accessor = primitive.get(&Semantic::Weights(0)).ok_or_else(|| missing("WEIGHTS_0"))?;
    let joints = read_joints(&joints_accessor, buffers, &format!("{at} JOINTS_0"))?;
    let weights: Vec<[f32; 4]> =
        read_floats(&weights_accessor, buffers, &format!("{at} WEIGHTS_0"), Dimensions::Vec4, true)?;
    if joints.len() != count || weights.len() != count {
        return Err(format!(
            "{at}: {count} positions but {} JOINTS_0 and {} WEIGHTS_0 entries",
            joints.len(),
            weights.len()
        ));
    }
    let mut set = 1;
    while let Some(accessor) = primitive.get(&Semantic::Weights(set)) {
        let what = format!("{at} WEIGHTS_{set}");
        let extra: Vec<[f32; 4]> = read_floats(&accessor, buffers, &what, Dimensions::Vec4, true)?;
        if extra.iter().flatten().any(|&w| w != 0.0) {
            return Err(format!(
                "{what} has non-zero weights: more than 4 joint influences per vertex are not supported"
            ));
        }
        set += 1;
    }
    for (v, (j, w)) in joints.into_iter().zip(weights).enumerate() {
        if w.iter().any(|x| !x.is_finite() || *x < 0.0) {
            return Err(format!("{at}: vertex {v} has skin weights {w:?}; weights must be finite and non-negative"));
        }
        let sum: f32 = w.iter().sum();
        if (sum - 1.0).abs() > 1e-3 {
            return Err(format!("{at}: vertex {v} has skin weights {w:?} summing to {sum}, not 1 (within 1e-3)"));
        }
        let scale = if (sum - 1.0).abs() > 1e-6 { 1.0 / sum } else { 1.0 };
        let mut joint = [0u16; 4];
        for k in 0..4 {
            match skin.new_index.get(usize::from(j[k])) {
                Some(&new) => joint[k] = new,
                None if w[k] == 0.0 => joint[k] = 0,
                None => {
                    return Err(format!(
                        "{at}: vertex {v} uses joint {} but the skin has {} joints",
                        j[k], skin.joint_count
                    ))
                }
            }
        }
        geometry.joints.push(joint);
        geometry.weights.push(w.map(|x| x * scale));
    }
    Ok(())
}

/// Welds exactly equal positions: `remap[i]` is the welded index of vertex `i`, `kept[k]` the first
/// vertex that became welded vertex `k`. Same rule as [`crate::io::weld_by_position`].
fn weld(positions: &[Vec3]) -> (Vec<u32>, Vec<usize>) {
    let mut first: HashMap<[u32; 3], u32> = HashMap::with_capacity(positions.len());
    let mut kept = Vec::new();
    let remap = positions
        .iter()
        .enumerate()
        .map(|(i, p)| {
            // `+ 0.0` turns -0.0 into +0.0 so both weld.
            let key = [(p.x + 0.0).to_bits(), (p.y + 0.0).to_bits(), (p.z + 0.0).to_bits()];
            *first.entry(key).or_insert_with(|| {
                kept.push(i);
                (kept.len() - 1) as u32
            })
        })
        .collect();
    (remap, kept)
}

/// Whether two vertices' influences give every joint the same weight within `tolerance`.
fn same_influences(a: ([u16; 4], [f32; 4]), b: ([u16; 4], [f32; 4]), tolerance: f32) -> bool {
    let mut per_joint: Vec<(u16, f32)> = Vec::with_capacity(8);
    for (joints, weights, sign) in [(a.0, a.1, 1.0), (b.0, b.1, -1.0)] {
        for (j, w) in joints.into_iter().zip(weights) {
            match per_joint.iter_mut().find(|(k, _)| *k == j) {
                Some((_, sum)) => *sum += sign * w,
                None => per_joint.push((j, sign * w)),
            }
        }
    }
    per_joint.iter().all(|(_, d)| d.abs() <= tolerance)
}

fn read_model(document: &gltf::Document, buffers: &[Vec<u8>]) -> Reason<(Model, LoadInfo)> {
    let mesh =
        document.meshes().find(|m| m.primitives().any(|p| is_triangle_mode(p.mode()))).ok_or_else(|| match document
            .meshes()
            .len()
        {
            0 => "the file has no mesh".to_string(),
            n => format!("the file has no triangles: none of its {n} meshes has a triangle primitive"),
        })?;
    let graph = NodeGraph::new(document)?;
    let node = document.nodes().find(|n| n.mesh().is_some_and(|m| m.index() == mesh.index()));
    let skin = node.as_ref().and_then(|n| n.skin());
    let skeleton = skin.as_ref().map(|s| read_skin(s, &graph, buffers)).transpose()?;
    let skin_map = skeleton
        .as_ref()
        .map(|(skeleton, new_index)| SkinMap { joint_count: skeleton.parents.len(), new_index: new_index.as_slice() });
    let geometry = read_geometry(&mesh, buffers, skin_map.as_ref())?;

    let (remap, kept) = weld(&geometry.positions);
    let triangles: Vec<[u32; 3]> = geometry.triangles.iter().map(|t| t.map(|i| remap[i as usize])).collect();
    let mut info = LoadInfo {
        mesh: mesh.index(),
        mesh_name: mesh.name().map(str::to_string),
        node: node.as_ref().map(|n| n.index()),
        file_vertices: geometry.positions.len(),
        welded_vertices: kept.len(),
        triangles: triangles.len(),
        weight_conflicts: 0,
        skipped_primitives: geometry.skipped_primitives,
    };
    let mesh_error = |e: Error| format!("mesh {}: {e}", mesh.index());
    let model = match skeleton {
        None => {
            let world = node.map_or(Mat4::IDENTITY, |n| graph.world(n.index()));
            let positions = kept.iter().map(|&i| world.transform_point3(geometry.positions[i])).collect();
            Model::Static(Mesh::new(positions, triangles).map_err(mesh_error)?)
        }
        Some((skeleton, _)) => {
            let influence = |i: usize| (geometry.joints[i], geometry.weights[i]);
            info.weight_conflicts = (0..remap.len())
                .filter(|&i| {
                    let first = kept[remap[i] as usize];
                    first != i && !same_influences(influence(first), influence(i), 1e-4)
                })
                .count();
            let positions = kept.iter().map(|&i| geometry.positions[i]).collect();
            Model::Skinned(SkinnedMesh {
                mesh: Mesh::new(positions, triangles).map_err(mesh_error)?,
                skeleton,
                joints: kept.iter().map(|&i| geometry.joints[i]).collect(),
                weights: kept.iter().map(|&i| geometry.weights[i]).collect(),
            })
        }
    };
    Ok((model, info))
}

// ---------------------------------------------------------------------------------------------
// Writing
// ---------------------------------------------------------------------------------------------

/// Writes a skinned mesh as a GLB 2.0 file that [`load_gltf`] reads back to the same data.
///
/// Layout: one buffer (the BIN chunk) with `POSITION` (float, with min/max), `JOINTS_0` (unsigned
/// short), `WEIGHTS_0` (float), indices (unsigned int) and the inverse bind matrices; one mesh
/// node at the scene root with no transform, holding the mesh and the skin; one node per joint
/// with its rest translation / rotation / scale, its children being its child joints; and each
/// root joint whose `root_parent` is not the identity under a node carrying that matrix.
///
/// Errors: [`Error::Format`] (naming the path) if the skinned mesh is inconsistent (lengths,
/// joint indices, parents after children, non-finite values, weights not summing to 1, no
/// triangles); [`Error::Io`] if the file cannot be written.
pub fn save_glb(model: &SkinnedMesh, path: impl AsRef<Path>) -> Result<()> {
    let path = path.as_ref();
    let bytes = glb_bytes(model)
        .map_err(|reason| Error::Format { path: path.to_path_buf(), reason: format!("cannot save: {reason}") })?;
    std::fs::write(path, bytes).map_err(|source| Error::Io { path: path.to_path_buf(), source })
}

/// Checks what the GLB needs: consistent lengths and indices, finite values, unit weights.
fn check_for_save(model: &SkinnedMesh) -> Reason<()> {
    let skeleton = &model.skeleton;
    let joints = skeleton.parents.len();
    let vertices = model.mesh.positions().len();
    if joints == 0 || joints > 1 << 16 {
        return Err(format!("the skeleton has {joints} joints; 1 to 65536 are supported"));
    }
    let lengths = [skeleton.names.len(), skeleton.rest.len(), skeleton.root_parent.len(), skeleton.inverse_bind.len()];
    if lengths.iter().any(|&n| n != joints) {
        return Err(format!(
            "the skeleton has {joints} parents but {lengths:?} names, rest transforms, root transforms and inverse \
             bind matrices"
        ));
    }
    if model.joints.len() != vertices || model.weights.len() != vertices {
        return Err(format!(
            "{vertices} vertices but {} joint and {} weight entries",
            model.joints.len(),
            model.weights.len()
        ));
    }
    if model.mesh.triangles().is_empty() {
        return Err("the mesh has no triangles".into());
    }
    if let Some(j) = skeleton.parents.iter().enumerate().position(|(j, p)| p.is_some_and(|p| p >= j)) {
        return Err(format!("joint {j}'s parent does not come before it"));
    }
    let rest_finite = |r: &JointRest| r.translation.is_finite() && r.rotation.is_finite() && r.scale.is_finite();
    if let Some(j) = (0..joints).find(|&j| {
        !rest_finite(&skeleton.rest[j]) || !skeleton.root_parent[j].is_finite() || !skeleton.inverse_bind[j].is_finite()
    }) {
        return Err(format!("joint {j} has a non-finite rest, root or inverse bind transform"));
    }
    if let Some(j) = skeleton.rest.iter().position(|r| unit_quaternion(r.rotation.to_array()).is_none()) {
        return Err(format!("joint {j} has a zero rotation quaternion"));
    }
    for (v, (j, w)) in model.joints.iter().zip(&model.weights).enumerate() {
        let sum: f32 = w.iter().sum();
        if w.iter().any(|x| !x.is_finite() || *x < 0.0) || (sum - 1.0).abs() > 1e-3 {
            return Err(format!("vertex {v} has skin weights {w:?}: they must be non-negative and sum to 1"));
        }
        if let Some(k) = (0..4).find(|&k| w[k] > 0.0 && usize::from(j[k]) >= joints) {
            return Err(format!("vertex {v} uses joint {} but the skeleton has {joints}", j[k]));
        }
    }
    Ok(())
}

/// The GLB file: header, JSON chunk (space-padded) and BIN chunk (zero-padded).
fn glb_bytes(model: &SkinnedMesh) -> Reason<Vec<u8>> {
    check_for_save(model)?;
    let skeleton = &model.skeleton;
    let positions = model.mesh.positions();
    let joint_count = skeleton.parents.len();

    // Binary data; every piece is a multiple of 4 bytes, so every view is aligned.
    let mut bin: Vec<u8> = Vec::new();
    let mut views: Vec<(usize, usize, Option<u32>)> = Vec::new();
    let mut add_view = |bin: &mut Vec<u8>, bytes: Vec<u8>, target: Option<u32>| {
        views.push((bin.len(), bytes.len(), target));
        bin.extend(bytes);
    };
    const ARRAY_BUFFER: Option<u32> = Some(34962);
    const ELEMENT_ARRAY_BUFFER: Option<u32> = Some(34963);
    add_view(&mut bin, f32_bytes(positions.iter().flat_map(|p| p.to_array())), ARRAY_BUFFER);
    let joints_bytes = model
        .joints
        .iter()
        .zip(&model.weights)
        .flat_map(|(j, w)| {
            // A zero-weight influence may name any joint; write joint 0 for an out-of-range one.
            (0..4).map(move |k| if usize::from(j[k]) < joint_count || w[k] > 0.0 { j[k] } else { 0 })
        })
        .flat_map(u16::to_le_bytes)
        .collect();
    add_view(&mut bin, joints_bytes, ARRAY_BUFFER);
    add_view(&mut bin, f32_bytes(model.weights.iter().flatten().copied()), ARRAY_BUFFER);
    let index_bytes = model.mesh.triangles().iter().flatten().flat_map(|i| i.to_le_bytes()).collect();
    add_view(&mut bin, index_bytes, ELEMENT_ARRAY_BUFFER);
    add_view(&mut bin, f32_bytes(skeleton.inverse_bind.iter().flat_map(|m| m.to_cols_array())), None);

    let (min, max) =
        positions.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    let accessor = |view: usize, component: u32, count: usize, kind: &str| {
        vec![
            ("bufferView", view.to_string()),
            ("componentType", component.to_string()),
            ("count", count.to_string()),
            ("type", json::string(kind)),
        ]
    };
    let mut position_accessor = accessor(0, 5126, positions.len(), "VEC3");
    position_accessor.push(("min", json::floats(&min.to_array())));
    position_accessor.push(("max", json::floats(&max.to_array())));
    let accessors = [
        position_accessor,
        accessor(1, 5123, positions.len(), "VEC4"),
        accessor(2, 5126, positions.len(), "VEC4"),
        accessor(3, 5125, model.mesh.triangles().len() * 3, "SCALAR"),
        accessor(4, 5126, joint_count, "MAT4"),
    ];
    let buffer_views = views.iter().map(|&(offset, length, target)| {
        let mut fields =
            vec![("buffer", "0".to_string()), ("byteOffset", offset.to_string()), ("byteLength", length.to_string())];
        if let Some(target) = target {
            fields.push(("target", target.to_string()));
        }
        json::object(&fields)
    });

    // Nodes: 0 = mesh, 1 + j = joint j, then one holder per root joint with a root transform.
    let mut nodes = vec![json::object(&[("name", json::string("mesh")), ("mesh", "0".into()), ("skin", "0".into())])];
    for (j, rest) in skeleton.rest.iter().enumerate() {
        let mut fields = vec![("name", json::string(&skeleton.names[j]))];
        if rest.translation != Vec3::ZERO {
            fields.push(("translation", json::floats(&rest.translation.to_array())));
        }
        let rotation = unit_quaternion(rest.rotation.to_array()).unwrap_or(Quat::IDENTITY);
        if rotation != Quat::IDENTITY {
            fields.push(("rotation", json::floats(&rotation.to_array())));
        }
        if rest.scale != Vec3::ONE {
            fields.push(("scale", json::floats(&rest.scale.to_array())));
        }
        let children: Vec<String> =
            (0..joint_count).filter(|&c| skeleton.parents[c] == Some(j)).map(|c| (1 + c).to_string()).collect();
        if !children.is_empty() {
            fields.push(("children", json::array(children)));
        }
        nodes.push(json::object(&fields));
    }
    let mut scene_nodes = vec!["0".to_string()];
    for j in (0..joint_count).filter(|&j| skeleton.parents[j].is_none()) {
        let root_parent = skeleton.root_parent[j];
        if root_parent == Mat4::IDENTITY {
            scene_nodes.push((1 + j).to_string());
        } else {
            scene_nodes.push(nodes.len().to_string());
            nodes.push(json::object(&[
                ("name", json::string(&format!("{} parent", skeleton.names[j]))),
                ("matrix", json::floats(&root_parent.to_cols_array())),
                ("children", json::array([(1 + j).to_string()])),
            ]));
        }
    }

    let attributes = json::object(&[("POSITION", "0".into()), ("JOINTS_0", "1".into()), ("WEIGHTS_0", "2".into())]);
    let primitive = json::object(&[("attributes", attributes), ("indices", "3".into()), ("mode", "4".into())]);
    let document = json::object(&[
        (
            "asset",
            json::object(&[
                ("version", json::string("2.0")),
                ("generator", json::string(concat!("diffsil ", env!("CARGO_PKG_VERSION")))),
            ]),
        ),
        ("scene", "0".into()),
        ("scenes", json::array([json::object(&[("nodes", json::array(scene_nodes))])])),
        ("nodes", json::array(nodes)),
        (
            "meshes",
            json::array([json::object(&[("name", json::string("mesh")), ("primitives", json::array([primitive]))])]),
        ),
        (
            "skins",
            json::array([json::object(&[
                ("inverseBindMatrices", "4".into()),
                ("joints", json::array((1..=joint_count).map(|n| n.to_string()))),
            ])]),
        ),
        ("accessors", json::array(accessors.iter().map(|fields| json::object(fields)))),
        ("bufferViews", json::array(buffer_views)),
        ("buffers", json::array([json::object(&[("byteLength", bin.len().to_string())])])),
    ]);

    let mut json_chunk = document.into_bytes();
    json_chunk.resize(json_chunk.len().next_multiple_of(4), b' ');
    bin.resize(bin.len().next_multiple_of(4), 0);
    let total = 12 + 8 + json_chunk.len() + 8 + bin.len();
    let total = u32::try_from(total).map_err(|_| format!("the GLB would be {total} bytes, over the 4 GiB limit"))?;
    let mut out = Vec::with_capacity(total as usize);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&total.to_le_bytes());
    for (kind, chunk) in [(b"JSON", &json_chunk), (b"BIN\0", &bin)] {
        out.extend_from_slice(&(chunk.len() as u32).to_le_bytes());
        out.extend_from_slice(kind);
        out.extend_from_slice(chunk);
    }
    Ok(out)
}

/// Little-endian bytes of floats.
fn f32_bytes(values: impl IntoIterator<Item = f32>) -> Vec<u8> {
    values.into_iter().flat_map(f32::to_le_bytes).collect()
}

/// Just enough JSON writing for the GLB [`save_glb`] writes (no serde_json dependency).
mod json {
    /// `{"key":value,...}`; values are already JSON.
    pub(super) fn object(fields: &[(&str, String)]) -> String {
        let body: Vec<String> = fields.iter().map(|(key, value)| format!("{}:{value}", string(key))).collect();
        format!("{{{}}}", body.join(","))
    }

    /// `[item,...]`; items are already JSON.
    pub(super) fn array(items: impl IntoIterator<Item = String>) -> String {
        format!("[{}]", items.into_iter().collect::<Vec<_>>().join(","))
    }

    /// A JSON string literal.
    pub(super) fn string(text: &str) -> String {
        let mut out = String::with_capacity(text.len() + 2);
        out.push('"');
        for c in text.chars() {
            match c {
                '"' => out.push_str("\\\""),
                '\\' => out.push_str("\\\\"),
                '\n' => out.push_str("\\n"),
                '\r' => out.push_str("\\r"),
                '\t' => out.push_str("\\t"),
                c if u32::from(c) < 0x20 => out.push_str(&format!("\\u{:04x}", u32::from(c))),
                c => out.push(c),
            }
        }
        out.push('"');
        out
    }

    /// Finite floats as a JSON array. Rust prints the shortest decimal that reads back to the
    /// same `f32`, never in exponent form.
    pub(super) fn floats(values: &[f32]) -> String {
        debug_assert!(values.iter().all(|x| x.is_finite()));
        array(values.iter().map(|x| format!("{x}")))
    }
}
