//! The built-in MakeHuman body (CC0): a real human mesh with a 31-joint skeleton and 10 shape
//! targets, embedded in the library.

use crate::io::gltf::{load_gltf_bytes, Model};
use crate::pose::skin::SkinnedMesh;
use crate::{Error, Result};

/// The bytes of `assets/makehuman-body-7k.glb` (provenance and licence in `assets/SOURCES.md`).
pub const MAKEHUMAN_BODY_GLB: &[u8] = include_bytes!("../../assets/makehuman-body-7k.glb");

/// The MakeHuman body: 7,000 vertices, 13,996 triangles (closed), 31 joints (`cmu_mb` rig, identity
/// rest rotations, metres, +Y up, facing +Z, soles at y = 0, 1.659 m tall, A-pose), and 10 morph
/// targets with joint offsets (`gender`, `weight_max`, `weight_min`, `muscle_max`, `muscle_min`,
/// `height`, `proportions_ideal`, `proportions_uncommon`, `age_old`, `leg_length`), so that
/// [`SkinnedMesh::skin_shaped`] moves both the surface and the joints. CC0 (derived from
/// MakeHuman / MPFB2 data). Parsed from the embedded GLB at each call (about 40 ms on a 2-core
/// machine): keep the result rather than calling it in a loop.
pub fn makehuman_body() -> Result<SkinnedMesh> {
    match load_gltf_bytes(MAKEHUMAN_BODY_GLB, "makehuman-body-7k.glb (built in)")?.0 {
        Model::Skinned(body) => Ok(body),
        Model::Static(_) => Err(Error::InvalidSettings("the built-in MakeHuman body has no skin".into())),
    }
}
