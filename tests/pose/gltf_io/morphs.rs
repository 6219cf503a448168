//! Morph targets: POSITION deltas welded like the vertices, names from `mesh.extras.targetNames`,
//! joint offsets from `skins[0].extras.morphJointOffsets` remapped to the skeleton's joint order,
//! and the MakeHuman body (ignored asset test).

use diffsil::pose::skin::Pose;

use super::*;

/// Little-endian VEC3 float deltas as an accessor (no min / max needed for targets here).
fn deltas(doc: &mut Doc, d: &[[f32; 3]]) -> usize {
    doc.accessor(d.iter().flatten().flat_map(|x| x.to_le_bytes()).collect(), 5126, d.len(), "VEC3", "")
}

/// The corners of [`skinned_quad`]'s geometry as two primitives (corners 0–2 and 3–5, the second
/// repeating positions of the first), each with two morph targets, plus the given extras.
fn morph_quad(doc: &mut Doc, mesh_extras: &str, skin_extras: &str, second_targets: usize) -> String {
    let p = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]];
    let q = [[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
    let (pos_a, pos_b) = (doc.positions(&p), doc.positions(&q));
    let j = doc.joints(&[[1, 0, 0, 0], [1, 0, 0, 0], [0, 1, 0, 0]]);
    let w = doc.weights(&[[1.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0.5, 0.5, 0.0, 0.0]]);
    // Target 0 ("wide"): +x growing with the corner; target 1 ("tall"): +y on the top corners.
    let wide_a = deltas(doc, &[[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [0.5, 0.0, 0.25]]);
    let tall_a = deltas(doc, &[[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 2.0, 0.0]]);
    // The second primitive's corner 0 repeats corner 0 and corner 1 repeats corner 2: welding keeps
    // the first occurrence's deltas, so these values (different on purpose) must be dropped.
    let wide_b = deltas(doc, &[[9.0, 9.0, 9.0], [9.0, 9.0, 9.0], [-0.5, 0.0, 0.0]]);
    let tall_b = deltas(doc, &[[9.0, 9.0, 9.0], [9.0, 9.0, 9.0], [0.0, 2.0, 1.0]]);
    let ibm = doc.matrices(&[Mat4::from_translation(Vec3::new(0.0, -3.0, 0.0)), Mat4::IDENTITY]);
    let targets_b = [format!(r#"{{"POSITION":{wide_b}}}"#), format!(r#"{{"POSITION":{tall_b}}}"#)];
    let targets_b = targets_b[..second_targets].join(",");
    format!(
        r#""scene":0,"scenes":[{{"nodes":[0,1]}}],
        "nodes":[
          {{"name":"mesh","mesh":0,"skin":0}},
          {{"name":"armature","translation":[0,0,5],"children":[2]}},
          {{"name":"root","translation":[0,1,0],"children":[3]}},
          {{"name":"child","translation":[0,1.5,0]}}
        ],
        "meshes":[{{"primitives":[
          {{"attributes":{{"POSITION":{pos_a},"JOINTS_0":{j},"WEIGHTS_0":{w}}},
            "targets":[{{"POSITION":{wide_a}}},{{"POSITION":{tall_a}}}]}},
          {{"attributes":{{"POSITION":{pos_b},"JOINTS_0":{j},"WEIGHTS_0":{w}}},"targets":[{targets_b}]}}
        ]{mesh_extras}}}],
        "skins":[{{"joints":[3,2],"inverseBindMatrices":{ibm}{skin_extras}}}]"#
    )
}

const NAMES: &str = r#","extras":{"targetNames":["wide","tall"]}"#;
/// Per target, one offset per file joint (file joint 0 = `child`, 1 = `root`).
const OFFSETS: &str =
    r#","extras":{"morphJointOffsets":{"wide":[[0.5,0,0],[0.25,0,0]],"tall":[[0,2,0],[0,1,0]],"unused":[]}}"#;

#[test]
fn morph_targets_load_welded_with_names_and_joint_offsets() {
    let mut doc = Doc::default();
    let body = morph_quad(&mut doc, NAMES, OFFSETS, 2);
    let (model, info) = load_gltf_with_info(write("morph_quad.glb", &doc.glb(&body))).unwrap();
    assert_eq!((info.file_vertices, info.welded_vertices), (6, 4));
    let s = skinned(model);
    assert_eq!(s.mesh.positions(), [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y]);
    // Joints come parents first and keep their node indices and names.
    assert_eq!(s.skeleton.names, ["root", "child"]);
    assert_eq!(s.skeleton.nodes, [2, 3]);
    let m = &s.morphs;
    assert_eq!(m.names, ["wide", "tall"]);
    // Welded vertex k is file corner 0, 1, 2, 5: the first primitive's deltas, then the second
    // primitive's last corner.
    assert_eq!(
        m.deltas[0],
        [Vec3::ZERO, Vec3::new(0.5, 0.0, 0.0), Vec3::new(0.5, 0.0, 0.25), Vec3::new(-0.5, 0.0, 0.0)]
    );
    assert_eq!(m.deltas[1], [Vec3::ZERO, Vec3::ZERO, Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, 2.0, 1.0)]);
    // Offsets in the skeleton's order: joint 0 = `root` = file joint 1.
    let offsets = m.joint_offsets.as_ref().unwrap();
    assert_eq!(offsets[0], [Vec3::new(0.25, 0.0, 0.0), Vec3::new(0.5, 0.0, 0.0)]);
    assert_eq!(offsets[1], [Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 2.0, 0.0)]);

    // The joints follow the shape: at rest, root at (0, 1, 5) and child at (0, 2.5, 5) move by
    // 0.5·wide + 0.25·tall offsets.
    let betas = [0.5, 0.25];
    let rest = Pose::rest(2);
    let g = s.joint_transforms_shaped(&rest, &betas).unwrap();
    let expected = [Vec3::new(0.125, 1.25, 5.0), Vec3::new(0.25, 3.0, 5.0)];
    for j in 0..2 {
        assert!(g[j].w_axis.truncate().abs_diff_eq(expected[j], 1e-6), "joint {j}: {}", g[j].w_axis);
    }
    // The inverse bind matrices here are not the inverse rest ones (IBM_root = I, the file's
    // choice), so compare the shaped skin with the hand-computed LBS of the shaped vertices:
    // M_j = G'_j · IBM_j · T(−Δp_j).
    let posed = s.skin_shaped(&rest, &betas).unwrap();
    let ibm = [Mat4::IDENTITY, Mat4::from_translation(Vec3::new(0.0, -3.0, 0.0))];
    let dp = [Vec3::new(0.125, 0.25, 0.0), Vec3::new(0.25, 0.5, 0.0)];
    let m_j = |j: usize| g[j] * ibm[j] * Mat4::from_translation(-dp[j]);
    for (i, p) in posed.iter().enumerate() {
        let v = s.mesh.positions()[i] + 0.5 * m.deltas[0][i] + 0.25 * m.deltas[1][i];
        let (js, ws) = (s.joints[i], s.weights[i]);
        let expected: Vec3 = (0..4).map(|k| ws[k] * m_j(js[k] as usize).transform_point3(v)).sum();
        assert!(p.abs_diff_eq(expected, 1e-5), "vertex {i}: {p} vs {expected}");
    }
}

#[test]
fn morph_targets_without_names_or_offsets() {
    let mut doc = Doc::default();
    let body = morph_quad(&mut doc, "", "", 2);
    let s = skinned(load_gltf(write("morph_quad_plain.glb", &doc.glb(&body))).unwrap());
    assert_eq!(s.morphs.names, ["target_0", "target_1"]);
    assert_eq!(s.morphs.joint_offsets, None);
    // Without offsets the joints stay put.
    let rest = Pose::rest(2);
    assert_eq!(s.joint_transforms_shaped(&rest, &[1.0, -1.0]).unwrap(), s.joint_transforms(&rest).unwrap());
}

#[test]
fn inconsistent_morph_targets_are_clear_errors() {
    let mut doc = Doc::default();
    let body = morph_quad(&mut doc, NAMES, "", 1);
    let err = load_gltf(write("morph_quad_counts.glb", &doc.glb(&body))).unwrap_err();
    assert!(err.to_string().contains("morph targets"), "{err}");
    let mut doc = Doc::default();
    let bad = r#","extras":{"morphJointOffsets":{"wide":[[0.5,0,0]]}}"#;
    let body = morph_quad(&mut doc, NAMES, bad, 2);
    let err = load_gltf(write("morph_quad_offsets.glb", &doc.glb(&body))).unwrap_err();
    assert!(err.to_string().contains("morphJointOffsets.wide"), "{err}");
}

#[test]
#[ignore = "needs DIFFSIL_ASSETS"]
fn makehuman_body_shapes_move_surface_and_joints() {
    let path =
        PathBuf::from(std::env::var_os("DIFFSIL_ASSETS").expect("set DIFFSIL_ASSETS")).join("makehuman-body-7k.glb");
    let s = skinned(load_gltf(path).unwrap());
    assert_eq!((s.joint_count(), s.shape_count(), s.vertex_count()), (31, 10, 7000));
    assert_eq!(s.skeleton.nodes, (0..31).collect::<Vec<_>>());
    assert_eq!(s.skeleton.names[3], "LeftLeg");
    let leg = s.morphs.names.iter().position(|n| n == "leg_length").unwrap();
    let offsets = s.morphs.joint_offsets.as_ref().expect("the body has joint offsets");
    let rest = Pose::rest(31);
    let mut betas = vec![0.0; 10];
    betas[leg] = 1.0;
    let plain = s.joint_transforms(&rest).unwrap();
    let shaped = s.joint_transforms_shaped(&rest, &betas).unwrap();
    // The hips rise with longer legs, by the file's offset.
    let hips = shaped[0].w_axis.truncate() - plain[0].w_axis.truncate();
    assert!(hips.abs_diff_eq(offsets[leg][0], 1e-5) && hips.y > 0.1, "hips moved by {hips}");
    // The body grows by about the documented 18.5 cm, soles on the ground.
    let height = |v: &[Vec3]| {
        let (lo, hi) = v.iter().fold((f32::MAX, f32::MIN), |(lo, hi), p| (lo.min(p.y), hi.max(p.y)));
        (lo, hi - lo)
    };
    let (floor0, h0) = height(&s.skin(&rest).unwrap());
    let (floor1, h1) = height(&s.skin_shaped(&rest, &betas).unwrap());
    println!("makehuman 7k: height {h0:.4} m → {h1:.4} m with leg_length 1, floor {floor0:.4} → {floor1:.4}");
    assert!((h1 - h0 - 0.185).abs() < 0.03 && floor1.abs() < 0.01, "height {h0} → {h1}, floor {floor1}");
    // Posed and shaped: a bent knee follows the longer leg (the ankle is lower relative to the
    // hips than without shape) and nothing is NaN.
    let mut pose = rest.clone();
    pose.joint_rotations[3] = Vec3::new(1.2, 0.0, 0.0);
    let posed = s.skin_shaped(&pose, &betas).unwrap();
    assert!(posed.iter().all(|p| p.is_finite()));
}
