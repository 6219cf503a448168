//! Writing a static (e.g. posed) mesh as GLB.

use std::path::Path;

use glam::Vec3;

use super::write::{f32_bytes, glb_container, json};
use super::Reason;
use crate::{Error, Mesh, Result};

/// Writes a mesh (for instance a fitted, posed body from
/// [`SkinnedMesh::posed_mesh_shaped`](crate::pose::skin::SkinnedMesh::posed_mesh_shaped)) as a
/// self-contained GLB 2.0 file with no skin: `POSITION` (float, with min / max) and indices
/// (unsigned int) in one buffer, one mesh node at the scene root with no transform.
/// [`load_gltf`](super::load_gltf) reads it back as [`Model::Static`](super::Model::Static) with
/// the same positions and triangles.
///
/// Errors: [`Error::Format`] (naming the path) for a non-finite position; [`Error::Io`] if the
/// file cannot be written.
pub fn save_mesh_glb(mesh: &Mesh, path: impl AsRef<Path>) -> Result<()> {
    let path = path.as_ref();
    let bytes = mesh_glb_bytes(mesh)
        .map_err(|reason| Error::Format { path: path.to_path_buf(), reason: format!("cannot save: {reason}") })?;
    std::fs::write(path, bytes).map_err(|source| Error::Io { path: path.to_path_buf(), source })
}

fn mesh_glb_bytes(mesh: &Mesh) -> Reason<Vec<u8>> {
    let positions = mesh.positions();
    if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
        return Err(format!("vertex {i} is {:?}, not finite", positions[i]));
    }
    let mut bin = f32_bytes(positions.iter().flat_map(|p| p.to_array()));
    let index_offset = bin.len();
    bin.extend(mesh.triangles().iter().flatten().flat_map(|i| i.to_le_bytes()));
    let (min, max) =
        positions.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    let view = |offset: usize, length: usize, target: u32| {
        json::object(&[
            ("buffer", "0".into()),
            ("byteOffset", offset.to_string()),
            ("byteLength", length.to_string()),
            ("target", target.to_string()),
        ])
    };
    let accessors = [
        json::object(&[
            ("bufferView", "0".into()),
            ("componentType", "5126".into()),
            ("count", positions.len().to_string()),
            ("type", json::string("VEC3")),
            ("min", json::floats(&min.to_array())),
            ("max", json::floats(&max.to_array())),
        ]),
        json::object(&[
            ("bufferView", "1".into()),
            ("componentType", "5125".into()),
            ("count", (3 * mesh.triangles().len()).to_string()),
            ("type", json::string("SCALAR")),
        ]),
    ];
    let primitive = json::object(&[
        ("attributes", json::object(&[("POSITION", "0".into())])),
        ("indices", "1".into()),
        ("mode", "4".into()),
    ]);
    let document = json::object(&[
        ("asset", json::asset()),
        ("scene", "0".into()),
        ("scenes", json::array([json::object(&[("nodes", json::array(["0".to_string()]))])])),
        ("nodes", json::array([json::object(&[("name", json::string("mesh")), ("mesh", "0".into())])])),
        (
            "meshes",
            json::array([json::object(&[("name", json::string("mesh")), ("primitives", json::array([primitive]))])]),
        ),
        ("accessors", json::array(accessors)),
        (
            "bufferViews",
            json::array([view(0, index_offset, 34962), view(index_offset, bin.len() - index_offset, 34963)]),
        ),
        ("buffers", json::array([json::object(&[("byteLength", bin.len().to_string())])])),
    ]);
    glb_container(document, bin)
}
