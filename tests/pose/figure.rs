//! The built-in figure: skeleton, surface, weights, and how it deforms.

use std::collections::HashMap;
use std::sync::OnceLock;

use diffsil::pose::figure::{builtin_figure, joint_kinds, limb_joints, random_pose_limits, JointKind, JOINT_NAMES};
use diffsil::pose::skin::{Pose, SkinnedMesh};
use diffsil::{Camera, RenderSettings, Renderer, Vec3};
use glam::{Mat4, Quat};

fn figure() -> &'static SkinnedMesh {
    static FIGURE: OnceLock<SkinnedMesh> = OnceLock::new();
    FIGURE.get_or_init(builtin_figure)
}

fn joint(name: &str) -> usize {
    figure().skeleton.names.iter().position(|n| n == name).unwrap_or_else(|| panic!("no joint {name}"))
}

/// Rest world transform of every joint.
fn rest_world(fig: &SkinnedMesh) -> Vec<Mat4> {
    posed_world(fig, &vec![Vec3::ZERO; fig.skeleton.parents.len()])
}

/// World transforms with axis–angle offsets inserted after each joint's rest rotation.
fn posed_world(fig: &SkinnedMesh, offsets: &[Vec3]) -> Vec<Mat4> {
    let s = &fig.skeleton;
    let mut world: Vec<Mat4> = Vec::with_capacity(s.parents.len());
    for (j, (r, theta)) in s.rest.iter().zip(offsets).enumerate() {
        let offset = if *theta == Vec3::ZERO {
            Quat::IDENTITY
        } else {
            Quat::from_axis_angle(theta.normalize(), theta.length())
        };
        let local = Mat4::from_scale_rotation_translation(r.scale, r.rotation * offset, r.translation);
        world.push(match s.parents[j] {
            Some(p) => world[p] * local,
            None => s.root_parent[j] * local,
        });
    }
    world
}

/// Linear blend skinning written out here, independently of `diffsil::pose::skin`.
fn lbs(fig: &SkinnedMesh, offsets: &[Vec3]) -> Vec<Vec3> {
    let skinning: Vec<Mat4> =
        posed_world(fig, offsets).iter().zip(&fig.skeleton.inverse_bind).map(|(g, ibm)| *g * *ibm).collect();
    fig.mesh
        .positions()
        .iter()
        .zip(fig.joints.iter().zip(&fig.weights))
        .map(|(&v, (j, w))| (0..4).map(|k| skinning[j[k] as usize].transform_point3(v) * w[k]).sum())
        .collect()
}

#[test]
fn skeleton_is_smpl_like() {
    let s = &figure().skeleton;
    let n = s.parents.len();
    assert!(n >= 16);
    assert_eq!(n, JOINT_NAMES.len());
    assert_eq!((s.names.len(), s.rest.len(), s.inverse_bind.len(), s.root_parent.len()), (n, n, n, n));
    assert_eq!(s.parents[0], None);
    assert_eq!(s.names[0], "pelvis");
    for (j, p) in s.parents.iter().enumerate().skip(1) {
        assert!(matches!(p, Some(p) if *p < j), "joint {j} has parent {p:?}");
    }
    for name in [
        "left_hip",
        "right_hip",
        "spine1",
        "spine2",
        "spine3",
        "left_knee",
        "right_knee",
        "left_ankle",
        "right_ankle",
        "neck",
        "head",
        "left_collar",
        "right_collar",
        "left_shoulder",
        "right_shoulder",
        "left_elbow",
        "right_elbow",
        "left_wrist",
        "right_wrist",
    ] {
        joint(name);
    }
    let parent = |c: &str| s.parents[joint(c)].map(|p| s.names[p].as_str());
    assert_eq!(parent("left_elbow"), Some("left_shoulder"));
    assert_eq!(parent("left_wrist"), Some("left_elbow"));
    assert_eq!(parent("right_knee"), Some("right_hip"));
    assert_eq!(parent("head"), Some("neck"));
    for r in &s.rest {
        assert_eq!(r.rotation, Quat::IDENTITY);
        assert_eq!(r.scale, Vec3::ONE);
    }
    // Left is +x (the figure faces +z), the head is above the pelvis above the knees.
    let world = rest_world(figure());
    let at = |name: &str| world[joint(name)].w_axis.truncate();
    assert!(at("left_shoulder").x > 0.1 && at("right_shoulder").x < -0.1);
    assert!(at("head").y > at("neck").y && at("neck").y > at("pelvis").y && at("pelvis").y > at("left_knee").y);
    // A-pose: the forearm points down and out at roughly 45°.
    let forearm = (at("left_wrist") - at("left_elbow")).normalize();
    assert!(forearm.x > 0.5 && forearm.y < -0.5, "{forearm}");
}

#[test]
fn joint_kinds_drive_random_pose_limits() {
    let kinds = joint_kinds(&figure().skeleton);
    assert_eq!(kinds[joint("pelvis")], JointKind::Root);
    for name in ["spine1", "spine2", "spine3"] {
        assert_eq!(kinds[joint(name)], JointKind::Spine);
    }
    assert_eq!(kinds[joint("neck")], JointKind::Neck);
    assert_eq!(kinds[joint("head")], JointKind::Head);
    assert_eq!(kinds[joint("left_collar")], JointKind::Collar);
    let limbs = limb_joints(figure());
    for name in ["left_hip", "right_knee", "left_ankle", "right_shoulder", "left_elbow", "right_wrist"] {
        assert!(limbs.contains(&joint(name)), "{name}");
    }
    assert!(!limbs.contains(&joint("spine2")) && !limbs.contains(&joint("head")));
    assert_eq!(JointKind::Limb.random_pose_limit(), 0.5);
    assert_eq!(JointKind::Spine.random_pose_limit(), 0.25);
    assert_eq!(JointKind::Neck.random_pose_limit(), 0.25);
    assert_eq!(JointKind::Head.random_pose_limit(), 0.25);
    let limits = random_pose_limits(&figure().skeleton);
    assert_eq!(limits.len(), figure().joint_count());
    assert_eq!(limits[joint("left_knee")], 0.5);
    assert_eq!(limits[joint("spine2")], 0.25);
    assert_eq!(limits[figure().skeleton.parents.iter().position(Option::is_none).unwrap()], 0.0);
}

#[test]
fn size_and_placement() {
    let p = figure().mesh.positions();
    let (lo, hi) = p.iter().fold((p[0], p[0]), |(lo, hi), q| (lo.min(*q), hi.max(*q)));
    let height = hi.y - lo.y;
    assert!((1.6..=1.8).contains(&height), "height {height}");
    assert!(lo.y.abs() < 1e-4, "feet at y = {}", lo.y);
    assert!(hi.x + lo.x < 0.01 && hi.x > 0.5, "x extent {lo} {hi}");
    assert!(hi.z - lo.z < 0.45, "depth {}", hi.z - lo.z);
    let n = p.len();
    assert!((2000..=6000).contains(&n), "{n} vertices");
}

#[test]
fn surface_is_closed_welded_and_outward() {
    let mesh = &figure().mesh;
    let topo = mesh.topology();
    for e in 0..topo.edges().len() {
        assert_eq!(topo.edge_faces(e).len(), 2, "edge {:?}", topo.edges()[e]);
    }
    // Every directed edge once: the orientation is consistent.
    let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
    for t in mesh.triangles() {
        assert!(t[0] != t[1] && t[1] != t[2] && t[2] != t[0], "degenerate {t:?}");
        for k in 0..3 {
            *directed.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
        }
    }
    for (&(a, b), &count) in &directed {
        assert_eq!(count, 1, "edge {a}->{b}");
        assert_eq!(directed.get(&(b, a)), Some(&1), "edge {a}->{b} has no twin");
    }
    // Outward: positive volume, about that of a 70 kg body (65–80 litres give or take).
    let p = mesh.positions();
    let volume: f32 =
        mesh.triangles().iter().map(|&[a, b, c]| p[a as usize].dot(p[b as usize].cross(p[c as usize])) / 6.0).sum();
    assert!((0.04..0.1).contains(&volume), "volume {volume} m³");
    // Welded: no two vertices at the same place, every vertex used, one connected piece
    // (Euler characteristic 2: a sphere).
    let mut keys: Vec<[u32; 3]> = p.iter().map(|v| v.to_array().map(f32::to_bits)).collect();
    keys.sort_unstable();
    keys.dedup();
    assert_eq!(keys.len(), p.len());
    let mut used = vec![false; p.len()];
    mesh.triangles().iter().flatten().for_each(|&v| used[v as usize] = true);
    assert!(used.iter().all(|&u| u));
    let euler = p.len() as i64 - topo.edges().len() as i64 + mesh.triangles().len() as i64;
    assert_eq!(euler, 2);
    // No degenerate slivers.
    let worst = mesh
        .triangles()
        .iter()
        .map(|&[a, b, c]| {
            let (a, b, c) = (p[a as usize], p[b as usize], p[c as usize]);
            let sum = (b - a).length_squared() + (c - b).length_squared() + (a - c).length_squared();
            2.0 * 3f32.sqrt() * (b - a).cross(c - a).length() / sum
        })
        .fold(f32::INFINITY, f32::min);
    assert!(worst > 0.1, "worst triangle quality {worst}");
}

#[test]
fn weights_are_valid() {
    let fig = figure();
    let n = fig.mesh.positions().len();
    assert_eq!((fig.joints.len(), fig.weights.len()), (n, n));
    let joints = fig.skeleton.parents.len();
    for (j, w) in fig.joints.iter().zip(&fig.weights) {
        assert!(w.iter().all(|x| x.is_finite() && *x >= 0.0), "{w:?}");
        let sum: f32 = w.iter().sum();
        assert!((sum - 1.0).abs() < 1e-5, "sum {sum}");
        assert!(j.iter().all(|&k| (k as usize) < joints), "{j:?}");
    }
    // Blending really happens (knees and elbows), but not everywhere.
    let blended = fig.weights.iter().filter(|w| w[0] < 0.9).count();
    assert!(blended > n / 10 && blended < n * 9 / 10, "{blended} of {n} vertices blended");
}

#[test]
fn inverse_bind_matrices_invert_the_rest_pose() {
    let fig = figure();
    for (j, (g, ibm)) in rest_world(fig).iter().zip(&fig.skeleton.inverse_bind).enumerate() {
        let product = *g * *ibm;
        assert!(product.abs_diff_eq(Mat4::IDENTITY, 1e-5), "joint {j}: {product}");
    }
}

#[test]
fn generation_is_deterministic() {
    let a = builtin_figure();
    let b = figure();
    assert_eq!(a.mesh.positions(), b.mesh.positions());
    assert_eq!(a.mesh.triangles(), b.mesh.triangles());
    assert_eq!(a.joints, b.joints);
    assert_eq!(a.weights, b.weights);
    assert_eq!(a.skeleton, b.skeleton);
}

/// Joint names a weight points at, with the total weight per joint name over `vertices`.
fn influence(vertices: &[usize]) -> HashMap<&'static str, f32> {
    let fig = figure();
    let mut out = HashMap::new();
    for &v in vertices {
        for k in 0..4 {
            if fig.weights[v][k] > 0.0 {
                *out.entry(JOINT_NAMES[fig.joints[v][k] as usize]).or_insert(0.0) += fig.weights[v][k];
            }
        }
    }
    out
}

#[test]
fn limbs_are_weighted_to_their_own_bones() {
    let fig = figure();
    let p = fig.mesh.positions();
    let world = rest_world(fig);
    let at = |name: &str| world[joint(name)].w_axis.truncate();
    let shoulder_x = at("left_shoulder").x;
    let arm: Vec<usize> = (0..p.len()).filter(|&v| p[v].x > shoulder_x + 0.06).collect();
    assert!(arm.len() > 200);
    let arm_chain = ["left_shoulder", "left_elbow", "left_wrist", "left_hand"];
    let dominant_on_arm =
        arm.iter().filter(|&&v| arm_chain.contains(&JOINT_NAMES[fig.joints[v][0] as usize])).count() as f32;
    assert!(dominant_on_arm / arm.len() as f32 > 0.95, "{dominant_on_arm} of {}", arm.len());
    let total = influence(&arm);
    for (name, w) in &total {
        assert!(arm_chain.contains(name) || *name == "left_collar" || *name == "spine3", "{name}: {w}");
    }
    // The hand region never listens to the spine or the other side.
    let hand: Vec<usize> = (0..p.len()).filter(|&v| p[v].x > at("left_wrist").x - 0.02).collect();
    assert!(hand.len() > 50);
    for name in influence(&hand).keys() {
        assert!(["left_elbow", "left_wrist", "left_hand"].contains(name), "hand weighted to {name}");
    }
    // Both thighs: vertices near the left knee are on the left leg only.
    let knee = at("left_knee");
    let around_knee: Vec<usize> = (0..p.len()).filter(|&v| p[v].distance(knee) < 0.09).collect();
    assert!(around_knee.len() > 30);
    let total = influence(&around_knee);
    for name in total.keys() {
        assert!(["left_hip", "left_knee", "left_ankle"].contains(name), "knee weighted to {name}");
    }
    // The knee region blends thigh and shin.
    assert!(total.get("left_hip").copied().unwrap_or(0.0) > 0.2 * around_knee.len() as f32, "{total:?}");
    assert!(total.get("left_knee").copied().unwrap_or(0.0) > 0.2 * around_knee.len() as f32, "{total:?}");
    // Elbow likewise.
    let elbow = at("left_elbow");
    let around_elbow: Vec<usize> = (0..p.len()).filter(|&v| p[v].distance(elbow) < 0.06).collect();
    let total = influence(&around_elbow);
    assert!(total.get("left_shoulder").copied().unwrap_or(0.0) > 0.2 * around_elbow.len() as f32, "{total:?}");
    assert!(total.get("left_elbow").copied().unwrap_or(0.0) > 0.2 * around_elbow.len() as f32, "{total:?}");
    // Legs never listen to the other leg, even where the thighs nearly touch.
    for (side, other, sign) in [("left_", "right_", 1.0), ("right_", "left_", -1.0)] {
        let leg: Vec<usize> = (0..p.len()).filter(|&v| p[v].y < 0.75 && sign * p[v].x > 0.0).collect();
        assert!(leg.len() > 300);
        for name in influence(&leg).keys() {
            assert!(name.starts_with(side) || *name == "pelvis", "{side}leg weighted to {name}");
            assert!(!name.starts_with(other));
        }
    }
    // Feet belong to the ankles and feet.
    let feet: Vec<usize> = (0..p.len()).filter(|&v| p[v].y < 0.05).collect();
    for name in influence(&feet).keys() {
        assert!(
            ["left_ankle", "left_foot", "right_ankle", "right_foot", "left_knee", "right_knee"].contains(name),
            "{name}"
        );
    }
}

#[test]
fn binds_as_a_valid_skinned_mesh() {
    let fig = figure().clone();
    fig.skeleton.validate().unwrap();
    let rebound = SkinnedMesh::new(fig.mesh.clone(), fig.skeleton.clone(), fig.joints.clone(), fig.weights.clone())
        .expect("SkinnedMesh::new accepts the figure");
    assert_eq!(rebound.joints, fig.joints);
}

#[test]
fn rest_pose_reproduces_the_bind_vertices() {
    let fig = figure();
    let n = fig.skeleton.parents.len();
    let by_library = fig.skin(&Pose::rest(n)).unwrap();
    let by_hand = lbs(fig, &vec![Vec3::ZERO; n]);
    for ((a, b), c) in by_library.iter().zip(&by_hand).zip(fig.mesh.positions()) {
        assert!(a.distance(*c) < 1e-5, "{a} vs {c}");
        assert!(b.distance(*c) < 1e-5, "{b} vs {c}");
    }
}

#[test]
fn bending_an_elbow_moves_the_hand_only() {
    let fig = figure();
    let p = fig.mesh.positions();
    let mut pose = Pose::rest(fig.skeleton.parents.len());
    pose.joint_rotations[joint("left_elbow")] = Vec3::new(0.0, 0.0, 0.5);
    let bent = fig.skin(&pose).unwrap();
    let by_hand = lbs(fig, &pose.joint_rotations);
    let elbow = rest_world(fig)[joint("left_elbow")].w_axis.truncate();
    // Rest rotations are the identity, so the offset turns the forearm about the world z axis.
    let turn = |x: Vec3| elbow + Quat::from_rotation_z(0.5) * (x - elbow);
    let forearm_and_hand: Vec<u16> =
        ["left_elbow", "left_wrist", "left_hand"].iter().map(|n| joint(n) as u16).collect();
    let mut rigid = 0;
    for v in 0..p.len() {
        assert!(bent[v].distance(by_hand[v]) < 1e-5);
        let moved = bent[v].distance(p[v]);
        // Feet, legs, the right side, the head: still.
        if p[v].y < 0.8 || p[v].x < 0.0 || p[v].y > 1.5 {
            assert!(moved < 1e-6, "vertex {v} at {} moved {moved}", p[v]);
        }
        // Vertices bound to the forearm and hand only turn rigidly with it.
        let w = &fig.weights[v];
        let on_forearm: f32 = (0..4).filter(|&k| forearm_and_hand.contains(&fig.joints[v][k])).map(|k| w[k]).sum();
        if on_forearm > 1.0 - 1e-6 {
            rigid += 1;
            assert!(bent[v].distance(turn(p[v])) < 1e-4, "vertex {v}: {} vs {}", bent[v], turn(p[v]));
            assert!(moved > 0.01, "vertex {v} moved only {moved}");
        }
    }
    assert!(rigid > 100, "{rigid} vertices on the forearm and hand");
}

/// Whether segment `[p, q]` crosses triangle `t` (Möller–Trumbore; coplanar contact is ignored).
fn segment_hits_triangle(p: Vec3, q: Vec3, t: [Vec3; 3]) -> bool {
    let (e1, e2, d) = (t[1] - t[0], t[2] - t[0], q - p);
    let h = d.cross(e2);
    let det = e1.dot(h);
    if det.abs() < 1e-12 {
        return false;
    }
    let s = p - t[0];
    let u = s.dot(h) / det;
    let qv = s.cross(e1);
    let v = d.dot(qv) / det;
    let t = e2.dot(qv) / det;
    u >= 0.0 && v >= 0.0 && u + v <= 1.0 && (0.0..=1.0).contains(&t)
}

#[test]
fn surface_does_not_intersect_itself_at_rest() {
    let mesh = &figure().mesh;
    let (p, tris) = (mesh.positions(), mesh.triangles());
    let corners = |t: usize| tris[t].map(|v| p[v as usize]);
    // Bin triangles by the grid cells their bounding boxes overlap; test pairs sharing a cell.
    let cell = 0.04;
    let key = |x: Vec3| (x / cell).floor().as_ivec3();
    let mut grid: HashMap<glam::IVec3, Vec<usize>> = HashMap::new();
    for t in 0..tris.len() {
        let c = corners(t);
        let (lo, hi) = (key(c[0].min(c[1]).min(c[2])), key(c[0].max(c[1]).max(c[2])));
        for x in lo.x..=hi.x {
            for y in lo.y..=hi.y {
                for z in lo.z..=hi.z {
                    grid.entry(glam::IVec3::new(x, y, z)).or_default().push(t);
                }
            }
        }
    }
    let mut hits = Vec::new();
    let mut tested = std::collections::HashSet::new();
    for list in grid.values() {
        for (i, &a) in list.iter().enumerate() {
            for &b in &list[i + 1..] {
                if tris[a].iter().any(|v| tris[b].contains(v)) || !tested.insert((a.min(b), a.max(b))) {
                    continue;
                }
                let (ta, tb) = (corners(a), corners(b));
                let crosses = (0..3).any(|k| segment_hits_triangle(ta[k], ta[(k + 1) % 3], tb))
                    || (0..3).any(|k| segment_hits_triangle(tb[k], tb[(k + 1) % 3], ta));
                if crosses {
                    hits.push((a, b));
                }
            }
        }
    }
    assert!(tested.len() > 10_000);
    assert!(hits.is_empty(), "{} intersecting triangle pairs, e.g. {:?}", hits.len(), &hits[..hits.len().min(5)]);
}

#[test]
fn surface_has_no_folds() {
    // Neighbouring triangles never turn back on each other (no creases sharper than 120°).
    let mesh = &figure().mesh;
    let p = mesh.positions();
    let normal = |t: u32| {
        let [a, b, c] = mesh.triangles()[t as usize].map(|v| p[v as usize]);
        (b - a).cross(c - a).normalize()
    };
    let topo = mesh.topology();
    let worst = (0..topo.edges().len())
        .map(|e| normal(topo.edge_faces(e)[0]).dot(normal(topo.edge_faces(e)[1])))
        .fold(1.0, f32::min);
    assert!(worst > -0.5, "adjacent triangle normals at cos {worst}");
}

/// Renders the figure from the front and the side and checks the silhouettes look like a person
/// standing in an A-pose. Set `DIFFSIL_FIGURE_PNG=<dir>` to also save the pictures.
#[test]
fn silhouettes_look_like_a_person() {
    let fig = figure();
    let (w, h) = (96u32, 128u32);
    let target = Vec3::new(0.0, 0.87, 0.0);
    let front = Camera::orthographic(target + Vec3::Z * 5.0, target, 1.9, w, h);
    let side = Camera::orthographic(target + Vec3::X * 5.0, target, 1.9, w, h);
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let frame = renderer.render(&fig.mesh, &[front, side]).unwrap();
    let [front, side] = [&frame.images()[0], &frame.images()[1]];
    if let Ok(dir) = std::env::var("DIFFSIL_FIGURE_PNG") {
        // Bigger pictures to look at, including a three-quarter view and a posed figure.
        let (bw, bh) = (384, 512);
        let eye = |dir: Vec3| Camera::perspective(target + dir * 4.0, target, 0.5, bw, bh);
        let views = [eye(Vec3::Z), eye(Vec3::X), eye(Vec3::new(0.7, 0.2, 0.7).normalize())];
        let frame = renderer.render(&fig.mesh, &views).unwrap();
        for (name, img) in ["front", "side", "three_quarter"].iter().zip(frame.images()) {
            diffsil::io::save_png(img, format!("{dir}/figure_{name}.png")).unwrap();
        }
        let mut offsets = vec![Vec3::ZERO; fig.skeleton.parents.len()];
        offsets[joint("left_shoulder")] = Vec3::new(0.0, 0.0, 0.6);
        offsets[joint("left_elbow")] = Vec3::new(0.0, 1.2, 0.0);
        offsets[joint("right_hip")] = Vec3::new(-0.8, 0.0, 0.0);
        offsets[joint("right_knee")] = Vec3::new(1.2, 0.0, 0.0);
        offsets[joint("spine2")] = Vec3::new(0.0, 0.3, 0.0);
        offsets[joint("neck")] = Vec3::new(0.3, 0.0, 0.0);
        let mut posed = fig.mesh.clone();
        posed.set_positions(&lbs(fig, &offsets)).unwrap();
        let frame = renderer.render(&posed, &views).unwrap();
        for (name, img) in ["front", "side", "three_quarter"].iter().zip(frame.images()) {
            diffsil::io::save_png(img, format!("{dir}/figure_posed_{name}.png")).unwrap();
        }
    }
    let row_width = |img: &diffsil::Image, frac: f32| -> f32 {
        let r = ((1.0 - frac) * h as f32) as u32; // frac of the height from the bottom of the view
        (0..w).map(|c| img.get(r, c)).sum()
    };
    // Pixel size 1.9 m / 128 ≈ 1.5 cm; the view's bottom row is at y = 0.87 − 0.95 = −0.08 m.
    let y_to_frac = |y: f32| (y + 0.08) / 1.9;
    let runs = |img: &diffsil::Image, y: f32| {
        let r = ((1.0 - y_to_frac(y)) * h as f32) as u32;
        (1..w).filter(|&c| (img.get(r, c) > 0.5) != (img.get(r, c - 1) > 0.5)).count() / 2
    };
    // Front: one head narrower than the chest; at chest and hand height the arms stand apart
    // from the torso (A-pose); two separate legs.
    let (head, chest, hands, shins) = (1.64, 1.3, 1.05, 0.3);
    assert_eq!(runs(front, head), 1);
    assert!(row_width(front, y_to_frac(chest)) > 1.5 * row_width(front, y_to_frac(head)));
    assert_eq!(runs(front, chest), 3, "arm, torso, arm");
    assert_eq!(runs(front, hands), 3, "hand, hips, hand");
    assert_eq!(runs(front, shins), 2, "two shins");
    assert_eq!(runs(side, chest), 1);
    // Side: much thinner than the front.
    let area = |img: &diffsil::Image| img.data().iter().sum::<f32>();
    assert!(area(side) < 0.6 * area(front), "side {} front {}", area(side), area(front));
    // Left-right symmetry of the front view.
    let mut asym = 0.0;
    for r in 0..h {
        for c in 0..w / 2 {
            asym += (front.get(r, c) - front.get(r, w - 1 - c)).abs();
        }
    }
    assert!(asym < 0.05 * area(front), "asymmetry {asym}");
}

/// Edge lengths and triangle quality stay in a usable range (printed for the record).
#[test]
fn mesh_statistics() {
    let fig = builtin_figure();
    println!(
        "built-in figure: {} vertices, {} triangles, {} joints",
        fig.mesh.positions().len(),
        fig.mesh.triangles().len(),
        fig.skeleton.parents.len()
    );
    let p = fig.mesh.positions();
    let (mut shortest, mut longest, mut worst, mut poor) = (f32::INFINITY, 0.0f32, f32::INFINITY, 0);
    for &[a, b, c] in fig.mesh.triangles() {
        let (a, b, c) = (p[a as usize], p[b as usize], p[c as usize]);
        for l in [a.distance(b), b.distance(c), c.distance(a)] {
            shortest = shortest.min(l);
            longest = longest.max(l);
        }
        let sum = (b - a).length_squared() + (c - b).length_squared() + (a - c).length_squared();
        let q = 2.0 * 3f32.sqrt() * (b - a).cross(c - a).length() / sum;
        worst = worst.min(q);
        poor += (q < 0.3) as usize;
    }
    let (lo, hi) = p.iter().fold((p[0], p[0]), |(lo, hi), q| (lo.min(*q), hi.max(*q)));
    println!("bounds {lo} .. {hi}");
    println!("edges {shortest:.4}..{longest:.4} m, worst triangle quality {worst:.3}, {poor} below 0.3");
    assert!(shortest > 1e-4 && longest < 0.1, "edges {shortest}..{longest} m");
    assert!(worst > 0.1, "worst triangle quality {worst}");
}
