//! Seeded fuzzing of every loader and of random extreme scenes on the CPU engine (issue 13); the
//! harness is `tests/common/fuzz.rs`.
//!
//! Each case must finish within 5 s, never panic, never return a non-finite value in an `Ok`
//! result, and never read outside the model's folder: every mutated glTF lives in
//! `<temp>/model/`, with `<temp>/sentinel.bin` beside the folder holding exactly the bytes its
//! buffer needs, so a loader that followed `../sentinel.bin`, an absolute path, a percent-encoded
//! `..` or a symbolic link out of the folder would *succeed*: those cases must fail.
//!
//! Sizes: `DIFFSIL_FUZZ_FILES` mutated files (default 10,000) and `DIFFSIL_FUZZ_SCENES` scenes
//! (default 20,000), seed `DIFFSIL_FUZZ_SEED` (default 13); with `DIFFSIL_ASSETS` set, small
//! real assets join the seed files. The full runs are `#[ignore]`d and run by `.ci/run`
//! (`cargo test --release --test pose fuzz -- --ignored`); a smoke run of 400 of each runs with
//! every `cargo test`.

use std::path::{Path, PathBuf};

use crate::common::files::temp_dir;
use crate::common::fuzz::{env_count, fuzz_seed, mutate, run_cases, Outcome, Scene};
use crate::common::rng::{Draws, SplitMix64};
use diffsil::io::gltf::{load_animations, load_gltf_bytes, load_gltf_with_info, load_mesh, save_glb, Model};
use diffsil::io::{load_obj, load_png_target, save_png, TargetMode};
use diffsil::pose::skin::{JointRest, Skeleton, SkinnedMesh};
use diffsil::{Image, Mesh, Renderer, Vec3};
use glam::Mat4;

const CUBE_OBJ: &str = "# a cube\nmtllib cube.mtl\no cube\nv -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\n\
v -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\nvt 0 0\nvt 1 0\nvt 1 1\nvn 0 0 1\n\
f 1/1/1 4/2/1 3/3/1 2/1/1\nf 5/1/1 6/2/1 7/3/1 8/1/1\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf -4 -3 -7 -8\ng two\nf 1 5 8\n";

/// The URIs that leave the model's folder (or name a device or FIFO), as `.gltf` buffer URIs.
fn escapes(sentinel: &Path) -> Vec<String> {
    vec![
        "../sentinel.bin".into(),
        sentinel.display().to_string(),
        "%2e%2e/sentinel.bin".into(),
        "..%2fsentinel.bin".into(),
        "sub/../../sentinel.bin".into(),
        "model.bin/../../sentinel.bin".into(),
        "link.bin".into(),
        "/dev/zero".into(),
        "/dev/stdin".into(),
        "pipe.bin".into(),
        "/proc/self/fd/0".into(),
    ]
}

/// The seed files, by kind, and the folder layout the cases run in.
struct Seeds {
    /// `(extension, bytes)`.
    files: Vec<(&'static str, Vec<u8>)>,
    /// The `.gltf` with an external buffer (`"uri":"model.bin"`).
    external: String,
    /// `<temp>/model/`, holding `model.bin`, `link.bin` (→ `../sentinel.bin`) and the FIFO `pipe.bin`.
    folder: PathBuf,
    sentinel: PathBuf,
}

/// A two-joint skinned quad, written as GLB by the crate itself.
fn skinned_glb(dir: &Path) -> Vec<u8> {
    let mesh = Mesh::new(
        vec![Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 0.2)],
        vec![[0, 1, 2], [0, 2, 3]],
    )
    .unwrap();
    let child = JointRest { translation: Vec3::new(0.0, 0.5, 0.0), ..JointRest::IDENTITY };
    let skeleton = Skeleton {
        names: vec!["root".into(), "child".into()],
        parents: vec![None, Some(0)],
        rest: vec![JointRest::IDENTITY, child],
        root_parent: vec![Mat4::IDENTITY; 2],
        inverse_bind: vec![Mat4::IDENTITY, Mat4::from_translation(Vec3::new(0.0, -0.5, 0.0))],

        nodes: Vec::new(),
    };
    let weights = vec![[1.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0.5, 0.5, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]];
    let model = SkinnedMesh::new(mesh, skeleton, vec![[0, 1, 0, 0]; 4], weights).unwrap();
    let path = dir.join("seed.glb");
    save_glb(&model, &path).unwrap();
    std::fs::read(path).unwrap()
}

/// The JSON and binary chunks of a GLB written by `save_glb`.
fn split_glb(glb: &[u8]) -> (String, Vec<u8>) {
    let word = |i: usize| u32::from_le_bytes(glb[i..i + 4].try_into().unwrap()) as usize;
    let json_len = word(12);
    let json = String::from_utf8(glb[20..20 + json_len].to_vec()).unwrap();
    let bin_len = word(20 + json_len);
    (json.trim_end().to_string(), glb[28 + json_len..28 + json_len + bin_len].to_vec())
}

fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [chunk[0], *chunk.get(1).unwrap_or(&0), *chunk.get(2).unwrap_or(&0)];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            out.push(if k <= chunk.len() { ALPHABET[(n >> (18 - 6 * k) & 63) as usize] as char } else { '=' });
        }
    }
    out
}

fn seeds() -> Seeds {
    let root = temp_dir();
    let folder = root.join("model");
    std::fs::create_dir_all(folder.join("sub")).unwrap();
    let glb = skinned_glb(&root);
    let (json, bin) = split_glb(&glb);
    assert!(json.contains(r#""buffers":[{"#), "{json}");
    let with_uri = |uri: &str| json.replacen(r#""buffers":[{"#, &format!(r#""buffers":[{{"uri":"{uri}","#), 1);
    let external = with_uri("model.bin");
    let embedded = with_uri(&format!("data:application/octet-stream;base64,{}", base64(&bin)));
    let sentinel = root.join("sentinel.bin");
    std::fs::write(&sentinel, &bin).unwrap();
    std::fs::write(folder.join("model.bin"), &bin).unwrap();
    std::os::unix::fs::symlink(&sentinel, folder.join("link.bin")).unwrap();
    let fifo = folder.join("pipe.bin");
    assert!(std::process::Command::new("mkfifo").arg(&fifo).status().unwrap().success());

    let image = Image::from_vec(8, 6, (0..48).map(|i| (i % 5) as f32 / 4.0).collect()).unwrap();
    save_png(&image, root.join("seed.png")).unwrap();
    let mut rgba16 = Vec::new();
    use image::ImageEncoder;
    image::codecs::png::PngEncoder::new(&mut rgba16)
        .write_image(&[0x12u8; 3 * 2 * 8], 3, 2, image::ExtendedColorType::Rgba16)
        .unwrap();
    let mut files: Vec<(&'static str, Vec<u8>)> = vec![
        ("obj", CUBE_OBJ.as_bytes().to_vec()),
        ("png", std::fs::read(root.join("seed.png")).unwrap()),
        ("png", rgba16),
        ("glb", glb),
        ("gltf", embedded.into_bytes()),
        ("gltf", external.clone().into_bytes()),
    ];
    if let Ok(assets) = std::env::var("DIFFSIL_ASSETS") {
        for name in ["suzanne.obj", "RiggedSimple.glb", "RiggedSimple.gltf", "RiggedFigure.glb", "RiggedFigure.gltf"] {
            let ext = if name.ends_with(".obj") {
                "obj"
            } else if name.ends_with(".glb") {
                "glb"
            } else {
                "gltf"
            };
            files.push((ext, std::fs::read(Path::new(&assets).join(name)).unwrap()));
        }
    }
    Seeds { files, external, folder, sentinel }
}

/// Loads `path` with every loader for its kind: `Ok(true)` if one accepted it (with finite data),
/// `Ok(false)` if all refused it.
fn load_all(ext: &str, path: &Path) -> Outcome {
    let non_finite = |what: &str| Err(format!("{what}: a non-finite value in an Ok result ({})", path.display()));
    let mesh_ok = |mesh: &Mesh| mesh.positions().iter().all(|p| p.is_finite());
    match ext {
        "png" => {
            let mut accepted = false;
            for mode in [TargetMode::Coverage, TargetMode::Threshold(0.5)] {
                if let Ok(image) = load_png_target(path, mode) {
                    accepted = true;
                    if !image.data().iter().all(|v| v.is_finite() && (0.0..=1.0).contains(v)) {
                        return non_finite("load_png_target");
                    }
                }
            }
            Ok(accepted)
        }
        "obj" => match load_obj(path) {
            Ok(mesh) if !mesh_ok(&mesh) => non_finite("load_obj"),
            Ok(_) => Ok(true),
            Err(_) => Ok(false),
        },
        _ => {
            let mut accepted = false;
            if let Ok((model, _)) = load_gltf_with_info(path) {
                accepted = true;
                if !mesh_ok(model.mesh()) {
                    return non_finite("load_gltf");
                }
                if let Model::Skinned(s) = &model {
                    if !s.weights.iter().flatten().all(|w| w.is_finite()) || s.skeleton.validate().is_err() {
                        return non_finite("load_gltf skin");
                    }
                }
            }
            if let Ok(mesh) = load_mesh(path) {
                accepted = true;
                if !mesh_ok(&mesh) {
                    return non_finite("load_mesh");
                }
            }
            // The animation loader, and its clips sampled on the file's own skeleton.
            if let (Ok(clips), Ok((Model::Skinned(s), _))) = (load_animations(path), load_gltf_with_info(path)) {
                accepted = true;
                for clip in &clips {
                    if !clip.duration.is_finite() {
                        return non_finite("load_animations");
                    }
                    for pose in clip.sample_frames(&s.skeleton, 3).into_iter().flatten() {
                        if !pose.to_params().iter().all(|v| v.is_finite()) {
                            return non_finite("Animation::sample");
                        }
                    }
                }
            }
            // The in-memory GLB loader on the same bytes.
            let bytes = std::fs::read(path).expect("the case file was just written");
            if let Ok((model, _)) = load_gltf_bytes(&bytes, &path.to_string_lossy()) {
                accepted = true;
                if !mesh_ok(model.mesh()) {
                    return non_finite("load_gltf_bytes");
                }
            }
            Ok(accepted)
        }
    }
}

/// `count` mutated files through the loaders; every eighth case is an unmutated escape URI,
/// which must be refused.
fn fuzz_files(count: usize) {
    let seed = fuzz_seed();
    let seeds = seeds();
    let escapes = escapes(&seeds.sentinel);
    let summary = run_cases("loaders", count, move |i| {
        let rng = &mut SplitMix64::new(seed.wrapping_mul(31) ^ (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
        let path = |ext: &str| seeds.folder.join(format!("case.{ext}"));
        if i % 8 == 7 {
            let uri = &escapes[rng.below(escapes.len())];
            let json = seeds.external.replace(r#""uri":"model.bin""#, &format!(r#""uri":"{uri}""#));
            let file = path("gltf");
            std::fs::write(&file, json).unwrap();
            return match load_gltf_with_info(&file) {
                Ok(_) => Err(format!("the buffer URI `{uri}` was followed out of the model's folder")),
                Err(e) if e.to_string().contains("sentinel") && !e.to_string().contains("outside") => {
                    Err(format!("`{uri}`: the loader tried to read the sentinel: {e}"))
                }
                Err(_) => Ok(false),
            };
        }
        let (ext, bytes) = &seeds.files[rng.below(seeds.files.len())];
        let file = path(ext);
        std::fs::write(&file, mutate(rng, bytes)).unwrap();
        load_all(ext, &file)
    });
    assert_eq!(summary.cases, count);
}

/// `count` random extreme scenes through render, backward, the fused step, the losses and Adam.
fn fuzz_scenes(count: usize) {
    let seed = fuzz_seed();
    let summary = run_cases("CPU scenes", count, move |i| {
        let scene = Scene::random(seed, i);
        match Renderer::new(scene.settings) {
            Ok(mut renderer) => scene.check(&mut renderer),
            Err(_) => Ok(false),
        }
    });
    assert_eq!(summary.cases, count);
    // The generator is not so extreme that nothing renders.
    assert!(summary.ok * 4 > count, "only {} of {count} scenes rendered", summary.ok);
}

#[test]
fn fuzz_smoke_loaders() {
    fuzz_files(400);
}

#[test]
fn fuzz_smoke_scenes() {
    fuzz_scenes(400);
}

#[test]
#[ignore = "the CI fuzz run (.ci/run): DIFFSIL_FUZZ_FILES mutated files, 10,000 by default"]
fn fuzz_loaders() {
    fuzz_files(env_count("DIFFSIL_FUZZ_FILES", 10_000));
}

#[test]
#[ignore = "the CI fuzz run (.ci/run): DIFFSIL_FUZZ_SCENES random scenes, 20,000 by default"]
fn fuzz_scenes_cpu() {
    fuzz_scenes(env_count("DIFFSIL_FUZZ_SCENES", 20_000));
}
