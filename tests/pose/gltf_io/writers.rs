//! The posed-mesh writers (`io::save_obj`, `io::gltf::save_mesh_glb`) and pose / shape JSON.

use diffsil::io::gltf::save_mesh_glb;
use diffsil::io::{load_obj, save_obj};
use diffsil::pose::makehuman_body;
use diffsil::pose::skin::Pose;

use super::*;

/// A posed, closed mesh with coordinates that do not print short (so round-off would show).
fn posed_box() -> Mesh {
    let s = two_joint_box();
    let mut pose = Pose::rest(2);
    pose.joint_rotations[1] = Vec3::new(0.3, -0.1, 0.7);
    pose.translation = Vec3::new(0.1, 1.0 / 3.0, -2.0);
    s.posed_mesh(&pose).unwrap()
}

#[test]
fn save_obj_round_trips_positions_and_triangles_exactly() {
    let mesh = posed_box();
    let path = temp_dir().join("posed_box.obj");
    save_obj(&path, &mesh).unwrap();
    let back = load_obj(&path).unwrap();
    // load_obj renumbers vertices in order of first use: compare the triangles' corner positions
    // (bit for bit, winding kept).
    let corners = |m: &Mesh| {
        let mut t: Vec<[[u32; 3]; 3]> =
            m.triangles().iter().map(|t| t.map(|i| m.positions()[i as usize].to_array().map(f32::to_bits))).collect();
        t.sort();
        t
    };
    assert_eq!(back.positions().len(), mesh.positions().len());
    assert_eq!(corners(&back), corners(&mesh));
    let text = std::fs::read_to_string(&path).unwrap();
    assert_eq!(text.lines().filter(|l| l.starts_with("f ")).count(), 12);
    // A non-finite vertex is refused, naming it.
    let mut bad = mesh.positions().to_vec();
    bad[5].y = f32::NAN;
    let bad = Mesh::new(bad, mesh.triangles().to_vec());
    if let Ok(bad) = bad {
        let err = save_obj(temp_dir().join("bad.obj"), &bad).unwrap_err();
        assert!(err.to_string().contains("vertex 5"), "{err}");
    }
}

#[test]
fn save_mesh_glb_round_trips_as_a_static_mesh() {
    let mesh = posed_box();
    let path = temp_dir().join("posed_box.glb");
    save_mesh_glb(&mesh, &path).unwrap();
    let back = static_mesh(load_gltf(&path).unwrap());
    assert_eq!(back.positions(), mesh.positions());
    assert_eq!(back.triangles(), mesh.triangles());
    // What a viewer sees is what the skinned mesh gives at that pose.
    assert_eq!(load_mesh(&path).unwrap().positions(), mesh.positions());
}

#[test]
fn pose_and_shape_round_trip_through_json() {
    let mut pose = Pose::rest(3).with_joint_translations();
    pose.joint_rotations[1] = Vec3::new(0.1, -1.0 / 3.0, 2.5e-8);
    pose.joint_translations[2] = Vec3::new(-0.7, 1e-3, 0.0);
    pose.orientation = Vec3::new(0.0, 3.0, 0.0);
    pose.translation = Vec3::new(1.0, 2.0, 1.0 / 7.0);
    let betas = [0.25f32, -1.0 / 3.0];
    let text = pose.to_json(&betas);
    assert_eq!(Pose::from_json(&text).unwrap(), (pose.clone(), betas.to_vec()));
    // Without joint translations or shape.
    let plain = Pose::rest(2);
    assert_eq!(Pose::from_json(&plain.to_json(&[])).unwrap(), (plain, Vec::new()));
    // Errors name the field.
    for (broken, field) in [
        (text.replace("\"orientation\"", "\"orient\""), "orientation"),
        (text.replace("diffsil-pose-1", "other"), "format"),
        ("[1, 2]".to_string(), "format"),
        ("{".to_string(), "not JSON"),
    ] {
        let err = Pose::from_json(&broken).unwrap_err();
        assert!(err.to_string().contains(field), "{err}");
    }
    let head = r#"{"format":"diffsil-pose-1","orientation":[0,0,0],"translation":[0,0,0],"#;
    let err = Pose::from_json(&format!(r#"{head}"joint_rotations":[[1,2]]}}"#)).unwrap_err();
    assert!(err.to_string().contains("joint_rotations"), "{err}");
    let err = Pose::from_json(&format!(r#"{head}"joint_rotations":[[1,2,3]],"joint_translations":[]}}"#));
    assert!(err.is_ok(), "an empty translation list means none");
    let two = format!(r#"{head}"joint_rotations":[[1,2,3]],"joint_translations":[[0,0,0],[0,0,0]]}}"#);
    assert!(matches!(Pose::from_json(&two), Err(Error::LengthMismatch { .. })));
}

#[test]
fn save_glb_keeps_morph_targets_names_and_joint_offsets() {
    let body = makehuman_body().unwrap();
    let path = temp_dir().join("makehuman_round_trip.glb");
    save_glb(&body, &path).unwrap();
    let back = skinned(load_gltf(&path).unwrap());
    assert_same_skinned(&body, &back);
    // Deltas are binary (exact); joint offsets go through JSON text and read back to the same f32.
    assert_eq!(back.morphs, body.morphs);
    let mut betas = vec![0.0; 10];
    betas[9] = 0.5;
    let pose = Pose::rest(31);
    let (a, b) = (back.skin_shaped(&pose, &betas).unwrap(), body.skin_shaped(&pose, &betas).unwrap());
    assert!(a.iter().zip(&b).all(|(x, y)| x.abs_diff_eq(*y, 1e-6)));
    // Offsets are stored by name: duplicate names cannot be saved with them.
    let mut twice = body.clone();
    twice.morphs.names[1] = twice.morphs.names[0].clone();
    let err = save_glb(&twice, temp_dir().join("twice.glb")).unwrap_err();
    assert!(err.to_string().contains("used twice"), "{err}");
}
