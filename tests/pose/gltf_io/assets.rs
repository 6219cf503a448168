//! The Khronos sample models in `$DIFFSIL_ASSETS` (ignored by default).

use super::*;

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
