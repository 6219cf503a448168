//! Reading a glTF file: the public loaders and the assembly of a [`Model`].

use std::path::Path;

use glam::Mat4;

use super::container::{load_buffers, parse_document};
use super::geometry::{is_triangle_mode, read_geometry, same_influences, SkinMap};
use super::morph::{joint_offsets, target_names};
use super::skin::{read_skin, NodeGraph};
use super::{LoadInfo, Model, Reason};
use crate::pose::skin::{MorphTargets, Pose, SkinnedMesh};
use crate::{Error, Mesh, Result};

/// Loads the first triangle mesh of a `.gltf` (embedded or external buffers) or `.glb` file, with
/// its skin if its node has one. See the [module docs](super) for what is read and how.
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

pub(super) fn read_model(document: &gltf::Document, buffers: &[Vec<u8>]) -> Reason<(Model, LoadInfo)> {
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

    let (remap, kept) = crate::io::weld_map(&geometry.positions);
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
        Some((skeleton, new_index)) => {
            let influence = |i: usize| (geometry.joints[i], geometry.weights[i]);
            info.weight_conflicts = (0..remap.len())
                .filter(|&i| {
                    let first = kept[remap[i] as usize];
                    first != i && !same_influences(influence(first), influence(i), 1e-4)
                })
                .count();
            let positions = kept.iter().map(|&i| geometry.positions[i]).collect();
            let names = target_names(&mesh, geometry.targets.len())?;
            let offsets = match skin.as_ref() {
                Some(skin) if !names.is_empty() => joint_offsets(skin, &names, &new_index)?,
                _ => None,
            };
            let morphs = MorphTargets {
                names,
                // A welded vertex keeps the deltas of its first occurrence, like its influences.
                deltas: geometry.targets.iter().map(|t| kept.iter().map(|&i| t[i]).collect()).collect(),
                joint_offsets: offsets,
            };
            Model::Skinned(SkinnedMesh {
                mesh: Mesh::new(positions, triangles).map_err(mesh_error)?,
                skeleton,
                joints: kept.iter().map(|&i| geometry.joints[i]).collect(),
                weights: kept.iter().map(|&i| geometry.weights[i]).collect(),
                morphs,
            })
        }
    };
    Ok((model, info))
}
