//! Golden hashes: the bits of images, gradients, losses and fitted poses on the test scenes,
//! recorded before the redesign (#10) and compared after it. Any change to the arithmetic of a
//! stage changes a hash. `DIFFSIL_GOLDEN_PRINT=1` prints the table instead of comparing.

mod common;

use common::scenes::{self, Scene3d};
use diffsil::pose::figure::{builtin_figure, random_pose_limits};
use diffsil::pose::fit::{framing_cameras, random_pose, FitSettings, PoseFit};
use diffsil::pose::skin::Pose;
use diffsil::{Image, Mesh, RenderSettings, Renderer, Targets, Vec2, Vec3};

/// FNV-1a over 32-bit words.
#[derive(Clone, Copy)]
struct Hash(u64);

impl Hash {
    fn new() -> Hash {
        Hash(0xcbf2_9ce4_8422_2325)
    }
    fn word(&mut self, w: u32) {
        for b in w.to_le_bytes() {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    fn floats(&mut self, xs: impl IntoIterator<Item = f32>) {
        for x in xs {
            self.word(x.to_bits());
        }
    }
    fn vec2s(&mut self, xs: &[Vec2]) {
        self.floats(xs.iter().flat_map(|v| v.to_array()));
    }
    fn vec3s(&mut self, xs: &[Vec3]) {
        self.floats(xs.iter().flat_map(|v| v.to_array()));
    }
    fn f64(&mut self, x: f64) {
        let bits = x.to_bits();
        self.word(bits as u32);
        self.word((bits >> 32) as u32);
    }
}

/// A deterministic `∂L/∂I` for an image of this size.
fn weights(width: u32, height: u32, seed: u32) -> Image {
    let data = (0..width * height)
        .map(|i| {
            let x = (i.wrapping_mul(2_654_435_761).wrapping_add(seed.wrapping_mul(40_503))) >> 8;
            (x % 2001) as f32 / 1000.0 - 1.0
        })
        .collect();
    Image::from_vec(width, height, data).unwrap()
}

fn scenes_3d() -> Vec<Scene3d> {
    let mut scenes = vec![
        scenes::icosphere_3d(),
        scenes::torus_fold_3d(),
        scenes::blob_3d(),
        scenes::two_spheres_3d(),
        scenes::open_patch_3d(),
        scenes::hemisphere_3d(),
    ];
    for s in &mut scenes {
        s.cameras.extend(scenes::orbit_cameras(2, 0.4, 36, 28));
        s.cameras.extend(scenes::orthographic_cameras(1, 1.1, 30, 30));
    }
    scenes
}

/// Every hash, by name, from `renderer` (CPU or GPU).
fn hashes(renderer: &mut Renderer) -> Vec<(String, u64)> {
    let mut out = Vec::new();
    for scene in scenes::all_2d() {
        let frame = renderer.render_screen(&scene.topology(), &[scene.view()]).unwrap();
        let mut h = Hash::new();
        h.floats(frame.images()[0].data().iter().copied());
        out.push((format!("2d/{}/image", scene.name), h.0));
        let d = weights(scene.width, scene.height, 1);
        let g = renderer.backward_screen(&frame, &[d]).unwrap();
        let mut h = Hash::new();
        h.vec2s(&g[0]);
        out.push((format!("2d/{}/grad", scene.name), h.0));
    }
    for scene in scenes_3d() {
        let frame = renderer.render(&scene.mesh, &scene.cameras).unwrap();
        let mut h = Hash::new();
        for image in frame.images() {
            h.floats(image.data().iter().copied());
        }
        out.push((format!("3d/{}/images", scene.name), h.0));
        let d: Vec<Image> =
            scene.cameras.iter().enumerate().map(|(k, c)| weights(c.width, c.height, k as u32)).collect();
        let g = renderer.backward(&frame, &d).unwrap();
        let mut h = Hash::new();
        h.vec3s(&g);
        out.push((format!("3d/{}/grad", scene.name), h.0));
        let moved = Mesh::with_topology(
            scene.mesh.positions().iter().map(|p| *p + Vec3::new(0.04, -0.03, 0.02)).collect(),
            scene.mesh.topology().clone(),
        )
        .unwrap();
        let targets = Targets::new(renderer.render(&moved, &scene.cameras).unwrap().images().to_vec()).unwrap();
        let step = renderer.squared_error_step(&scene.mesh, &scene.cameras, &targets).unwrap();
        let mut h = Hash::new();
        h.vec3s(&step.gradient);
        out.push((format!("3d/{}/step_grad", scene.name), h.0));
    }
    out
}

/// A few steps of the pose fit on the built-in figure at 32², CPU.
fn pose_fit_hash() -> u64 {
    let model = builtin_figure();
    let limits = random_pose_limits(&model.skeleton);
    let truth = random_pose(&limits, 30f32.to_radians(), 5);
    let cameras = framing_cameras(&model.mesh, 4, 32);
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let truth_mesh = Mesh::with_topology(model.skin(&truth).unwrap(), model.mesh.topology().clone()).unwrap();
    let targets = renderer.render(&truth_mesh, &cameras).unwrap().images().to_vec();
    let settings = FitSettings { initial: Some(Pose::rest(model.joint_count())), learning_rate: 0.02, lambda: 1e-7 };
    let mut fit = PoseFit::new(model, cameras, targets, renderer, settings).unwrap();
    let mut h = Hash::new();
    for _ in 0..5 {
        let report = fit.step().unwrap();
        h.f64(report.silhouette);
    }
    h.floats(fit.pose().to_params());
    h.0
}

/// Recorded on `3df6b1c` (before the redesign), CPU backend.
const CPU: &[(&str, u64)] = &[
    ("2d/triangle/image", 0x6d2a3cb0bec75e7c),
    ("2d/triangle/grad", 0x0113bd22c31721fb),
    ("2d/quad/image", 0x7aa6961ef6a1d2c5),
    ("2d/quad/grad", 0xe2349a7c8364cc0a),
    ("2d/icosphere/image", 0x970508d48e4e4355),
    ("2d/icosphere/grad", 0xe39cf0c737fe6c30),
    ("2d/torus_fold/image", 0xae134a9efd72140b),
    ("2d/torus_fold/grad", 0x9401c7c6569e4dd3),
    ("2d/blob/image", 0xbf0bff82a99058e2),
    ("2d/blob/grad", 0x546aecc33549a84c),
    ("2d/two_spheres/image", 0x1332a69c33e716e5),
    ("2d/two_spheres/grad", 0x316f791585d268cd),
    ("2d/open_patch/image", 0x6df6c16c89b8806c),
    ("2d/open_patch/grad", 0x49f8a5ed507aca86),
    ("2d/hemisphere/image", 0xd429bd884c0e5715),
    ("2d/hemisphere/grad", 0xf6d596f3b20425c8),
    ("2d/square_on_grid/image", 0xef49de3008475365),
    ("2d/square_on_grid/grad", 0xdfa98e04a9ba9f18),
    ("2d/diamond_on_grid/image", 0x0b8dd7afbd68d305),
    ("2d/diamond_on_grid/grad", 0xf218e521c5109a79),
    ("2d/flat_grid/image", 0x31114f4199676f7c),
    ("2d/flat_grid/grad", 0xf4239acfb708e1d2),
    ("3d/icosphere/images", 0x8f5beda9bbbeb8ef),
    ("3d/icosphere/grad", 0x5eaeacc5731a5af6),
    ("3d/icosphere/step_grad", 0x8c931c6cbab59ffd),
    ("3d/torus_fold/images", 0xb5a564e355d4d142),
    ("3d/torus_fold/grad", 0x0fbdc2c08a452f47),
    ("3d/torus_fold/step_grad", 0x2268587ca8318e2a),
    ("3d/blob/images", 0x1ab7601794ddab5f),
    ("3d/blob/grad", 0x0d6f367275982647),
    ("3d/blob/step_grad", 0xc8ad7ff933b2dbf5),
    ("3d/two_spheres/images", 0x3e0cf1f35626c6d2),
    ("3d/two_spheres/grad", 0x296f6e6c47f18389),
    ("3d/two_spheres/step_grad", 0x20c92caac05f1e5c),
    ("3d/open_patch/images", 0xbdfe5d6f63516c75),
    ("3d/open_patch/grad", 0x29b1822f04f5704b),
    ("3d/open_patch/step_grad", 0x8a13ddc49924714e),
    ("3d/hemisphere/images", 0x73ca929a39528781),
    ("3d/hemisphere/grad", 0x68146d52ced41ec0),
    ("3d/hemisphere/step_grad", 0x4dcad04941dd16fc),
];
/// Recorded on `3df6b1c` (before the redesign), lavapipe.
const GPU: &[(&str, u64)] = &[
    ("2d/triangle/image", 0x6d2a3cb0bec75e7c),
    ("2d/triangle/grad", 0xf585302090c7bef5),
    ("2d/quad/image", 0x7aa6961ef6a1d2c5),
    ("2d/quad/grad", 0xd0bf1a356ac01b04),
    ("2d/icosphere/image", 0x970508d48e4e4355),
    ("2d/icosphere/grad", 0x8451c8676f9dbc3c),
    ("2d/torus_fold/image", 0xae134a9efd72140b),
    ("2d/torus_fold/grad", 0x6d0cad1e11cb1b2c),
    ("2d/blob/image", 0xbf0bff82a99058e2),
    ("2d/blob/grad", 0x06eb1f0fcf0d1f88),
    ("2d/two_spheres/image", 0x1332a69c33e716e5),
    ("2d/two_spheres/grad", 0x265a29c9a7ef4065),
    ("2d/open_patch/image", 0x6df6c16c89b8806c),
    ("2d/open_patch/grad", 0x81d439f5c0a9648a),
    ("2d/hemisphere/image", 0xd429bd884c0e5715),
    ("2d/hemisphere/grad", 0x6adae721efd8371f),
    ("2d/square_on_grid/image", 0xef49de3008475365),
    ("2d/square_on_grid/grad", 0x4e6c9385bde1c9aa),
    ("2d/diamond_on_grid/image", 0x0b8dd7afbd68d305),
    ("2d/diamond_on_grid/grad", 0x01d7c2cd7564563d),
    ("2d/flat_grid/image", 0x31114f4199676f7c),
    ("2d/flat_grid/grad", 0x3fc8fa6ee381cf83),
    ("3d/icosphere/images", 0x8f5beda9bbbeb8ef),
    ("3d/icosphere/grad", 0x2672da79aed80cf5),
    ("3d/icosphere/step_grad", 0xda8b04564eff7d58),
    ("3d/torus_fold/images", 0xb5a564e355d4d142),
    ("3d/torus_fold/grad", 0xe41498eaa500083a),
    ("3d/torus_fold/step_grad", 0x5431a6887eaad63e),
    ("3d/blob/images", 0x1ab7601794ddab5f),
    ("3d/blob/grad", 0x2f4e25eeac311a35),
    ("3d/blob/step_grad", 0x4780c2e9ec15c50d),
    ("3d/two_spheres/images", 0x3e0cf1f35626c6d2),
    ("3d/two_spheres/grad", 0x40025225967a3374),
    ("3d/two_spheres/step_grad", 0x499d83c59c039e6f),
    ("3d/open_patch/images", 0xbdfe5d6f63516c75),
    ("3d/open_patch/grad", 0xdc7e28419dbc894c),
    ("3d/open_patch/step_grad", 0x6b4d66bcd00b96e4),
    ("3d/hemisphere/images", 0x73ca929a39528781),
    ("3d/hemisphere/grad", 0x4f9b482c159fa117),
    ("3d/hemisphere/step_grad", 0x21bcc24b20d3c0e8),
];
const POSE_FIT: u64 = 0x1bd6aa991883e377;

fn compare(backend: &str, got: &[(String, u64)], want: &[(&str, u64)]) {
    if std::env::var("DIFFSIL_GOLDEN_PRINT").is_ok() {
        println!("const {backend}: &[(&str, u64)] = &[");
        for (name, h) in got {
            println!("    (\"{name}\", 0x{h:016x}),");
        }
        println!("];");
        return;
    }
    assert_eq!(got.len(), want.len(), "{backend}: number of golden hashes");
    let wrong: Vec<&str> =
        got.iter().zip(want).filter(|((n, h), (wn, wh))| n != wn || h != wh).map(|((n, _), _)| n.as_str()).collect();
    assert!(wrong.is_empty(), "{backend}: outputs changed bits: {wrong:?}");
}

#[test]
fn cpu_outputs_match_the_golden_hashes() {
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    compare("CPU", &hashes(&mut renderer), CPU);
}

#[test]
fn gpu_outputs_match_the_golden_hashes() {
    let Some(ctx) = common::gpu::gpu_or_skip("gpu_outputs_match_the_golden_hashes") else { return };
    let mut renderer = Renderer::with_gpu_context(RenderSettings::default(), ctx).unwrap();
    compare("GPU", &hashes(&mut renderer), GPU);
}

#[test]
fn pose_fit_matches_its_golden_hash() {
    let h = pose_fit_hash();
    if std::env::var("DIFFSIL_GOLDEN_PRINT").is_ok() {
        println!("const POSE_FIT: u64 = 0x{h:016x};");
        return;
    }
    assert_eq!(h, POSE_FIT, "pose fit changed bits");
}
