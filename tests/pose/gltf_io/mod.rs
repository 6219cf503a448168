//! Tests of `diffsil::io::gltf`: glTF / GLB loading (static and skinned, welding, joint order),
//! GLB writing and round trips, and clear errors on malformed or unsupported files.
//!
//! The tests marked `#[ignore]` read the Khronos sample models in `$DIFFSIL_ASSETS`:
//! `DIFFSIL_ASSETS=../shared/assets cargo test --test gltf_io -- --include-ignored`.

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
    SkinnedMesh { mesh: Mesh::new(positions, triangles).unwrap(), skeleton, joints, weights }
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

// ---------------------------------------------------------------------------------------------
// Round trips and loading, no assets needed

#[test]
fn skinned_box_round_trips_through_glb() {
    let model = two_joint_box();
    let path = temp_dir().join("box.glb");
    save_glb(&model, &path).unwrap();
    let (loaded, info) = load_gltf_with_info(&path).unwrap();
    let loaded = skinned(loaded);
    assert_same_skinned(&model, &loaded);
    assert_valid_skin(&loaded);
    assert_eq!(
        info,
        LoadInfo {
            mesh: 0,
            mesh_name: Some("mesh".into()),
            node: Some(0),
            file_vertices: 8,
            welded_vertices: 8,
            triangles: 12,
            weight_conflicts: 0,
            skipped_primitives: 0,
        }
    );
    // Saving what was loaded gives the same file.
    let again = temp_dir().join("again.glb");
    save_glb(&loaded, &again).unwrap();
    assert_same_skinned(&loaded, &skinned(load_gltf(&again).unwrap()));
    // The bind pose is the rest pose here, so the rest-pose mesh is the box itself.
    let rest = load_mesh(&path).unwrap();
    assert_eq!(rest.triangles(), model.mesh.triangles());
    for (a, b) in rest.positions().iter().zip(model.mesh.positions()) {
        assert!(a.abs_diff_eq(*b, 1e-5), "{a} vs {b}");
    }
}

#[test]
fn saved_glb_is_a_valid_container_with_the_documented_layout() {
    let model = two_joint_box();
    let path = temp_dir().join("layout.glb");
    save_glb(&model, &path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let word = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().unwrap()) as usize;
    assert_eq!(&bytes[0..4], b"glTF");
    assert_eq!(word(4), 2);
    assert_eq!(word(8), bytes.len());
    let json_len = word(12);
    assert_eq!(&bytes[16..20], b"JSON");
    assert_eq!(json_len % 4, 0);
    let bin_at = 20 + json_len;
    assert_eq!(&bytes[bin_at + 4..bin_at + 8], b"BIN\0");
    assert_eq!(word(bin_at) % 4, 0);
    assert_eq!(bin_at + 8 + word(bin_at), bytes.len());

    // The gltf crate validates it; check the accessors and hierarchy it sees.
    let gltf = gltf::Gltf::from_slice(&bytes).unwrap();
    let primitive = gltf.meshes().next().unwrap().primitives().next().unwrap();
    let position = primitive.get(&gltf::Semantic::Positions).unwrap();
    let numbers = |v: gltf::json::Value| v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect::<Vec<_>>();
    assert_eq!(numbers(position.min().unwrap()), [-0.5, -0.25, 0.0]);
    assert_eq!(numbers(position.max().unwrap()), [0.5, 0.25, 2.0]);
    assert_eq!(primitive.indices().unwrap().data_type(), gltf::accessor::DataType::U32);
    assert_eq!(primitive.get(&gltf::Semantic::Joints(0)).unwrap().data_type(), gltf::accessor::DataType::U16);
    assert_eq!(primitive.get(&gltf::Semantic::Weights(0)).unwrap().data_type(), gltf::accessor::DataType::F32);
    let skin = gltf.skins().next().unwrap();
    assert_eq!(skin.inverse_bind_matrices().unwrap().count(), 2);
    let nodes: Vec<_> = gltf.nodes().collect();
    assert_eq!(nodes.len(), 4, "mesh node, two joints, one root holder");
    let mesh_node = &nodes[0];
    assert!(mesh_node.mesh().is_some() && mesh_node.skin().is_some());
    assert_eq!(mesh_node.transform().matrix(), Mat4::IDENTITY.to_cols_array_2d());
    let scene_roots: Vec<usize> = gltf.scenes().next().unwrap().nodes().map(|n| n.index()).collect();
    assert_eq!(scene_roots, [0, 3]);
    let joint_nodes: Vec<usize> = skin.joints().map(|n| n.index()).collect();
    assert_eq!(joint_nodes, [1, 2]);
    assert_eq!(nodes[3].children().map(|n| n.index()).collect::<Vec<_>>(), [1]);
    assert_eq!(nodes[1].children().map(|n| n.index()).collect::<Vec<_>>(), [2]);
    let (t, r, s) = nodes[2].transform().decomposed();
    assert_eq!((t, s), ([0.0, 0.0, 1.0], [1.0, 1.5, 1.0]));
    assert!(close(&r, &model.skeleton.rest[1].rotation.to_array(), 1e-7));
    assert_eq!(nodes[1].name(), Some("hip \"root\""));
}

#[test]
fn seams_weld_keeping_the_first_weights_and_joints_come_parents_first() {
    let mut doc = Doc::default();
    let body = skinned_quad(&mut doc, &QUAD_WEIGHTS, "");
    let path = write("quad.glb", &doc.glb(&body));
    let (model, info) = load_gltf_with_info(&path).unwrap();
    assert_eq!((info.file_vertices, info.welded_vertices, info.triangles), (6, 4, 2));
    assert_eq!(info.weight_conflicts, 1, "corner 5 repeats corner 2 with other weights");
    let s = skinned(model);
    assert_valid_skin(&s);
    // Mesh node translation (100, 0, 0) ignored; welded in first-occurrence order.
    let expected = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
    assert_eq!(s.mesh.positions(), expected);
    assert_eq!(s.mesh.triangles(), [[0, 1, 2], [0, 2, 3]]);
    // Skeleton: `root` first now; file joint 0 (`child`) is joint 1.
    assert_eq!(s.skeleton.names, ["root", "child"]);
    assert_eq!(s.skeleton.parents, [None, Some(0)]);
    // Zero-weight entries are remapped too (file joint 0 → 1).
    assert_eq!(s.joints, [[0, 1, 1, 1], [0, 1, 1, 1], [1, 0, 1, 1], [1, 1, 1, 1]]);
    assert_eq!(s.weights[2], [0.5, 0.5, 0.0, 0.0], "first occurrence's weights kept");
    // IBMs follow their joints.
    assert_eq!(s.skeleton.inverse_bind, [Mat4::IDENTITY, Mat4::from_translation(Vec3::new(0.0, -3.0, 0.0))]);
    // Root under `armature`; `offset` folded into `child`'s rest translation.
    assert_eq!(s.skeleton.root_parent, [Mat4::from_translation(Vec3::new(0.0, 0.0, 5.0)), Mat4::IDENTITY]);
    assert_eq!(s.skeleton.rest[0].translation, Vec3::new(0.0, 1.0, 0.0));
    assert_eq!(s.skeleton.rest[1].translation, Vec3::new(0.0, 1.5, 0.0));
    // So the joints' rest world transforms are the nodes' world transforms.
    let world = rest_world(&s.skeleton);
    assert!(world[0].abs_diff_eq(DMat4::from_translation(DVec3::new(0.0, 1.0, 5.0)), 1e-12));
    assert!(world[1].abs_diff_eq(DMat4::from_translation(DVec3::new(0.0, 2.5, 5.0)), 1e-12));
}

#[test]
fn embedded_gltf_and_glb_of_one_document_load_identically() {
    let mut doc = Doc::default();
    let body = skinned_quad(&mut doc, &QUAD_WEIGHTS, "");
    let a = skinned(load_gltf(write("quad.glb", &doc.glb(&body))).unwrap());
    let b = skinned(load_gltf(write("quad.gltf", doc.embedded_gltf(&body).as_bytes())).unwrap());
    assert_eq!(a.mesh.positions(), b.mesh.positions());
    assert_eq!(a.mesh.triangles(), b.mesh.triangles());
    assert_eq!((&a.joints, &a.weights, &a.skeleton), (&b.joints, &b.weights, &b.skeleton));
}

#[test]
fn static_gltf_loads_as_static_in_world_space() {
    let mut doc = Doc::default();
    let body = static_doc(&mut doc);
    // External buffer with a percent-encoded name.
    let dir = temp_dir();
    std::fs::write(dir.join("sheet data.bin"), &doc.bin).unwrap();
    let path = dir.join("sheet.gltf");
    std::fs::write(&path, doc.json(&body, Some("sheet%20data.bin"))).unwrap();
    let (model, info) = load_gltf_with_info(&path).unwrap();
    let mesh = static_mesh(model);
    // Strip of 6 indices = 4 triangles, list = 2 triangles, points skipped.
    assert_eq!(info.triangles, 6);
    assert_eq!(info.skipped_primitives, 1);
    assert_eq!((info.file_vertices, info.welded_vertices), (12, 6));
    assert_eq!((info.mesh_name.as_deref(), info.node), (Some("sheet"), Some(1)));
    assert_eq!(
        mesh.triangles(),
        [[0, 1, 2], [2, 1, 3], [2, 3, 4], [4, 3, 5], [0, 1, 2], [2, 1, 3]],
        "strip triangles alternate their winding back"
    );
    // World = translate(1, 2, 3) · scale(2).
    let expected: Vec<Vec3> = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [0.0, 2.0], [1.0, 2.0]]
        .iter()
        .map(|&[x, y]| Vec3::new(1.0 + 2.0 * x, 2.0 + 2.0 * y, 3.0))
        .collect();
    assert_eq!(mesh.positions(), expected);
    // The same document embedded loads the same; load_mesh gives the same mesh.
    let embedded = write("sheet.gltf", doc.embedded_gltf(&body).as_bytes());
    assert_eq!(static_mesh(load_gltf(&embedded).unwrap()).positions(), expected);
    assert_eq!(load_mesh(&embedded).unwrap().positions(), expected);
}

#[test]
fn normalized_byte_weights_and_fan_primitives_are_read() {
    let mut doc = Doc::default();
    let pos = doc.positions(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]]);
    let j = doc.accessor(vec![0, 1, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 1, 0, 0, 0], 5121, 4, "VEC4", "");
    let w = doc.accessor(
        vec![255, 0, 0, 0, 51, 204, 0, 0, 128, 127, 0, 0, 0, 255, 0, 0],
        5121,
        4,
        "VEC4",
        r#","normalized":true"#,
    );
    let ibm = doc.matrices(&[Mat4::IDENTITY, Mat4::IDENTITY]);
    let body = format!(
        r#""nodes":[{{"mesh":0,"skin":0}},{{"name":"a","children":[2]}},{{"name":"b"}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":{pos},"JOINTS_0":{j},"WEIGHTS_0":{w}}},"mode":6}}]}}],
        "skins":[{{"joints":[1,2],"inverseBindMatrices":{ibm}}}]"#
    );
    let s = skinned(load_gltf(write("fan.glb", &doc.glb(&body))).unwrap());
    assert_valid_skin(&s);
    assert_eq!(s.mesh.triangles(), [[0, 1, 2], [0, 2, 3]]);
    assert_eq!(s.joints, [[0, 1, 0, 0], [1, 0, 0, 0], [0, 1, 0, 0], [1, 0, 0, 0]]);
    assert!(close(&s.weights[1], &[0.2, 0.8, 0.0, 0.0], 1e-7));
    assert!(close(&s.weights[2], &[128.0 / 255.0, 127.0 / 255.0, 0.0, 0.0], 1e-7));
}

#[test]
fn load_mesh_dispatches_on_the_extension() {
    let obj = write("tri.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    assert_eq!(load_mesh(&obj).unwrap().triangles(), [[0, 1, 2]]);
    // A skinned glTF comes back in the rest pose: here the IBMs are identities, so every vertex
    // moves by its joints' rest world transforms.
    let mut doc = Doc::default();
    let body = skinned_quad(&mut doc, &QUAD_WEIGHTS, "");
    let path = write("quad.GLB", &doc.glb(&body));
    let s = skinned(load_gltf(&path).unwrap());
    let world = rest_world(&s.skeleton);
    let rest = load_mesh(&path).unwrap();
    assert_eq!(rest.triangles(), s.mesh.triangles());
    for (v, &p) in s.mesh.positions().iter().enumerate() {
        let expected: DVec3 = (0..4)
            .map(|k| {
                let j = usize::from(s.joints[v][k]);
                (world[j] * s.skeleton.inverse_bind[j].as_dmat4()).transform_point3(p.as_dvec3())
                    * f64::from(s.weights[v][k])
            })
            .sum();
        assert!(rest.positions()[v].as_dvec3().abs_diff_eq(expected, 1e-5), "{} vs {expected}", rest.positions()[v]);
    }
    assert_ne!(rest.positions(), s.mesh.positions());
    match load_mesh(write("mesh.stl", b"solid")) {
        Err(Error::Format { reason, .. }) => assert!(reason.contains(".obj, .gltf or .glb"), "{reason}"),
        other => panic!("expected a format error, got {other:?}"),
    }
}

// ---------------------------------------------------------------------------------------------
// Malformed and unsupported files: clear errors, no panics

#[test]
fn missing_file_is_an_io_error() {
    let path = temp_dir().join("nope.glb");
    assert!(matches!(load_gltf(&path), Err(Error::Io { path: p, .. }) if p == path));
    // A missing external buffer names the buffer file.
    let mut doc = Doc::default();
    let body = static_doc(&mut doc);
    let gltf = write("lost.gltf", doc.json(&body, Some("lost.bin")).as_bytes());
    match load_gltf(&gltf) {
        Err(Error::Io { path, .. }) => assert_eq!(path.file_name().unwrap(), "lost.bin"),
        other => panic!("expected an I/O error, got {other:?}"),
    }
}

#[test]
fn truncated_glb_is_an_error_at_every_length() {
    let path = temp_dir().join("whole.glb");
    save_glb(&two_joint_box(), &path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let cut = temp_dir().join("cut.glb");
    // Every length around the header and chunk boundaries, and every 16th elsewhere (file writes
    // are slow on some file systems).
    let bin_chunk = 20 + u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let near = |length: usize, at: usize| length.abs_diff(at) <= 12;
    let lengths = (0..bytes.len()).filter(|&n| n < 32 || near(n, bin_chunk) || near(n, bytes.len()) || n % 16 == 0);
    for length in lengths {
        std::fs::write(&cut, &bytes[..length]).unwrap();
        match load_gltf(&cut) {
            Err(Error::Format { path, reason }) => {
                assert_eq!(path, cut);
                assert!(!reason.is_empty());
            }
            other => panic!("cut at {length} of {}: expected a format error, got {other:?}", bytes.len()),
        }
    }
    assert!(
        format_error(&write("t.glb", &bytes[..bytes.len() / 2]), &["truncated GLB"]).contains(&bytes.len().to_string())
    );
    // A header whose length field is too small for anything.
    let mut tiny = bytes.clone();
    tiny[8..12].copy_from_slice(&4u32.to_le_bytes());
    format_error(&write("tiny.glb", &tiny), &["4 bytes"]);
    let mut version = bytes;
    version[4..8].copy_from_slice(&1u32.to_le_bytes());
    format_error(&write("v1.glb", &version), &["version 1"]);
}

#[test]
fn garbage_is_an_error() {
    let mut noise = Vec::new();
    let mut x = 0x1234_5678_u32;
    for _ in 0..4096 {
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        noise.push(x as u8);
    }
    format_error(&write("noise.glb", &noise), &["not a glTF file"]);
    format_error(&write("empty.gltf", b""), &["not a glTF file"]);
    format_error(&write("broken.gltf", b"{\"asset\": {\"version\": \"2.0\"}, \"nodes\": [}"), &["not a valid glTF"]);
    format_error(&write("array.gltf", b"[1, 2, 3]"), &["not a glTF file"]);
    let mut magic_then_noise = b"glTF".to_vec();
    magic_then_noise.extend_from_slice(&2u32.to_le_bytes());
    magic_then_noise.extend_from_slice(&(noise.len() as u32 + 12).to_le_bytes());
    magic_then_noise.extend_from_slice(&noise);
    format_error(&write("magic.glb", &magic_then_noise), &["not a valid glTF"]);
    // Valid JSON, not a valid glTF document (bad index).
    format_error(&write("index.gltf", br#"{"asset":{"version":"2.0"},"nodes":[{"mesh":3}]}"#), &["not a valid glTF"]);
    format_error(&write("nomesh.gltf", br#"{"asset":{"version":"2.0"},"nodes":[{}]}"#), &["no mesh"]);
}

#[test]
fn sparse_accessors_are_rejected() {
    let mut doc = Doc::default();
    let body = static_doc(&mut doc);
    // Turn the POSITION accessor into a sparse one (one displaced vertex).
    let extra = doc.bin.len();
    doc.bin.extend(0u32.to_le_bytes());
    doc.bin.extend([0.5f32, 0.5, 0.5].iter().flat_map(|x| x.to_le_bytes()));
    doc.views.push(format!(r#"{{"buffer":0,"byteOffset":{extra},"byteLength":4}}"#));
    doc.views.push(format!(r#"{{"buffer":0,"byteOffset":{},"byteLength":12}}"#, extra + 4));
    let (iv, vv) = (doc.views.len() - 2, doc.views.len() - 1);
    doc.accessors[0] = doc.accessors[0].replace(
        r#""type":"VEC3""#,
        &format!(
            r#""type":"VEC3","sparse":{{"count":1,"indices":{{"bufferView":{iv},"componentType":5125}},"values":{{"bufferView":{vv}}}}}"#
        ),
    );
    format_error(&write("sparse.glb", &doc.glb(&body)), &["sparse accessor", "POSITION"]);
}

#[test]
fn required_geometry_extensions_are_rejected_appearance_ones_ignored() {
    let mut doc = Doc::default();
    let body = static_doc(&mut doc);
    let with = |required: &str| format!(r#""extensionsUsed":[{required}],"extensionsRequired":[{required}],{body}"#);
    let draco = with(r#""KHR_draco_mesh_compression""#);
    format_error(&write("draco.glb", &doc.glb(&draco)), &["KHR_draco_mesh_compression", "not support"]);
    let quantized = with(r#""KHR_materials_unlit","KHR_mesh_quantization""#);
    let reason = format_error(&write("quant.glb", &doc.glb(&quantized)), &["KHR_mesh_quantization"]);
    assert!(!reason.contains("unlit"), "{reason}");
    let unlit = with(r#""KHR_materials_unlit""#);
    assert!(matches!(load_gltf(write("unlit.glb", &doc.glb(&unlit))), Ok(Model::Static(_))));
}

#[test]
fn bad_weights_are_rejected() {
    let cases: [(&str, [f32; 4], &[&str]); 4] = [
        ("half", [0.25, 0.25, 0.0, 0.0], &["summing to 0.5", "vertex 2"]),
        ("negative", [1.5, -0.5, 0.0, 0.0], &["non-negative", "vertex 2"]),
        ("nan", [f32::NAN, 1.0, 0.0, 0.0], &["finite", "vertex 2"]),
        ("zero", [0.0; 4], &["summing to 0"]),
    ];
    for (name, bad, words) in cases {
        let mut weights = QUAD_WEIGHTS;
        weights[2] = bad;
        let mut doc = Doc::default();
        let body = skinned_quad(&mut doc, &weights, "");
        format_error(&write(&format!("{name}.glb"), &doc.glb(&body)), words);
    }
    // Weights within 1e-3 of 1 are renormalised.
    let mut weights = QUAD_WEIGHTS;
    weights[2] = [0.5, 0.5004, 0.0, 0.0];
    let mut doc = Doc::default();
    let body = skinned_quad(&mut doc, &weights, "");
    let s = skinned(load_gltf(write("almost.glb", &doc.glb(&body))).unwrap());
    assert_valid_skin(&s);
    assert!(close(&s.weights[2], &[0.5 / 1.0004, 0.5004 / 1.0004, 0.0, 0.0], 1e-7));
}

#[test]
fn missing_inverse_bind_matrices_are_rejected() {
    let mut doc = Doc::default();
    let body = skinned_quad(&mut doc, &QUAD_WEIGHTS, "");
    let body = body.replace(r#","inverseBindMatrices":4"#, "");
    assert!(!body.contains("inverseBindMatrices"));
    format_error(&write("noibm.glb", &doc.glb(&body)), &["missing inverseBindMatrices", "skin 0"]);
}

#[test]
fn out_of_range_and_non_finite_data_are_rejected() {
    // Triangle index past the vertices.
    let mut doc = Doc::default();
    let pos = doc.positions(&[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    let idx = doc.indices_u32(&[0, 1, 3]);
    let body = format!(
        r#""meshes":[{{"primitives":[{{"attributes":{{"POSITION":{pos}}},"indices":{idx}}}]}}],"nodes":[{{"mesh":0}}]"#
    );
    format_error(&write("index.glb", &doc.glb(&body)), &["index 2 is 3", "out of range"]);

    // NaN position.
    let mut doc = Doc::default();
    let pos = doc.positions(&[[0.0; 3], [1.0, f32::NAN, 0.0], [0.0, 1.0, 0.0]]);
    let body = format!(r#""meshes":[{{"primitives":[{{"attributes":{{"POSITION":{pos}}}}}]}}]"#);
    format_error(&write("nan.glb", &doc.glb(&body)), &["vertex 1", "non-finite position"]);

    // An accessor claiming more elements than its buffer view holds.
    let mut doc = Doc::default();
    let pos = doc.positions(&[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    doc.accessors[pos] = doc.accessors[pos].replace(r#""count":3"#, r#""count":3000000000"#);
    let body = format!(r#""meshes":[{{"primitives":[{{"attributes":{{"POSITION":{pos}}}}}]}}]"#);
    format_error(&write("overrun.glb", &doc.glb(&body)), &["overruns", "POSITION"]);

    // POSITION of the wrong type.
    let mut doc = Doc::default();
    let pos = doc.positions(&[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    doc.accessors[pos] = doc.accessors[pos].replace(r#""type":"VEC3""#, r#""type":"VEC2""#);
    let body = format!(r#""meshes":[{{"primitives":[{{"attributes":{{"POSITION":{pos}}}}}]}}]"#);
    format_error(&write("vec2.glb", &doc.glb(&body)), &["Vec2", "expected Vec3"]);

    // A joint index past the skin's joints, with a non-zero weight.
    let mut doc = Doc::default();
    let body = skinned_quad(&mut doc, &QUAD_WEIGHTS, "");
    // JOINTS_0 follows 6 positions (72 bytes) and 6 u32 indices (24 bytes); vertex 1's first joint.
    let at = 72 + 24 + 8;
    doc.bin[at..at + 2].copy_from_slice(&7u16.to_le_bytes());
    format_error(&write("joint.glb", &doc.glb(&body)), &["vertex 1 uses joint 7", "2 joints"]);
}

#[test]
fn no_triangles_and_broken_hierarchies_are_rejected() {
    let mut doc = Doc::default();
    let pos = doc.positions(&[[0.0; 3], [1.0, 0.0, 0.0]]);
    let body = format!(r#""meshes":[{{"primitives":[{{"attributes":{{"POSITION":{pos}}},"mode":1}}]}}]"#);
    format_error(&write("lines.glb", &doc.glb(&body)), &["no triangles"]);
    let body = format!(r#""meshes":[{{"primitives":[{{"attributes":{{"POSITION":{pos}}},"mode":4}}]}}]"#);
    format_error(&write("two.glb", &doc.glb(&body)), &["2 triangle indices"]);
    let body = format!(r#""meshes":[{{"primitives":[{{"attributes":{{"POSITION":{pos}}},"mode":5}}]}}]"#);
    format_error(&write("short-strip.glb", &doc.glb(&body)), &["no triangles"]);

    let mut doc = Doc::default();
    let body = static_doc(&mut doc);
    let cyclic = body.replace(r#""scale":[2,2,2],"mesh":0"#, r#""scale":[2,2,2],"mesh":0,"children":[0]"#);
    format_error(&write("cycle.glb", &doc.glb(&cyclic)), &["cycle"]);
    let twice = body.replace(r#""children":[1]"#, r#""children":[1,1]"#);
    format_error(&write("twice.glb", &doc.glb(&twice)), &["more than one parent"]);

    // A joint listed twice.
    let mut doc = Doc::default();
    let body = skinned_quad(&mut doc, &QUAD_WEIGHTS, "").replace(r#""joints":[3,2]"#, r#""joints":[3,3]"#);
    format_error(&write("dup.glb", &doc.glb(&body)), &["twice"]);
}

#[test]
fn saving_an_inconsistent_model_is_an_error() {
    let mut model = two_joint_box();
    model.skeleton.parents[1] = Some(1);
    let path = temp_dir().join("bad.glb");
    match save_glb(&model, &path) {
        Err(Error::Format { path: p, reason }) => {
            assert_eq!(p, path);
            assert!(reason.contains("parent"), "{reason}");
        }
        other => panic!("expected a format error, got {other:?}"),
    }
    assert!(!path.exists());
    let mut model = two_joint_box();
    model.weights[0] = [0.5, 0.0, 0.0, 0.0];
    assert!(matches!(save_glb(&model, &path), Err(Error::Format { .. })));
    let mut model = two_joint_box();
    model.joints[0] = [9, 0, 0, 0];
    assert!(matches!(save_glb(&model, &path), Err(Error::Format { .. })));
    let mut model = two_joint_box();
    model.skeleton.inverse_bind.pop();
    assert!(matches!(save_glb(&model, &path), Err(Error::Format { .. })));
}

// ---------------------------------------------------------------------------------------------
// The Khronos sample models in $DIFFSIL_ASSETS

fn assets() -> PathBuf {
    PathBuf::from(std::env::var_os("DIFFSIL_ASSETS").expect("set DIFFSIL_ASSETS to the assets folder"))
}

/// Loads `name.gltf` and `name.glb`, checks they give identical data and returns one.
fn load_pair(name: &str) -> (SkinnedMesh, LoadInfo) {
    let (a, info_a) = load_gltf_with_info(assets().join(format!("{name}.gltf"))).unwrap();
    let (b, info_b) = load_gltf_with_info(assets().join(format!("{name}.glb"))).unwrap();
    let (a, b) = (skinned(a), skinned(b));
    assert_eq!(info_a, info_b);
    assert_eq!(a.mesh.positions(), b.mesh.positions());
    assert_eq!(a.mesh.triangles(), b.mesh.triangles());
    assert_eq!((&a.joints, &a.weights, &a.skeleton), (&b.joints, &b.weights, &b.skeleton));
    assert_valid_skin(&a);
    let topology = a.mesh.topology();
    let open = (0..topology.edges().len()).filter(|&e| topology.edge_faces(e).len() != 2).count();
    let euler = topology.vertex_count() as i64 - topology.edges().len() as i64 + topology.triangles().len() as i64;
    assert_eq!((open, euler), (0, 2), "{name}: the welded mesh should be a closed surface of genus 0");
    assert_eq!(info_a.weight_conflicts, 0);
    println!(
        "{name}: {} file vertices weld to {} ({} weight conflicts), {} triangles, {} joints, {open} edges without exactly 2 faces",
        info_a.file_vertices,
        info_a.welded_vertices,
        info_a.weight_conflicts,
        info_a.triangles,
        a.skeleton.parents.len()
    );
    (a, info_a)
}

/// The world transform of every node, straight from the file, in f64.
fn node_world_transforms(path: &Path) -> Vec<DMat4> {
    let document = gltf::Gltf::open(path).unwrap();
    let mut parent = vec![None; document.nodes().len()];
    for node in document.nodes() {
        for child in node.children() {
            parent[child.index()] = Some(node.index());
        }
    }
    let local: Vec<DMat4> = document
        .nodes()
        .map(|n| match n.transform() {
            gltf::scene::Transform::Matrix { matrix } => Mat4::from_cols_array_2d(&matrix).as_dmat4(),
            gltf::scene::Transform::Decomposed { translation: t, rotation: r, scale: s } => {
                DMat4::from_scale_rotation_translation(
                    Vec3::from(s).as_dvec3(),
                    DQuat::from_array(r.map(f64::from)).normalize(),
                    Vec3::from(t).as_dvec3(),
                )
            }
        })
        .collect();
    (0..local.len())
        .map(|mut i| {
            let mut world = local[i];
            while let Some(p) = parent[i] {
                world = local[p] * world;
                i = p;
            }
            world
        })
        .collect()
}

/// The skeleton's rest world transforms equal the joint nodes' world transforms in the file
/// (matched by name).
fn assert_skeleton_matches_nodes(path: &Path, s: &SkinnedMesh) {
    let document = gltf::Gltf::open(path).unwrap();
    let node_world = node_world_transforms(path);
    let world = rest_world(&s.skeleton);
    for (j, name) in s.skeleton.names.iter().enumerate() {
        let node = document.nodes().find(|n| n.name() == Some(name)).unwrap();
        let diff = (world[j] - node_world[node.index()]).to_cols_array().iter().fold(0.0f64, |a, x| a.max(x.abs()));
        assert!(diff < 1e-5, "{}: joint `{name}` world transform differs by {diff}", path.display());
    }
}

#[test]
#[ignore = "needs DIFFSIL_ASSETS"]
fn rigged_simple_loads() {
    let (s, info) = load_pair("RiggedSimple");
    assert_eq!(s.skeleton.parents.len(), 2);
    assert_eq!(s.skeleton.parents, [None, Some(0)]);
    assert_eq!(info.file_vertices, 160);
    assert_eq!(info.triangles, 188);
    assert_eq!(info.welded_vertices, RIGGED_SIMPLE_WELDED);
    assert_skeleton_matches_nodes(&assets().join("RiggedSimple.gltf"), &s);
}

#[test]
#[ignore = "needs DIFFSIL_ASSETS"]
fn rigged_figure_loads() {
    let (s, info) = load_pair("RiggedFigure");
    assert_eq!(s.skeleton.parents.len(), 19);
    assert_eq!(info.file_vertices, 370);
    assert_eq!(info.triangles, 256);
    assert_eq!(info.welded_vertices, RIGGED_FIGURE_WELDED);
    assert!(info.welded_vertices < 370);
    assert_skeleton_matches_nodes(&assets().join("RiggedFigure.gltf"), &s);
    // SOURCES.md: world(joint)·IBM is the same matrix for all 19 joints within 1.4e-6.
    let world = rest_world(&s.skeleton);
    let products: Vec<DMat4> = world.iter().zip(&s.skeleton.inverse_bind).map(|(g, b)| *g * b.as_dmat4()).collect();
    let spread = products
        .iter()
        .map(|m| (*m - products[0]).to_cols_array().iter().fold(0.0f64, |a, x| a.max(x.abs())))
        .fold(0.0, f64::max);
    println!("RiggedFigure: world(joint)·IBM spread over the joints = {spread:.3e}; M = {:?}", products[0].as_mat4());
    assert!(spread <= 1.4e-6, "world·IBM spread {spread}");
    // The welded figure is closed: every edge has exactly two faces.
    let topology = s.mesh.topology();
    let open: Vec<[u32; 2]> = (0..topology.edges().len())
        .filter(|&e| topology.edge_faces(e).len() != 2)
        .map(|e| topology.edges()[e])
        .collect();
    assert_eq!(open.len(), RIGGED_FIGURE_OPEN_EDGES, "edges without exactly two faces: {open:?}");
}

#[test]
#[ignore = "needs DIFFSIL_ASSETS"]
fn cesium_man_loads() {
    let (s, info) = load_pair("CesiumMan");
    assert_eq!(s.skeleton.parents.len(), 19);
    assert_eq!(info.file_vertices, 3273);
    assert_eq!(info.triangles, 4672);
    assert_eq!(info.welded_vertices, CESIUM_MAN_WELDED);
    assert_skeleton_matches_nodes(&assets().join("CesiumMan.gltf"), &s);
}

#[test]
#[ignore = "needs DIFFSIL_ASSETS"]
fn assets_round_trip_through_save_glb() {
    for name in ["RiggedSimple", "RiggedFigure", "CesiumMan"] {
        let s = skinned(load_gltf(assets().join(format!("{name}.glb"))).unwrap());
        let path = temp_dir().join(format!("{name}.glb"));
        save_glb(&s, &path).unwrap();
        let back = skinned(load_gltf(&path).unwrap());
        assert_same_skinned(&s, &back);
        // Same rest pose too.
        let (a, b) = (load_mesh(assets().join(format!("{name}.glb"))).unwrap(), load_mesh(&path).unwrap());
        for (p, q) in a.positions().iter().zip(b.positions()) {
            assert!(p.abs_diff_eq(*q, 1e-5), "{name}: {p} vs {q}");
        }
    }
}

// Measured on the files in ../shared/assets (see SOURCES.md for their checksums).
// Each welded mesh is closed with Euler characteristic 2 (V − E + F: 96 − 282 + 188,
// 130 − 384 + 256, 2338 − 7008 + 4672), and no seam duplicate carries different weights.
const RIGGED_SIMPLE_WELDED: usize = 96;
const RIGGED_FIGURE_WELDED: usize = 130;
const RIGGED_FIGURE_OPEN_EDGES: usize = 0;
const CESIUM_MAN_WELDED: usize = 2338;
