//! Malformed and unsupported files: clear errors, no panics.

use super::*;

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
    // The header is fine; the first chunk's length field (noise) overruns the file.
    format_error(&write("magic.glb", &magic_then_noise), &["truncated GLB", "chunk 0", "re-export"]);
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
// Untrusted files (issue 13): nothing outside the model's folder, no devices, no panics.

/// A folder `root/model/` holding a `.gltf` whose buffer URI is `uri`, and beside the folder
/// `root/sentinel.bin` with the very bytes the buffer needs: a loader that follows the URI out of
/// the folder would succeed. Returns the `.gltf` path and the sentinel's path.
fn gltf_with_uri(uri_of: impl Fn(&Path) -> String) -> (PathBuf, PathBuf) {
    let root = temp_dir();
    let folder = root.join("model");
    std::fs::create_dir_all(&folder).unwrap();
    let mut doc = Doc::default();
    let body = static_doc(&mut doc);
    let sentinel = root.join("sentinel.bin");
    std::fs::write(&sentinel, &doc.bin).unwrap();
    std::fs::write(folder.join("inside.bin"), &doc.bin).unwrap();
    let gltf = folder.join("model.gltf");
    std::fs::write(&gltf, doc.json(&body, Some(&uri_of(&sentinel)))).unwrap();
    (gltf, sentinel)
}

#[test]
fn buffer_uris_outside_the_model_folder_are_refused() {
    // Inside the folder (also through `./` and a `..` that stays inside): loads.
    for uri in ["inside.bin", "./inside.bin", "sub/../inside.bin", "%69nside.bin"] {
        let (gltf, _) = gltf_with_uri(|_| uri.to_string());
        if uri.starts_with("sub/") {
            std::fs::create_dir_all(gltf.parent().unwrap().join("sub")).unwrap();
        }
        assert!(load_gltf(&gltf).is_ok(), "{uri}: {:?}", load_gltf(&gltf).err());
    }
    type UriOf = fn(&Path) -> String;
    let escapes: [(&str, UriOf, &str); 5] = [
        ("absolute", |s| s.display().to_string(), "absolute path"),
        ("parent", |_| "../sentinel.bin".into(), "climbs above"),
        ("deeper parent", |_| "a/../../sentinel.bin".into(), "climbs above"),
        ("percent-encoded parent", |_| "%2e%2e/sentinel.bin".into(), "climbs above"),
        ("etc", |_| "/etc/passwd".into(), "absolute path"),
    ];
    for (case, uri_of, words) in escapes {
        let (gltf, _) = gltf_with_uri(uri_of);
        let reason = format_error(&gltf, &["buffer 0", "outside the model's folder", "allow_outside_folder", words]);
        println!("{case}: {reason}");
    }
    // A symbolic link in the folder pointing out of it.
    let (gltf, sentinel) = gltf_with_uri(|_| "link.bin".into());
    std::os::unix::fs::symlink(&sentinel, gltf.parent().unwrap().join("link.bin")).unwrap();
    format_error(&gltf, &["buffer 0", "symbolic link", "outside the model's folder"]);
    // Trusted files may opt in.
    let options = LoadOptions { allow_outside_folder: true, ..LoadOptions::default() };
    assert!(load_gltf_with_options(&gltf, &options).is_ok());
    let (gltf, _) = gltf_with_uri(|_| "../sentinel.bin".into());
    assert!(load_gltf_with_options(&gltf, &options).is_ok());
}

#[test]
fn device_and_fifo_buffers_are_refused_without_blocking() {
    let start = std::time::Instant::now();
    let options = LoadOptions { allow_outside_folder: true, ..LoadOptions::default() };
    for device in ["/dev/zero", "/dev/stdin"] {
        let (gltf, _) = gltf_with_uri(|_| device.into());
        format_error(&gltf, &["absolute path", "outside the model's folder"]);
        // Even when allowed outside the folder, a device is not a regular file.
        match load_gltf_with_options(&gltf, &options) {
            Err(Error::Format { reason, .. }) => assert!(reason.contains("not a regular file"), "{device}: {reason}"),
            other => panic!("{device}: expected a Format error, got {other:?}"),
        }
    }
    let (gltf, _) = gltf_with_uri(|_| "pipe.bin".into());
    let fifo = gltf.parent().unwrap().join("pipe.bin");
    assert!(std::process::Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    match load_gltf(&gltf) {
        Err(Error::Format { path, reason }) => {
            assert_eq!(path, fifo);
            assert!(reason.contains("pipe") && reason.contains("regular file"), "{reason}");
        }
        other => panic!("expected a Format error, got {other:?}"),
    }
    assert!(start.elapsed().as_secs_f64() < 2.0, "took {:?}", start.elapsed());
}

#[test]
fn buffer_sizes_above_the_limits_are_refused_before_reading() {
    let (gltf, _) = gltf_with_uri(|_| "inside.bin".into());
    let small = LoadOptions { max_file_bytes: 16, ..LoadOptions::default() };
    let reason = match load_gltf_with_options(&gltf, &small) {
        Err(Error::Format { reason, .. }) => reason,
        other => panic!("expected a Format error, got {other:?}"),
    };
    assert!(reason.contains("limit of 16 bytes") && reason.contains("LoadOptions::max_file_bytes"), "{reason}");

    // A declared byteLength of 1e12 (a data URI cannot back it): refused before decoding.
    let mut doc = Doc::default();
    let body = static_doc(&mut doc);
    let json = doc
        .embedded_gltf(&body)
        .replace(&format!(r#""byteLength":{}"#, doc.bin.len()), r#""byteLength":1000000000000"#);
    format_error(&write("huge.gltf", json.as_bytes()), &["buffer 0", "byteLength of 1000000000000", "above the limit"]);
    let tight = LoadOptions { max_total_bytes: 8, ..LoadOptions::default() };
    let glb = write("total.glb", &doc.glb(&body));
    match load_gltf_with_options(&glb, &tight) {
        Err(Error::Format { reason, .. }) => assert!(reason.contains("max_total_bytes"), "{reason}"),
        other => panic!("expected a Format error, got {other:?}"),
    }
}

#[test]
fn an_out_of_range_position_accessor_is_an_error_not_a_panic() {
    let mut doc = Doc::default();
    let pos = doc.positions(&[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    let body = format!(r#""meshes":[{{"primitives":[{{"attributes":{{"POSITION":{}}}}}]}}]"#, pos + 7);
    format_error(
        &write("accessor.glb", &doc.glb(&body)),
        &["POSITION accessor 7", "only 1 accessors", "fix the index"],
    );
}

#[test]
fn glb_chunk_errors_name_the_chunk_without_nul_bytes() {
    let mut doc = Doc::default();
    let body = static_doc(&mut doc);
    let mut bytes = doc.glb(&body);
    // The BIN chunk's length field: after the header, the JSON chunk and its 8-byte header.
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let at = 12 + 8 + json_len;
    bytes[at..at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
    let reason = format_error(&write("chunk.glb", &bytes), &["truncated GLB", "chunk 1 (`BIN`)", "re-export"]);
    assert!(!reason.contains('\0'), "{reason:?}");
}

#[test]
fn joint_transforms_near_the_f32_limit_are_rejected_with_the_joint_named() {
    let mut doc = Doc::default();
    let body = skinned_quad(&mut doc, &QUAD_WEIGHTS, "")
        .replace(r#"{"name":"child","translation":[0,1,0]}"#, r#"{"name":"child","translation":[0,3e38,0]}"#);
    assert!(body.contains("3e38"));
    format_error(&write("far.glb", &doc.glb(&body)), &["skeleton", "joint 1 (`child`)", "3e38", "rescale the model"]);
    // And a pose that drives a translation there.
    let model = match load_gltf(write("quad.glb", &doc.glb(&skinned_quad(&mut Doc::default(), &QUAD_WEIGHTS, "")))) {
        Ok(Model::Skinned(m)) => m,
        other => panic!("expected a skinned model, got {other:?}"),
    };
    let mut pose = diffsil::pose::skin::Pose::rest(model.joint_count());
    pose.translation = Vec3::new(3e38, 0.0, 0.0);
    let message = model.skin(&pose).unwrap_err().to_string();
    assert!(message.contains("translation") && message.contains("3e38") && message.contains("1e18"), "{message}");
}

#[test]
fn a_skinned_model_with_a_non_finite_rest_vertex_names_the_file() {
    // Three nested scales of 1e18 (each allowed) compose to 1e54, beyond f32 once skinned.
    let mut doc = Doc::default();
    let body = skinned_quad(&mut doc, &QUAD_WEIGHTS, "")
        .replace(r#""translation":[0,0,5],"children":[2]"#, r#""scale":[1e18,1e18,1e18],"children":[2]"#)
        .replace(r#"{"name":"root","translation":[0,1,0]"#, r#"{"name":"root","scale":[1e18,1e18,1e18]"#)
        .replace(r#"{"name":"child","translation":[0,1,0]}"#, r#"{"name":"child","scale":[1e18,1e18,1e18]}"#);
    let path = write("overflow.glb", &doc.glb(&body));
    match diffsil::io::gltf::load_mesh(&path) {
        Err(Error::Format { path: p, reason }) => {
            assert_eq!(p, path);
            assert!(reason.contains("rest pose") && reason.contains("non-finite"), "{reason}");
        }
        other => panic!("expected a Format error naming the file, got {other:?}"),
    }
}
