//! Round trips and loading of hand-written documents (no assets needed).

use super::*;

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
