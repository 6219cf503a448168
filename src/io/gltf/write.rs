//! Writing a skinned mesh as GLB.

use std::path::Path;

use glam::{Mat4, Quat, Vec3};

use super::skin::unit_quaternion;
use super::Reason;
use crate::pose::skin::{JointRest, SkinnedMesh};
use crate::{Error, Result};

/// Writes a skinned mesh as a GLB 2.0 file that [`load_gltf`](super::load_gltf) reads back to the same data.
///
/// Layout: one buffer (the BIN chunk) with `POSITION` (float, with min/max), `JOINTS_0` (unsigned
/// short), `WEIGHTS_0` (float), indices (unsigned int) and the inverse bind matrices; one mesh
/// node at the scene root with no transform, holding the mesh and the skin; one node per joint
/// with its rest translation / rotation / scale, its children being its child joints; and each
/// root joint whose `root_parent` is not the identity under a node carrying that matrix. Morph
/// targets, when the mesh has them, are written as `POSITION` targets (default weights 0) with
/// their names in `mesh.extras.targetNames` and their joint offsets, if any, in
/// `skins[0].extras.morphJointOffsets`, as [`load_gltf`](super::load_gltf) reads them.
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
    model.morphs.validate(vertices, joints).map_err(|e| e.to_string())?;
    if model.morphs.joint_offsets.is_some() {
        let names = &model.morphs.names;
        if let Some(k) = (0..names.len()).find(|&k| names[..k].contains(&names[k])) {
            return Err(format!(
                "morph target name `{}` is used twice; joint offsets are stored by name, so names must be unique",
                names[k]
            ));
        }
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
    let morphs = &model.morphs;
    for deltas in &morphs.deltas {
        add_view(&mut bin, f32_bytes(deltas.iter().flat_map(|d| d.to_array())), ARRAY_BUFFER);
    }

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
    let mut accessors = vec![
        position_accessor,
        accessor(1, 5123, positions.len(), "VEC4"),
        accessor(2, 5126, positions.len(), "VEC4"),
        accessor(3, 5125, model.mesh.triangles().len() * 3, "SCALAR"),
        accessor(4, 5126, joint_count, "MAT4"),
    ];
    for (k, deltas) in morphs.deltas.iter().enumerate() {
        let (lo, hi) = deltas.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), d| (lo.min(*d), hi.max(*d)));
        let mut fields = accessor(5 + k, 5126, deltas.len(), "VEC3");
        fields.push(("min", json::floats(&lo.to_array())));
        fields.push(("max", json::floats(&hi.to_array())));
        accessors.push(fields);
    }
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
    let mut primitive = vec![("attributes", attributes), ("indices", "3".into()), ("mode", "4".into())];
    let mut mesh = vec![("name", json::string("mesh"))];
    let mut skin = vec![
        ("inverseBindMatrices", "4".to_string()),
        ("joints", json::array((1..=joint_count).map(|n| n.to_string()))),
    ];
    if !morphs.is_empty() {
        let targets = (0..morphs.count()).map(|k| json::object(&[("POSITION", (5 + k).to_string())]));
        primitive.push(("targets", json::array(targets)));
        mesh.push(("weights", json::floats(&vec![0.0; morphs.count()])));
        let names = json::array(morphs.names.iter().map(|n| json::string(n)));
        mesh.push(("extras", json::object(&[("targetNames", names)])));
        if let Some(offsets) = &morphs.joint_offsets {
            let per_target: Vec<(&str, String)> = morphs
                .names
                .iter()
                .zip(offsets)
                .map(|(name, list)| (name.as_str(), json::array(list.iter().map(|o| json::floats(&o.to_array())))))
                .collect();
            skin.push(("extras", json::object(&[("morphJointOffsets", json::object(&per_target))])));
        }
    }
    mesh.push(("primitives", json::array([json::object(&primitive)])));
    let document = json::object(&[
        ("asset", json::asset()),
        ("scene", "0".into()),
        ("scenes", json::array([json::object(&[("nodes", json::array(scene_nodes))])])),
        ("nodes", json::array(nodes)),
        ("meshes", json::array([json::object(&mesh)])),
        ("skins", json::array([json::object(&skin)])),
        ("accessors", json::array(accessors.iter().map(|fields| json::object(fields)))),
        ("bufferViews", json::array(buffer_views)),
        ("buffers", json::array([json::object(&[("byteLength", bin.len().to_string())])])),
    ]);

    glb_container(document, bin)
}

/// The GLB container around a JSON document and its binary chunk.
pub(super) fn glb_container(document: String, mut bin: Vec<u8>) -> Reason<Vec<u8>> {
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
pub(super) fn f32_bytes(values: impl IntoIterator<Item = f32>) -> Vec<u8> {
    values.into_iter().flat_map(f32::to_le_bytes).collect()
}

/// Just enough JSON writing for the GLB [`save_glb`](super::save_glb) writes (no serde_json dependency).
pub(super) mod json {
    /// The `asset` object every file diffsil writes carries: glTF 2.0, generator "diffsil <version>".
    pub(in crate::io::gltf) fn asset() -> String {
        object(&[("version", string("2.0")), ("generator", string(concat!("diffsil ", env!("CARGO_PKG_VERSION"))))])
    }

    /// `{"key":value,...}`; values are already JSON.
    pub(in crate::io::gltf) fn object(fields: &[(&str, String)]) -> String {
        let body: Vec<String> = fields.iter().map(|(key, value)| format!("{}:{value}", string(key))).collect();
        format!("{{{}}}", body.join(","))
    }

    /// `[item,...]`; items are already JSON.
    pub(in crate::io::gltf) fn array(items: impl IntoIterator<Item = String>) -> String {
        format!("[{}]", items.into_iter().collect::<Vec<_>>().join(","))
    }

    /// A JSON string literal.
    pub(in crate::io::gltf) fn string(text: &str) -> String {
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
    pub(in crate::io::gltf) fn floats(values: &[f32]) -> String {
        debug_assert!(values.iter().all(|x| x.is_finite()));
        array(values.iter().map(|x| format!("{x}")))
    }
}
