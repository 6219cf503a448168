//! glTF animations: a tiny hand-written clip per interpolation mode, sampled between keys against
//! hand-computed values, scale channels on joints with a non-unit rest scale, and CesiumMan's
//! walk (ignored asset test).

use diffsil::io::gltf::load_animations;
use diffsil::pose::skin::{Animation, Interpolation, Pose, Property};

use super::*;

fn floats(doc: &mut Doc, values: &[f32], kind: &str, count: usize) -> usize {
    doc.accessor(values.iter().flat_map(|x| x.to_le_bytes()).collect(), 5126, count, kind, "")
}

fn quat(q: Quat) -> [f32; 4] {
    q.to_array()
}

/// Two joints: `root` (node 1, rest translation (0, 1, 0)) and `child` (node 2, rest translation
/// (0, 1, 0) and rest rotation 0.3 rad about z), skinning one triangle (mesh node 0). Four clips:
/// `step` and `linear` (child rotation about x from 0.2 to 1.0 rad over [0, 2] s; `linear` also
/// moves the root from (0, 1, 0) to (2, 1, 0)), `cubic` (root translation and child rotation as
/// cubic splines over [0, 2] s), and an unnamed one (a linear scale channel on the child, from 1
/// to 2 over [0, 2] s, and a channel on the mesh node, which is skipped).
fn animated_doc(doc: &mut Doc) -> String {
    let pos = doc.positions(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 2.0, 0.0]]);
    let j = doc.joints(&[[0, 0, 0, 0], [0, 0, 0, 0], [1, 0, 0, 0]]);
    let w = doc.weights(&[[1.0, 0.0, 0.0, 0.0]; 3]);
    let rest_child = Mat4::from_translation(Vec3::Y) * Mat4::from_quat(Quat::from_rotation_z(0.3));
    let ibm =
        doc.matrices(&[Mat4::from_translation(-Vec3::Y), (Mat4::from_translation(Vec3::Y) * rest_child).inverse()]);
    let times = floats(doc, &[0.0, 2.0], "SCALAR", 2);
    let rotations = [quat(Quat::from_rotation_x(0.2)), quat(Quat::from_rotation_x(1.0))].concat();
    let rot = floats(doc, &rotations, "VEC4", 2);
    let moves = floats(doc, &[0.0, 1.0, 0.0, 2.0, 1.0, 0.0], "VEC3", 2);
    // Cubic: [in0, v0, out0, in1, v1, out1].
    let cubic_moves = floats(
        doc,
        &[0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 4.0, 2.0, 1.0, 0.0, 0.0, 0.0, 0.0],
        "VEC3",
        6,
    );
    let zero = [0.0f32; 4];
    let cubic_rotations =
        [zero, quat(Quat::from_rotation_x(0.2)), zero, zero, quat(Quat::from_rotation_x(1.0)), zero].concat();
    let cubic_rot = floats(doc, &cubic_rotations, "VEC4", 6);
    let scales = floats(doc, &[1.0, 1.0, 1.0, 2.0, 2.0, 2.0], "VEC3", 2);
    let sampler = |input: usize, output: usize, mode: &str| {
        format!(r#"{{"input":{input},"output":{output},"interpolation":"{mode}"}}"#)
    };
    let channel = |sampler: usize, node: usize, path: &str| {
        format!(r#"{{"sampler":{sampler},"target":{{"node":{node},"path":"{path}"}}}}"#)
    };
    let rz = format!("{:?}", quat(Quat::from_rotation_z(0.3)));
    format!(
        r#""scene":0,"scenes":[{{"nodes":[0,1]}}],
        "nodes":[
          {{"name":"mesh","mesh":0,"skin":0}},
          {{"name":"root","translation":[0,1,0],"children":[2]}},
          {{"name":"child","translation":[0,1,0],"rotation":{rz}}}
        ],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":{pos},"JOINTS_0":{j},"WEIGHTS_0":{w}}}}}]}}],
        "skins":[{{"joints":[1,2],"inverseBindMatrices":{ibm}}}],
        "animations":[
          {{"name":"step","samplers":[{s_step}],"channels":[{c_step}]}},
          {{"name":"linear","samplers":[{s_lin_r},{s_lin_t}],"channels":[{c_lin_r},{c_lin_t}]}},
          {{"name":"cubic","samplers":[{s_cub_r},{s_cub_t}],"channels":[{c_cub_r},{c_cub_t}]}},
          {{"samplers":[{s_scale},{s_lin_t}],"channels":[{c_scale},{c_mesh}]}}
        ]"#,
        s_step = sampler(times, rot, "STEP"),
        c_step = channel(0, 2, "rotation"),
        s_lin_r = sampler(times, rot, "LINEAR"),
        s_lin_t = sampler(times, moves, "LINEAR"),
        c_lin_r = channel(0, 2, "rotation"),
        c_lin_t = channel(1, 1, "translation"),
        s_cub_r = sampler(times, cubic_rot, "CUBICSPLINE"),
        s_cub_t = sampler(times, cubic_moves, "CUBICSPLINE"),
        c_cub_r = channel(0, 2, "rotation"),
        c_cub_t = channel(1, 1, "translation"),
        s_scale = sampler(times, scales, "LINEAR"),
        c_scale = channel(0, 2, "scale"),
        c_mesh = channel(1, 0, "translation"),
    )
}

/// The child's rotation offset that turns its rest rotation (0.3 rad about z) into `q`.
fn child_offset(q: Quat) -> Vec3 {
    let offset = (Quat::from_rotation_z(0.3).inverse() * q).normalize();
    let (axis, angle) = offset.to_axis_angle();
    axis * angle
}

fn load() -> (SkinnedMesh, Vec<Animation>) {
    let mut doc = Doc::default();
    let body = animated_doc(&mut doc);
    let path = write("animated.glb", &doc.glb(&body));
    (skinned(load_gltf(&path).unwrap()), load_animations(&path).unwrap())
}

fn assert_vec3(a: Vec3, b: Vec3, label: &str) {
    assert!(a.abs_diff_eq(b, 2e-6), "{label}: {a} vs {b}");
}

#[test]
fn clips_load_with_names_modes_and_skipped_channels() {
    let (s, clips) = load();
    let names: Vec<&str> = clips.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["step", "linear", "cubic", "animation_3"]);
    assert_eq!(clips[0].channels[0].interpolation, Interpolation::Step);
    assert_eq!(
        clips[1].channels.iter().map(|c| (c.joint, c.property)).collect::<Vec<_>>(),
        [(1, Property::Rotation), (0, Property::Translation)]
    );
    assert_eq!(clips[2].channels[0].values.len(), 6, "cubic splines keep in / value / out per key");
    assert!(clips.iter().all(|c| c.duration == 2.0 || c.channels.is_empty()));
    assert_eq!(clips[3].ignored_other_channels, 1);
    assert_eq!(clips[3].channels.iter().map(|c| (c.joint, c.property)).collect::<Vec<_>>(), [(1, Property::Scale)]);
    assert!(!clips[0].has_translations() && clips[1].has_translations());
    assert!(!clips[1].has_scales() && clips[3].has_scales());
    // Scaled halfway (1.5 at t = 1), rotated and moved not at all.
    let pose = clips[3].sample(&s.skeleton, 1.0).unwrap();
    assert_eq!(pose.joint_scales, [Vec3::ONE, Vec3::splat(1.5)]);
    assert_eq!(pose.joint_rotations, [Vec3::ZERO; 2]);
    assert!(pose.joint_translations.is_empty());
    // A clip with no channels samples to the rest pose.
    let empty = Animation { channels: Vec::new(), ..clips[3].clone() };
    assert_eq!(empty.sample(&s.skeleton, 1.0).unwrap(), Pose::rest(2));
}

#[test]
fn step_holds_the_previous_key() {
    let (s, clips) = load();
    for (time, angle) in [(-1.0, 0.2), (0.0, 0.2), (0.5, 0.2), (1.99, 0.2), (2.0, 1.0), (5.0, 1.0)] {
        let pose = clips[0].sample(&s.skeleton, time).unwrap();
        assert_vec3(pose.joint_rotations[1], child_offset(Quat::from_rotation_x(angle)), &format!("t = {time}"));
        assert_eq!(pose.joint_rotations[0], Vec3::ZERO);
        assert!(pose.joint_translations.is_empty());
    }
}

#[test]
fn linear_slerps_rotations_and_lerps_translations() {
    let (s, clips) = load();
    let pose = clips[1].sample(&s.skeleton, 0.5).unwrap();
    // s = 0.25: 0.2 + 0.25·0.8 = 0.4 rad about x; the root at (0.5, 1, 0), i.e. τ = (0.5, 0, 0).
    assert_vec3(pose.joint_rotations[1], child_offset(Quat::from_rotation_x(0.4)), "rotation");
    assert_vec3(pose.joint_translations[0], Vec3::new(0.5, 0.0, 0.0), "root translation");
    assert_vec3(pose.joint_translations[1], Vec3::ZERO, "child translation");
    // Skinned at that pose, the joints are where the animated node transforms put them.
    let g = s.joint_transforms(&pose).unwrap();
    let root = Mat4::from_translation(Vec3::new(0.5, 1.0, 0.0));
    let child = root * Mat4::from_translation(Vec3::Y) * Mat4::from_quat(Quat::from_rotation_x(0.4));
    assert!(g[0].abs_diff_eq(root, 1e-6) && g[1].abs_diff_eq(child, 1e-6), "{g:?}");
}

#[test]
fn cubic_spline_follows_the_hermite_formula() {
    let (s, clips) = load();
    let pose = clips[2].sample(&s.skeleton, 1.0).unwrap();
    // s = 0.5, Δt = 2: p = 0.5·v0 + 0.25·out0 + 0.5·v1 − 0.25·in1 = (1.25, 1, −1).
    assert_vec3(pose.joint_translations[0], Vec3::new(1.25, 0.0, -1.0), "root translation");
    // Zero tangents, midpoint: normalise(q0 + q1) = 0.6 rad about x.
    assert_vec3(pose.joint_rotations[1], child_offset(Quat::from_rotation_x(0.6)), "rotation");
    // At s = 0.25: h = (0.84375, 0.28125, 0.15625, −0.09375) (with Δt folded into the tangents).
    let pose = clips[2].sample(&s.skeleton, 0.5).unwrap();
    let expected =
        0.84375 * Vec3::Y + 0.28125 * Vec3::X + 0.15625 * Vec3::new(2.0, 1.0, 0.0) - 0.09375 * Vec3::new(0.0, 0.0, 4.0);
    assert_vec3(pose.joint_translations[0], expected - Vec3::Y, "root translation at s = 0.25");
}

/// Two joints with non-unit rest scales: `root` (node 1, scale (2, 1, 0.5)) and `child` (node 2,
/// translation (0, 1, 0), scale (1, 3, 1)), skinning one triangle. Two clips: `scales`, the
/// root's scale linear from (2, 1, 0.5) to (4, 1, 1) over [0, 2] s and the child's by steps
/// from (1, 3, 1) to (2, 6, 3); `cubic_scale`, the child's as a cubic spline from (1, 3, 1) to
/// (1, 6, 1) with out-tangent (0, 2, 0) at the first key and in-tangent (0, 4, 0) at the second.
fn scaled_doc(doc: &mut Doc) -> String {
    let pos = doc.positions(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 2.0, 0.0]]);
    let j = doc.joints(&[[0, 0, 0, 0], [0, 0, 0, 0], [1, 0, 0, 0]]);
    let w = doc.weights(&[[1.0, 0.0, 0.0, 0.0]; 3]);
    let root = Mat4::from_scale(Vec3::new(2.0, 1.0, 0.5));
    let child = root * Mat4::from_scale_rotation_translation(Vec3::new(1.0, 3.0, 1.0), Quat::IDENTITY, Vec3::Y);
    let ibm = doc.matrices(&[root.inverse(), child.inverse()]);
    let times = floats(doc, &[0.0, 2.0], "SCALAR", 2);
    let root_scales = floats(doc, &[2.0, 1.0, 0.5, 4.0, 1.0, 1.0], "VEC3", 2);
    let child_steps = floats(doc, &[1.0, 3.0, 1.0, 2.0, 6.0, 3.0], "VEC3", 2);
    // Cubic: [in0, v0, out0, in1, v1, out1].
    let child_cubic = floats(
        doc,
        &[0.0, 0.0, 0.0, 1.0, 3.0, 1.0, 0.0, 2.0, 0.0, 0.0, 4.0, 0.0, 1.0, 6.0, 1.0, 0.0, 0.0, 0.0],
        "VEC3",
        6,
    );
    format!(
        r#""scene":0,"scenes":[{{"nodes":[0,1]}}],
        "nodes":[
          {{"name":"mesh","mesh":0,"skin":0}},
          {{"name":"root","scale":[2,1,0.5],"children":[2]}},
          {{"name":"child","translation":[0,1,0],"scale":[1,3,1]}}
        ],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":{pos},"JOINTS_0":{j},"WEIGHTS_0":{w}}}}}]}}],
        "skins":[{{"joints":[1,2],"inverseBindMatrices":{ibm}}}],
        "animations":[
          {{"name":"scales","samplers":[
              {{"input":{times},"output":{root_scales},"interpolation":"LINEAR"}},
              {{"input":{times},"output":{child_steps},"interpolation":"STEP"}}],
            "channels":[
              {{"sampler":0,"target":{{"node":1,"path":"scale"}}}},
              {{"sampler":1,"target":{{"node":2,"path":"scale"}}}}]}},
          {{"name":"cubic_scale","samplers":[{{"input":{times},"output":{child_cubic},"interpolation":"CUBICSPLINE"}}],
            "channels":[{{"sampler":0,"target":{{"node":2,"path":"scale"}}}}]}}
        ]"#
    )
}

fn load_scaled() -> (SkinnedMesh, Vec<Animation>) {
    let mut doc = Doc::default();
    let body = scaled_doc(&mut doc);
    let path = write("scaled.glb", &doc.glb(&body));
    (skinned(load_gltf(&path).unwrap()), load_animations(&path).unwrap())
}

#[test]
fn scale_channels_sample_to_factors_of_the_rest_scale() {
    let (s, clips) = load_scaled();
    assert_eq!(s.skeleton.rest[0].scale, Vec3::new(2.0, 1.0, 0.5));
    let scales = &clips[0];
    assert!(scales.has_scales() && !scales.has_translations());
    // t = 0.5 (s = 0.25): the root at (2.5, 1, 0.625), 1.25 × (1, 1, 1.25) its rest; the child still
    // at its first key (a factor of 1).
    let pose = scales.sample(&s.skeleton, 0.5).unwrap();
    assert_vec3(pose.joint_scales[0], Vec3::new(1.25, 1.0, 1.25), "root, linear");
    assert_vec3(pose.joint_scales[1], Vec3::ONE, "child, step before its second key");
    assert_eq!(pose.joint_rotations, [Vec3::ZERO; 2]);
    // At and after the last key the child's step reaches (2, 6, 3): twice its rest scale.
    let end = scales.sample(&s.skeleton, 2.0).unwrap();
    assert_vec3(end.joint_scales[0], Vec3::new(2.0, 1.0, 2.0), "root, last key");
    assert_vec3(end.joint_scales[1], Vec3::new(2.0, 2.0, 3.0), "child, last key");
    // The skinned joints are where the animated node transforms put them.
    let g = s.joint_transforms(&pose).unwrap();
    let root = Mat4::from_scale(Vec3::new(2.5, 1.0, 0.625));
    let child = root * Mat4::from_scale_rotation_translation(Vec3::new(1.0, 3.0, 1.0), Quat::IDENTITY, Vec3::Y);
    assert!(g[0].abs_diff_eq(root, 1e-6) && g[1].abs_diff_eq(child, 1e-6), "{g:?}");
    // And the vertices follow: the child's vertex (0, 2, 0) is bound at the child's rest.
    let v = s.skin(&end).unwrap();
    let root_end = Mat4::from_scale(Vec3::new(4.0, 1.0, 1.0));
    let child_end = root_end * Mat4::from_scale_rotation_translation(Vec3::new(2.0, 6.0, 3.0), Quat::IDENTITY, Vec3::Y);
    let bound = (Mat4::from_scale(Vec3::new(2.0, 1.0, 0.5))
        * Mat4::from_scale_rotation_translation(Vec3::new(1.0, 3.0, 1.0), Quat::IDENTITY, Vec3::Y))
    .inverse();
    assert_vec3(v[2], (child_end * bound).transform_point3(Vec3::new(0.0, 2.0, 0.0)), "skinned vertex");
    assert_vec3(v[1], root_end.transform_point3(Vec3::new(0.5, 0.0, 0.0)), "root's vertex");
}

#[test]
fn cubic_spline_scales_follow_the_hermite_formula() {
    let (s, clips) = load_scaled();
    // s = 0.5, Δt = 2: y = 0.5·3 + 0.25·2 + 0.5·6 − 0.25·4 = 4, a factor 4/3 of the rest's 3.
    let pose = clips[1].sample(&s.skeleton, 1.0).unwrap();
    assert_vec3(pose.joint_scales[1], Vec3::new(1.0, 4.0 / 3.0, 1.0), "child, midpoint");
    assert_vec3(pose.joint_scales[0], Vec3::ONE, "root, not animated");
    // s = 0.25: h = (0.84375, 0.28125, 0.15625, −0.09375), Δt folded into the tangents.
    let pose = clips[1].sample(&s.skeleton, 0.5).unwrap();
    let y = 0.84375 * 3.0 + 0.28125 * 2.0 + 0.15625 * 6.0 - 0.09375 * 4.0;
    assert_vec3(pose.joint_scales[1], Vec3::new(1.0, y / 3.0, 1.0), "child, s = 0.25");
}

#[test]
fn a_scale_of_a_zero_rest_scale_is_a_clear_error() {
    let (mut s, clips) = load_scaled();
    // The child's rest scale flattened in y: its keys (3 and 6 in y) are no factor of 0.
    s.skeleton.rest[1].scale.y = 0.0;
    let err = clips[0].sample(&s.skeleton, 0.5).unwrap_err();
    assert!(err.to_string().contains("joint 1") && err.to_string().contains("rest scale"), "{err}");
    // Where the key is 0 as well, the factor is 1.
    let mut flat = clips[0].clone();
    flat.channels[1].values.iter_mut().for_each(|v| v[1] = 0.0);
    assert_eq!(flat.sample(&s.skeleton, 0.5).unwrap().joint_scales[1].y, 1.0);
}

#[test]
fn malformed_animations_are_clear_errors() {
    let (s, clips) = load();
    assert!(clips[1].sample(&s.skeleton, f32::NAN).is_err());
    let mut bad = clips[1].clone();
    bad.channels[0].times = vec![1.0, 1.0];
    assert!(bad.sample(&s.skeleton, 0.5).unwrap_err().to_string().contains("increasing"));
    let mut bad = clips[1].clone();
    bad.nodes.pop();
    assert!(matches!(bad.sample(&s.skeleton, 0.5), Err(Error::LengthMismatch { .. })));
    // A file whose mesh has no skin has no skeleton to animate.
    let mut doc = Doc::default();
    let body = static_doc(&mut doc);
    let err = load_animations(write("static_anim.glb", &doc.glb(&body))).unwrap_err();
    assert!(err.to_string().contains("no skin"), "{err}");
}

#[test]
#[ignore = "needs DIFFSIL_ASSETS"]
fn cesium_man_walk_samples_to_its_keys() {
    let path = PathBuf::from(std::env::var_os("DIFFSIL_ASSETS").expect("set DIFFSIL_ASSETS")).join("CesiumMan.glb");
    let s = skinned(load_gltf(&path).unwrap());
    let clips = load_animations(&path).unwrap();
    assert_eq!(clips.len(), 1);
    let walk = &clips[0];
    println!(
        "CesiumMan: `{}`, {:.3} s, {} channels ({} of scale), {} other skipped",
        walk.name,
        walk.duration,
        walk.channels.len(),
        walk.channels.iter().filter(|c| c.property == Property::Scale).count(),
        walk.ignored_other_channels
    );
    assert!(walk.duration > 0.5 && !walk.channels.is_empty());
    // At every key time of every rotation channel, rest rotation · R(θ) is the key (up to sign).
    for channel in walk.channels.iter().filter(|c| c.property == Property::Rotation) {
        for (k, &t) in channel.times.iter().enumerate().step_by(5) {
            let pose = walk.sample(&s.skeleton, t).unwrap();
            let theta = pose.joint_rotations[channel.joint];
            let rest = s.skeleton.rest[channel.joint].rotation.normalize();
            let local = rest * Quat::from_scaled_axis(theta);
            let key = Quat::from_array(channel.values[k]).normalize();
            assert!(local.dot(key).abs() > 1.0 - 1e-5, "joint {} key {k}: {local} vs {key}", channel.joint);
        }
    }
    // A walk bends joints far from the rest pose, and skins to finite vertices.
    let frames = walk.sample_frames(&s.skeleton, 12).unwrap();
    let largest = frames.iter().flat_map(|p| p.joint_rotations.iter().map(|r| r.length())).fold(0.0, f32::max);
    println!("CesiumMan: largest joint rotation over 12 frames {:.1}°", largest.to_degrees());
    assert!(largest > 0.5);
    for pose in &frames {
        assert!(s.skin(pose).unwrap().iter().all(|v| v.is_finite()));
    }
    // The walk keys every joint's scale too, at 1 up to rounding (1 ± 1.3e-6 in the file).
    assert!(walk.has_scales());
    let off = frames.iter().flat_map(|p| p.joint_scales.iter()).map(|s| (*s - Vec3::ONE).abs().max_element());
    assert!(off.fold(0.0, f32::max) < 1e-5);
}
