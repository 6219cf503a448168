//! The machinery of the golden-hash tests (`golden` in each test binary): the bits of images,
//! gradients, losses and fitted poses, hashed, and compared with tables recorded before the
//! redesign (#10). `DIFFSIL_GOLDEN_PRINT=1` prints the table instead of comparing.

use super::scenes::{self, Scene3d};
use diffsil::{Image, Mesh, Renderer, Targets, Vec2, Vec3};

/// FNV-1a over 32-bit words.
#[derive(Clone, Copy)]
#[allow(clippy::new_without_default)]
pub struct Hash(pub u64);

impl Hash {
    pub fn new() -> Hash {
        Hash(0xcbf2_9ce4_8422_2325)
    }
    pub fn word(&mut self, w: u32) {
        for b in w.to_le_bytes() {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    pub fn floats(&mut self, xs: impl IntoIterator<Item = f32>) {
        for x in xs {
            self.word(x.to_bits());
        }
    }
    pub fn f64(&mut self, x: f64) {
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

/// Every hashed output, by name, from `renderer` (CPU or GPU): the `f32` words in the order they
/// are hashed (images row by row, gradients vertex by vertex).
pub fn outputs(renderer: &mut Renderer) -> Vec<(String, Vec<f32>)> {
    let mut out = Vec::new();
    let vec2s = |g: &[Vec2]| g.iter().flat_map(|v| v.to_array()).collect::<Vec<f32>>();
    let vec3s = |g: &[Vec3]| g.iter().flat_map(|v| v.to_array()).collect::<Vec<f32>>();
    for scene in scenes::all_2d() {
        let frame = renderer.render_screen(&scene.topology(), &[scene.view()]).unwrap();
        out.push((format!("2d/{}/image", scene.name), frame.images()[0].data().to_vec()));
        let d = weights(scene.width, scene.height, 1);
        let g = renderer.backward_screen(&frame, &[d]).unwrap();
        out.push((format!("2d/{}/grad", scene.name), vec2s(&g[0])));
    }
    for scene in scenes_3d() {
        let frame = renderer.render(&scene.mesh, &scene.cameras).unwrap();
        let images = frame.images().iter().flat_map(|image| image.data().iter().copied()).collect();
        out.push((format!("3d/{}/images", scene.name), images));
        let d: Vec<Image> =
            scene.cameras.iter().enumerate().map(|(k, c)| weights(c.width, c.height, k as u32)).collect();
        let g = renderer.backward(&frame, &d).unwrap();
        out.push((format!("3d/{}/grad", scene.name), vec3s(&g)));
        let moved = Mesh::with_topology(
            scene.mesh.positions().iter().map(|p| *p + Vec3::new(0.04, -0.03, 0.02)).collect(),
            scene.mesh.topology().clone(),
        )
        .unwrap();
        let targets = Targets::new(renderer.render(&moved, &scene.cameras).unwrap().images().to_vec()).unwrap();
        let step = renderer.squared_error_step(&scene.mesh, &scene.cameras, &targets).unwrap();
        out.push((format!("3d/{}/step_grad", scene.name), vec3s(&step.gradient)));
    }
    out
}

/// The hash of one output's words.
pub fn hash_of(words: &[f32]) -> u64 {
    let mut h = Hash::new();
    h.floats(words.iter().copied());
    h.0
}

/// Every hash, by name, from `renderer` (CPU or GPU).
pub fn hashes(renderer: &mut Renderer) -> Vec<(String, u64)> {
    outputs(renderer).into_iter().map(|(name, words)| (name, hash_of(&words))).collect()
}

pub fn compare(backend: &str, got: &[(String, u64)], want: &[(&str, u64)]) {
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
