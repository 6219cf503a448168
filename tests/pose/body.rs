//! The built-in MakeHuman body (`diffsil::pose::makehuman_body`): what it holds, and shaped,
//! posed skinning of it.

use diffsil::pose::makehuman_body;
use diffsil::pose::skin::Pose;
use diffsil::Vec3;

#[test]
fn makehuman_body_loads_with_skeleton_and_shape_space() {
    let body = makehuman_body().unwrap();
    assert_eq!((body.vertex_count(), body.mesh.triangles().len()), (7000, 13996));
    assert!(body.mesh.topology().is_closed());
    assert_eq!((body.joint_count(), body.shape_count()), (31, 10));
    assert_eq!(body.skeleton.names[0], "Hips");
    assert_eq!(body.skeleton.nodes.len(), 31);
    assert_eq!(body.morphs.names[9], "leg_length");
    let offsets = body.morphs.joint_offsets.as_ref().expect("joint offsets");
    // Rest pose: 1.659 m tall, soles on the ground.
    let rest = Pose::rest(31);
    let v = body.skin(&rest).unwrap();
    let (lo, hi) = v.iter().fold((f32::MAX, f32::MIN), |(lo, hi), p| (lo.min(p.y), hi.max(p.y)));
    assert!(lo.abs() < 0.01 && (hi - lo - 1.659).abs() < 0.01, "{lo} .. {hi}");
    // A shape moves the joints by their offsets: the head joint with `height`.
    let head = body.skeleton.names.iter().position(|n| n == "Head").unwrap();
    let mut betas = vec![0.0; 10];
    betas[5] = 0.2;
    let plain = body.joint_transforms(&rest).unwrap()[head].w_axis.truncate();
    let shaped = body.joint_transforms_shaped(&rest, &betas).unwrap()[head].w_axis.truncate();
    assert!((shaped - plain).abs_diff_eq(0.2 * offsets[5][head], 1e-5) && shaped.y - plain.y > 0.05);
    // Posed and shaped: finite, and the shaped head vertices rise with the head joint.
    let mut pose = rest.clone();
    pose.joint_rotations[body.skeleton.names.iter().position(|n| n == "LeftArm").unwrap()] = Vec3::new(0.0, 0.0, 0.8);
    let posed = body.skin_shaped(&pose, &betas).unwrap();
    assert!(posed.iter().all(|p| p.is_finite()));
    let top = posed.iter().map(|p| p.y).fold(f32::MIN, f32::max);
    assert!(top - hi > 0.05, "height {hi} → {top}");
}
