//! Tests of `diffsil::io::gltf`: glTF / GLB loading (static and skinned, welding, joint order),
//! GLB writing and round trips, and clear errors on malformed or unsupported files.
//!
//! The tests marked `#[ignore]` read the Khronos sample models in `$DIFFSIL_ASSETS`:
//! `DIFFSIL_ASSETS=../shared/assets cargo test --test pose gltf_io -- --include-ignored`.

use crate::common::files::{temp_dir, write};

use std::path::{Path, PathBuf};

use diffsil::io::gltf::{load_gltf, load_gltf_with_info, load_mesh, save_glb, LoadInfo, Model};
use diffsil::pose::skin::{JointRest, Skeleton, SkinnedMesh};
use diffsil::{Error, Mesh, Vec3};
use glam::{DMat4, DQuat, DVec3, Mat4, Quat};

// ---------------------------------------------------------------------------------------------
// Helpers

/// A GLB container around a JSON text and a binary chunk (padded as the spec says).
fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut json = json.as_bytes().to_vec();
    json.resize(json.len().next_multiple_of(4), b' ');
    let mut bin = bin.to_vec();
    bin.resize(bin.len().next_multiple_of(4), 0);
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [chunk[0], *chunk.get(1).unwrap_or(&0), *chunk.get(2).unwrap_or(&0)];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(ALPHABET[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// Builds the binary buffer, buffer views and accessors of a hand-written glTF.
#[derive(Default)]
struct Doc {
    bin: Vec<u8>,
    views: Vec<String>,
    accessors: Vec<String>,
}

impl Doc {
    /// Adds one accessor over its own buffer view; `extra` is appended to its JSON (`,"k":v`).
    fn accessor(&mut self, bytes: Vec<u8>, component: u32, count: usize, kind: &str, extra: &str) -> usize {
        let offset = self.bin.len();
        self.views.push(format!(r#"{{"buffer":0,"byteOffset":{offset},"byteLength":{}}}"#, bytes.len()));
        self.bin.extend(&bytes);
        self.bin.resize(self.bin.len().next_multiple_of(4), 0);
        let view = self.views.len() - 1;
        self.accessors.push(format!(
            r#"{{"bufferView":{view},"componentType":{component},"count":{count},"type":"{kind}"{extra}}}"#
        ));
        self.accessors.len() - 1
    }
    /// POSITION data, with the min / max the spec requires (over the finite values).
    fn positions(&mut self, p: &[[f32; 3]]) -> usize {
        let bound = |pick: fn(f32, f32) -> f32| {
            let b: Vec<String> = (0..3)
                .map(|k| p.iter().map(|v| v[k]).filter(|x| x.is_finite()).reduce(pick).unwrap_or(0.0).to_string())
                .collect();
            b.join(",")
        };
        let extra = format!(r#","min":[{}],"max":[{}]"#, bound(f32::min), bound(f32::max));
        self.accessor(p.iter().flatten().flat_map(|x| x.to_le_bytes()).collect(), 5126, p.len(), "VEC3", &extra)
    }
    fn indices_u32(&mut self, i: &[u32]) -> usize {
        self.accessor(i.iter().flat_map(|x| x.to_le_bytes()).collect(), 5125, i.len(), "SCALAR", "")
    }
    fn indices_u8(&mut self, i: &[u8]) -> usize {
        self.accessor(i.to_vec(), 5121, i.len(), "SCALAR", "")
    }
    fn joints(&mut self, j: &[[u16; 4]]) -> usize {
        self.accessor(j.iter().flatten().flat_map(|x| x.to_le_bytes()).collect(), 5123, j.len(), "VEC4", "")
    }
    fn weights(&mut self, w: &[[f32; 4]]) -> usize {
        self.accessor(w.iter().flatten().flat_map(|x| x.to_le_bytes()).collect(), 5126, w.len(), "VEC4", "")
    }
    fn matrices(&mut self, m: &[Mat4]) -> usize {
        let bytes = m.iter().flat_map(|m| m.to_cols_array()).flat_map(|x| x.to_le_bytes()).collect();
        self.accessor(bytes, 5126, m.len(), "MAT4", "")
    }
    /// The full JSON: `body` holds scenes, nodes, meshes, skins (and whatever else).
    fn json(&self, body: &str, buffer_uri: Option<&str>) -> String {
        let uri = buffer_uri.map(|u| format!(r#","uri":"{u}""#)).unwrap_or_default();
        format!(
            r#"{{"asset":{{"version":"2.0"}},{body},"accessors":[{}],"bufferViews":[{}],"buffers":[{{"byteLength":{}{uri}}}]}}"#,
            self.accessors.join(","),
            self.views.join(","),
            self.bin.len()
        )
    }
    fn glb(&self, body: &str) -> Vec<u8> {
        glb(&self.json(body, None), &self.bin)
    }
    fn embedded_gltf(&self, body: &str) -> String {
        self.json(body, Some(&format!("data:application/octet-stream;base64,{}", base64(&self.bin))))
    }
}

/// The 8 corners and 12 triangles of an axis-aligned box.
fn box_geometry(lo: Vec3, hi: Vec3) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let positions = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            )
        })
        .collect();
    let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    let triangles = quads.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
    (positions, triangles)
}

/// World transforms of a skeleton's joints in the rest pose, in f64, computed here independently.
fn rest_world(skeleton: &Skeleton) -> Vec<DMat4> {
    let mut world: Vec<DMat4> = Vec::new();
    for (j, rest) in skeleton.rest.iter().enumerate() {
        let local = DMat4::from_scale_rotation_translation(
            rest.scale.as_dvec3(),
            rest.rotation.as_dquat().normalize(),
            rest.translation.as_dvec3(),
        );
        let parent = match skeleton.parents[j] {
            Some(p) => world[p],
            None => skeleton.root_parent[j].as_dmat4(),
        };
        world.push(parent * local);
    }
    world
}

/// A box from z = 0 to z = 2 on two joints (a root under a transformed parent, and a child one
/// unit up), with weights blending across the middle and inverse bind matrices = inverse rest.
fn two_joint_box() -> SkinnedMesh {
    let (positions, triangles) = box_geometry(Vec3::new(-0.5, -0.25, 0.0), Vec3::new(0.5, 0.25, 2.0));
    let joints = positions.iter().map(|p| if p.z > 1.0 { [1, 0, 0, 0] } else { [0, 1, 0, 0] }).collect();
    let weights =
        positions.iter().map(|p| if p.z > 1.0 { [0.75, 0.25, 0.0, 0.0] } else { [1.0, 0.0, 0.0, 0.0] }).collect();
    let mut skeleton = Skeleton {
        names: vec!["hip \"root\"".into(), "spine".into()],
        // save_glb writes joint j as node 1 + j.
        nodes: vec![1, 2],
        parents: vec![None, Some(0)],
        rest: vec![
            JointRest { translation: Vec3::new(0.1, 0.2, 0.3), rotation: Quat::from_rotation_y(0.3), scale: Vec3::ONE },
            JointRest {
                translation: Vec3::new(0.0, 0.0, 1.0),
                rotation: Quat::from_rotation_x(-0.2),
                scale: Vec3::new(1.0, 1.5, 1.0),
            },
        ],
        root_parent: vec![
            Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2) * Mat4::from_translation(Vec3::X),
            Mat4::IDENTITY,
        ],
        inverse_bind: vec![],
    };
    skeleton.inverse_bind = rest_world(&skeleton).iter().map(|m| m.inverse().as_mat4()).collect();
    SkinnedMesh {
        mesh: Mesh::new(positions, triangles).unwrap(),
        skeleton,
        joints,
        weights,
        morphs: Default::default(),
    }
}

fn skinned(model: Model) -> SkinnedMesh {
    match model {
        Model::Skinned(s) => s,
        Model::Static(_) => panic!("expected a skinned model"),
    }
}

fn static_mesh(model: Model) -> Mesh {
    match model {
        Model::Static(m) => m,
        Model::Skinned(_) => panic!("expected a static model"),
    }
}

fn close(a: &[f32], b: &[f32], tolerance: f32) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tolerance)
}

/// Same skeleton up to JSON float round-off in the rest and root transforms.
fn assert_same_skeleton(a: &Skeleton, b: &Skeleton) {
    assert_eq!(a.names, b.names);
    assert_eq!(a.parents, b.parents);
    assert_eq!(a.inverse_bind, b.inverse_bind, "inverse bind matrices are binary: exact");
    for (x, y) in a.rest.iter().zip(&b.rest) {
        assert!(close(&x.translation.to_array(), &y.translation.to_array(), 1e-6), "{x:?} vs {y:?}");
        assert!(close(&x.rotation.to_array(), &y.rotation.to_array(), 1e-6), "{x:?} vs {y:?}");
        assert!(close(&x.scale.to_array(), &y.scale.to_array(), 1e-6), "{x:?} vs {y:?}");
    }
    for (x, y) in a.root_parent.iter().zip(&b.root_parent) {
        assert!(close(&x.to_cols_array(), &y.to_cols_array(), 1e-6), "{x:?} vs {y:?}");
    }
    assert_eq!(a.rest.len(), b.rest.len());
    assert_eq!(a.root_parent.len(), b.root_parent.len());
}

fn assert_same_skinned(a: &SkinnedMesh, b: &SkinnedMesh) {
    assert_eq!(a.mesh.positions(), b.mesh.positions());
    assert_eq!(a.mesh.triangles(), b.mesh.triangles());
    assert_eq!(a.joints, b.joints);
    for (x, y) in a.weights.iter().zip(&b.weights) {
        assert!(close(x, y, 1e-6), "{x:?} vs {y:?}");
    }
    assert_eq!(a.weights.len(), b.weights.len());
    assert_same_skeleton(&a.skeleton, &b.skeleton);
}

/// What every loaded skinned mesh must satisfy.
fn assert_valid_skin(s: &SkinnedMesh) {
    let n = s.skeleton.parents.len();
    assert!(n > 0);
    for (j, p) in s.skeleton.parents.iter().enumerate() {
        assert!(p.is_none_or(|p| p < j), "joint {j}'s parent {p:?} comes after it");
    }
    assert_eq!(s.skeleton.names.len(), n);
    assert_eq!(s.skeleton.rest.len(), n);
    assert_eq!(s.skeleton.root_parent.len(), n);
    assert_eq!(s.skeleton.inverse_bind.len(), n);
    let v = s.mesh.positions().len();
    assert_eq!(s.joints.len(), v);
    assert_eq!(s.weights.len(), v);
    for (j, w) in s.joints.iter().zip(&s.weights) {
        assert!(j.iter().all(|&j| usize::from(j) < n), "joint index out of range: {j:?}");
        assert!(w.iter().all(|&w| w.is_finite() && w >= 0.0), "{w:?}");
        assert!((w.iter().sum::<f32>() - 1.0).abs() <= 1e-6, "weights {w:?} do not sum to 1");
    }
}

/// The error of loading `path`, which must be a `Format` error naming the file and containing
/// every one of `words`.
fn format_error(path: &Path, words: &[&str]) -> String {
    match load_gltf(path) {
        Err(Error::Format { path: p, reason }) => {
            assert_eq!(p, path);
            for word in words {
                assert!(reason.contains(word), "`{reason}` should mention `{word}`");
            }
            reason
        }
        Err(e) => panic!("expected a format error, got {e:?}"),
        Ok(m) => panic!("expected an error, got {m:?}"),
    }
}

// ---------------------------------------------------------------------------------------------
// Skinned glTF documents written by hand

/// A skinned quad: 2 triangles as 6 split corners (like an exporter splitting at a UV seam),
/// 4 distinct positions. Corner 3 repeats corner 0 with equal weights, corner 5 repeats corner 2
/// with *different* weights. Joints listed child-first in the skin (nodes 3, 2): node 2 `root`
/// sits under non-joint node 1 `armature` (translated); node 3 `child` sits under non-joint node
/// 4 `offset` (translated) under `root`. The mesh node 0 has a transform that must be ignored.
fn skinned_quad(doc: &mut Doc, weights: &[[f32; 4]; 6], skin_extra: &str) -> String {
    let p = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]];
    let pos = doc.positions(&p);
    let idx = doc.indices_u32(&[0, 1, 2, 3, 5, 4]);
    // File joint 0 = `child`, 1 = `root`.
    let j = doc.joints(&[[1, 0, 0, 0], [1, 0, 0, 0], [0, 1, 0, 0], [1, 0, 0, 0], [0, 0, 0, 0], [0, 1, 0, 0]]);
    let w = doc.weights(weights);
    let ibm = doc.matrices(&[Mat4::from_translation(Vec3::new(0.0, -3.0, 0.0)), Mat4::IDENTITY]);
    format!(
        r#""scene":0,"scenes":[{{"nodes":[0,1]}}],
        "nodes":[
          {{"name":"mesh","mesh":0,"skin":0,"translation":[100,0,0]}},
          {{"name":"armature","translation":[0,0,5],"children":[2]}},
          {{"name":"root","translation":[0,1,0],"children":[4]}},
          {{"name":"child","translation":[0,1,0]}},
          {{"name":"offset","translation":[0,0.5,0],"children":[3]}}
        ],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":{pos},"JOINTS_0":{j},"WEIGHTS_0":{w}}},"indices":{idx}}}]}}],
        "skins":[{{"joints":[3,2]{skin_extra},"inverseBindMatrices":{ibm}}}]"#
    )
}

const QUAD_WEIGHTS: [[f32; 4]; 6] = [
    [1.0, 0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0, 0.0],
    [0.5, 0.5, 0.0, 0.0],
    [1.0, 0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0, 0.0],
    [0.25, 0.75, 0.0, 0.0],
];

/// A static (unskinned) triangle strip + triangle list + points, under a transformed parent.
fn static_doc(doc: &mut Doc) -> String {
    let p = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 2.0, 0.0], [1.0, 2.0, 0.0]];
    let pos = doc.positions(&p);
    let list = doc.indices_u8(&[0, 1, 2, 2, 1, 3]);
    format!(
        r#""scene":0,"scenes":[{{"nodes":[0]}}],
        "nodes":[
          {{"name":"parent","translation":[1,2,3],"children":[1]}},
          {{"name":"holder","scale":[2,2,2],"mesh":0}}
        ],
        "meshes":[{{"name":"sheet","primitives":[
          {{"attributes":{{"POSITION":{pos}}},"mode":5}},
          {{"attributes":{{"POSITION":{pos}}},"indices":{list}}},
          {{"attributes":{{"POSITION":{pos}}},"mode":0}}
        ]}}]"#
    )
}

mod animations;
mod assets;
mod malformed;
mod morphs;
mod round_trips;
mod writers;
