//! glTF animations: a tiny hand-written clip per interpolation mode, sampled between keys against
//! hand-computed values, and CesiumMan's walk (ignored asset test).

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
/// cubic splines over [0, 2] s), and `ignored` (a scale channel and a channel on the mesh node).
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
fn clips_load_with_names_modes_and_ignored_channels() {
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
    assert_eq!((clips[3].ignored_scale_channels, clips[3].ignored_other_channels), (1, 1));
    assert!(clips[3].channels.is_empty());
    assert!(!clips[0].has_translations() && clips[1].has_translations());
    // A clip with no channels samples to the rest pose.
    assert_eq!(clips[3].sample(&s.skeleton, 1.0).unwrap(), Pose::rest(2));
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
        "CesiumMan: `{}`, {:.3} s, {} channels, {} scale channels ignored, {} other ignored",
        walk.name,
        walk.duration,
        walk.channels.len(),
        walk.ignored_scale_channels,
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
}
