//! Tests of `diffsil::io`: OBJ loading with welding, PNG saving and target loading.

use crate::common::files::{temp_dir, write};

use std::path::PathBuf;

use diffsil::io::{load_obj, load_png_target, save_png, weld_by_position, TargetMode};
use diffsil::{Error, Image, Vec3};

/// A unit cube written like exporters do: 24 vertex/uv/normal corners over 8 positions
/// (each face has its own normal, so every corner is split per face), as 6 quads.
const CUBE_OBJ: &str = "\
# cube with per-face normals and uvs
mtllib cube.mtl
o Cube
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
v 1 0 1
v 1 1 1
v 0 1 1
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vn 0 0 -1
vn 0 0 1
vn 0 -1 0
vn 0 1 0
vn -1 0 0
vn 1 0 0
usemtl Material
f 1/1/1 4/2/1 3/3/1 2/4/1
f 5/1/2 6/2/2 7/3/2 8/4/2
f 1/1/3 2/2/3 6/3/3 5/4/3
f 4/1/4 8/2/4 7/3/4 3/4/4
f 1/1/5 5/2/5 8/3/5 4/4/5
f 2/1/6 3/2/6 7/3/6 6/4/6
";

#[test]
fn cube_with_seams_welds_to_8_vertices() {
    let path = write("cube.obj", CUBE_OBJ.as_bytes());
    let mesh = load_obj(&path).unwrap();
    assert_eq!(mesh.positions().len(), 8);
    assert_eq!(mesh.triangles().len(), 12);
    // Welded and closed: every edge has exactly two faces (no seam edges left).
    let topo = mesh.topology();
    assert_eq!(topo.edges().len(), 18);
    for e in 0..topo.edges().len() {
        assert_eq!(topo.edge_faces(e).len(), 2, "edge {:?}", topo.edges()[e]);
    }
    // Order of first occurrence: the first face's corners come first.
    assert_eq!(mesh.positions()[0], Vec3::new(0.0, 0.0, 0.0));
    assert_eq!(mesh.positions()[1], Vec3::new(0.0, 1.0, 0.0));
}

#[test]
fn cube_with_duplicated_positions_welds_to_8_vertices() {
    // Exporters that write one `v` per face corner: 24 `v` lines, 8 distinct positions.
    let corners = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]];
    let faces = [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [3, 7, 6, 2], [0, 4, 7, 3], [1, 2, 6, 5]];
    let mut obj = String::new();
    for (f, face) in faces.iter().enumerate() {
        for &c in face {
            let [x, y, z] = corners[c];
            obj += &format!("v {x} {y} {z}\nvt 0 0\nvn 0 0 1\n");
        }
        let k = 4 * f + 1;
        obj += &format!(
            "f {}/{}/{} {}/{}/{} {}/{}/{} {}/{}/{}\n",
            k,
            k,
            k,
            k + 1,
            k + 1,
            k + 1,
            k + 2,
            k + 2,
            k + 2,
            k + 3,
            k + 3,
            k + 3
        );
    }
    let mesh = load_obj(write("cube24.obj", obj.as_bytes())).unwrap();
    assert_eq!(mesh.positions().len(), 8);
    assert_eq!(mesh.triangles().len(), 12);
    let topo = mesh.topology();
    assert_eq!(topo.edges().len(), 18);
    assert!((0..18).all(|e| topo.edge_faces(e).len() == 2));
}

#[test]
fn quad_triangulates_to_two_triangles() {
    let path = write("quad.obj", b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
    let mesh = load_obj(&path).unwrap();
    assert_eq!(mesh.positions().len(), 4);
    assert_eq!(mesh.triangles(), &[[0, 1, 2], [0, 2, 3]]);
}

#[test]
fn models_are_merged_and_welded_across_objects() {
    let obj = "o A\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\no B\nv 1 0 0\nv 0 1 0\nv 1 1 -0\nv 1 1 0\nf 4 5 6\nf 4 5 7\n";
    let mesh = load_obj(write("two.obj", obj.as_bytes())).unwrap();
    assert_eq!(mesh.triangles().len(), 3);
    // (1,1,-0) and (1,1,0) weld; the shared (1,0,0) and (0,1,0) weld across objects.
    assert_eq!(mesh.positions().len(), 4);
}

#[test]
fn weld_by_position_is_deterministic_and_keeps_degenerate_triangles() {
    let p = [Vec3::X, Vec3::Y, Vec3::X, Vec3::Z, Vec3::Y];
    let (pos, tris) = weld_by_position(&p, &[[0, 1, 3], [2, 4, 3], [0, 2, 1], [0, 9, 1]]);
    assert_eq!(pos, vec![Vec3::X, Vec3::Y, Vec3::Z]);
    assert_eq!(tris, vec![[0, 1, 2], [0, 1, 2], [0, 0, 1], [0, u32::MAX, 1]]);
    // No duplicates: unchanged.
    let (pos, tris) = weld_by_position(&[Vec3::X, Vec3::Y, Vec3::Z], &[[2, 1, 0]]);
    assert_eq!(pos, vec![Vec3::X, Vec3::Y, Vec3::Z]);
    assert_eq!(tris, vec![[2, 1, 0]]);
}

#[test]
fn missing_file_is_io_error() {
    let path = temp_dir().join("does-not-exist.obj");
    match load_obj(&path) {
        Err(Error::Io { path: p, .. }) => assert_eq!(p, path),
        other => panic!("expected Io error, got {other:?}"),
    }
    assert!(matches!(load_png_target(temp_dir().join("nope.png"), TargetMode::Coverage), Err(Error::Io { .. })));
}

#[test]
fn garbage_files_are_errors_not_panics() {
    let cases: &[(&str, &[u8])] = &[
        ("text.obj", b"hello world\nthis is not an obj\n"),
        ("binary.obj", &[0xff, 0xfe, 0x00, 0x80, 0x9f, 0x10, 0x0a, 0xc3, 0x28]),
        ("empty.obj", b""),
        ("vertices-only.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\n"),
        ("bad-float.obj", b"v 0 zero 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
        ("bad-face.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 x 3\n"),
        ("empty-index.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf /1 2 3\n"),
        ("empty-index-0.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf /0 2 3\n"),
        ("huge-index.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999\n"),
        ("min-index.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -9223372036854775808\n"),
        ("zero-index.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n"),
        ("points-lines.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\np 1\nl 1 2\n"),
    ];
    for (name, content) in cases {
        let result = load_obj(write(name, content));
        match result {
            Err(Error::Format { reason, .. }) => println!("{name}: {reason}"),
            other => panic!("{name}: expected a Format error, got {other:?}"),
        }
    }
    // Texture/normal indices are ignored, so even broken ones load (and never panic).
    for (name, content) in [
        ("zero-uv.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/0 2/1 3/1\n"),
        ("neg-uv.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/-5 2/1 3/1\n"),
        ("neg-normal.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//-7 2//1 3//1\n"),
        ("oob-uv.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/1 3/2\n"),
    ] {
        let mesh = load_obj(write(name, content.as_bytes())).unwrap();
        assert_eq!((mesh.positions().len(), mesh.triangles().len()), (3, 1), "{name}");
    }
    let png = write("garbage.png", b"\x89PNG\r\n\x1a\nnot really");
    assert!(matches!(load_png_target(png, TargetMode::Coverage), Err(Error::Format { .. })));
    let png = write("text.png", b"hello");
    assert!(matches!(load_png_target(png, TargetMode::Coverage), Err(Error::Format { .. })));
}

#[test]
fn face_index_out_of_range_is_error() {
    for (name, obj) in
        [("oob.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n"), ("oob-neg.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n")]
    {
        match load_obj(write(name, obj.as_bytes())) {
            Err(Error::Format { reason, .. }) => {
                // The line, the index, the vertex count and the fix.
                for word in ["line 4", "index", "out of range", "3 vertices", "fix the `f` line"] {
                    assert!(reason.contains(word), "{name}: `{reason}` should mention `{word}`");
                }
                assert!(reason.contains(if name == "oob.obj" { "index 4" } else { "index -4" }), "{name}: {reason}");
            }
            other => panic!("{name}: expected a Format error, got {other:?}"),
        }
    }
    // A negative index counts back from the vertices defined *before* its line.
    match load_obj(write("early.obj", b"v 0 0 0\nf 1 -2 -1\nv 1 0 0\nv 0 1 0\n")) {
        Err(Error::Format { reason, .. }) => {
            assert!(reason.contains("line 2") && reason.contains("-2") && reason.contains("1 vertices"), "{reason}")
        }
        other => panic!("expected a Format error, got {other:?}"),
    }
}

/// A PNG whose header declares `width × height` at `bit_depth` and colour type `colour`, with no
/// pixel data: what a decompression bomb looks like before its (tiny, highly compressed) data.
fn png_header_only(width: u32, height: u32, bit_depth: u8, colour: u8) -> Vec<u8> {
    fn crc32(bytes: &[u8]) -> u32 {
        let mut crc = 0xFFFF_FFFFu32;
        for &b in bytes {
            crc ^= u32::from(b);
            for _ in 0..8 {
                crc = if crc & 1 == 1 { (crc >> 1) ^ 0xEDB8_8320 } else { crc >> 1 };
            }
        }
        !crc
    }
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut chunk = |kind: &[u8], data: &[u8]| {
        out.extend_from_slice(&(data.len() as u32).to_be_bytes());
        let body: Vec<u8> = kind.iter().chain(data).copied().collect();
        out.extend_from_slice(&body);
        out.extend_from_slice(&crc32(&body).to_be_bytes());
    };
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&width.to_be_bytes());
    ihdr.extend_from_slice(&height.to_be_bytes());
    ihdr.extend_from_slice(&[bit_depth, colour, 0, 0, 0]);
    chunk(b"IHDR", &ihdr);
    chunk(b"IDAT", &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01]);
    chunk(b"IEND", &[]);
    out
}

#[test]
fn png_bombs_are_refused_before_decoding() {
    // 20000² gray: above the largest resolution (the 389 KB file decoded 2 GB).
    let path = write("wide.png", &png_header_only(20_000, 20_000, 8, 0));
    let start = std::time::Instant::now();
    match load_png_target(&path, TargetMode::Coverage) {
        Err(Error::Format { path: p, reason }) => {
            assert_eq!(p, path);
            for word in ["PNG", "refused", "16384", "downscale"] {
                assert!(reason.contains(word), "`{reason}` should mention `{word}`");
            }
        }
        other => panic!("expected a Format error, got {other:?}"),
    }
    // 16384² RGBA 16-bit: a supported size, but 2 GiB of pixels, above the decoding limit.
    let path = write("deep.png", &png_header_only(16_384, 16_384, 16, 6));
    match load_png_target(&path, TargetMode::Coverage) {
        Err(Error::Format { reason, .. }) => {
            let limit = diffsil::io::MAX_PNG_DECODE_BYTES.to_string();
            assert!(reason.contains("PNG") && reason.contains(&limit) && reason.contains("downscale"), "{reason}");
        }
        other => panic!("expected a Format error, got {other:?}"),
    }
    assert!(start.elapsed().as_secs_f64() < 2.0, "refused after {:?}", start.elapsed());
}

#[test]
fn truncated_png_says_png_and_truncated() {
    let image = Image::from_vec(16, 16, (0..256).map(|i| (i % 7) as f32 / 6.0).collect()).unwrap();
    let path = temp_dir().join("full.png");
    save_png(&image, &path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let mut truncated_named = 0;
    for cut in 8..bytes.len() {
        let path = write("cut.png", &bytes[..cut]);
        match load_png_target(&path, TargetMode::Coverage) {
            // Only the IEND chunk (the last 12 bytes) missing: the pixels are all there.
            Ok(_) if cut >= bytes.len() - 12 => {}
            Err(Error::Format { path: p, reason }) => {
                assert_eq!(p, path);
                assert!(reason.contains("PNG"), "cut at {cut}: `{reason}` should say PNG");
                truncated_named += usize::from(reason.contains("truncated"));
            }
            other => panic!("cut at {cut}: expected a Format error, got {other:?}"),
        }
    }
    // Every cut after the header is an early end of file.
    assert!(truncated_named >= bytes.len() - 8 - 33, "{truncated_named} of {} cuts said truncated", bytes.len() - 8);
}

#[test]
fn loaders_refuse_directories_and_special_files_without_blocking() {
    let dir = temp_dir();
    let mut specials = vec![(dir.clone(), "a directory")];
    let fifo = dir.join("pipe.obj");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status().is_ok_and(|s| s.success());
    if made {
        specials.push((fifo, "a device, pipe or socket"));
    }
    if std::path::Path::new("/dev/zero").exists() {
        specials.push(("/dev/zero".into(), "a device, pipe or socket"));
    }
    for (path, kind) in &specials {
        let start = std::time::Instant::now();
        for result in [load_obj(path).map(|_| ()), load_png_target(path, TargetMode::Coverage).map(|_| ())] {
            match result {
                Err(Error::Format { path: p, reason }) => {
                    assert_eq!(&p, path);
                    assert!(reason.contains(kind) && reason.contains("regular file"), "{}: {reason}", path.display());
                }
                other => panic!("{}: expected a Format error, got {other:?}", path.display()),
            }
        }
        assert!(start.elapsed().as_secs_f64() < 1.0, "{} took {:?}", path.display(), start.elapsed());
    }
    assert!(specials.len() >= 2, "no FIFO or device to test with");
}

#[test]
fn non_finite_coordinate_is_error() {
    for (name, obj) in
        [("nan.obj", "v 0 0 0\nv 1 NaN 0\nv 0 1 0\nf 1 2 3\n"), ("inf.obj", "v 0 0 0\nv 1 0 inf\nv 0 1 0\nf 1 2 3\n")]
    {
        match load_obj(write(name, obj.as_bytes())) {
            Err(Error::Format { reason, .. }) => assert!(reason.contains("non-finite"), "{name}: {reason}"),
            other => panic!("{name}: expected a Format error, got {other:?}"),
        }
    }
}

#[test]
fn relative_indices_and_polygons_load() {
    let obj = "v 0 0 0\nv 1 0 0\nv 2 1 0\nv 1 2 0\nv 0 1 0\nf -5 -4 -3 -2 -1\n";
    let mesh = load_obj(write("pentagon.obj", obj.as_bytes())).unwrap();
    assert_eq!(mesh.positions().len(), 5);
    assert_eq!(mesh.triangles().len(), 3);
}

#[test]
fn png_roundtrip_within_one_level() {
    let (w, h) = (7u32, 5u32);
    let data: Vec<f32> = (0..w * h).map(|k| k as f32 / (w * h - 1) as f32).collect();
    let mut data_out_of_range = data.clone();
    data_out_of_range[0] = -3.0;
    data_out_of_range[1] = 7.0;
    data_out_of_range[2] = f32::NAN;
    let image = Image::from_vec(w, h, data_out_of_range).unwrap();
    let path = temp_dir().join("roundtrip.png");
    save_png(&image, &path).unwrap();
    let loaded = load_png_target(&path, TargetMode::Coverage).unwrap();
    assert_eq!((loaded.width(), loaded.height()), (w, h));
    for (k, (&a, &b)) in data.iter().zip(loaded.data()).enumerate() {
        let expected = match k {
            0 | 2 => 0.0,
            1 => 1.0,
            _ => a,
        };
        assert!((expected - b).abs() <= 1.0 / 255.0, "pixel {k}: {expected} vs {b}");
    }
    // Row 0 is the top row of the PNG.
    let decoded = image::open(&path).unwrap().to_luma8();
    assert_eq!(decoded.get_pixel(6, 0).0[0], (6.0f32 / 34.0 * 255.0).round() as u8);
    assert_eq!(decoded.get_pixel(0, 4).0[0], (28.0f32 / 34.0 * 255.0).round() as u8);
}

#[test]
fn save_png_errors() {
    let empty = Image::filled(0, 3, 0.5);
    assert!(matches!(save_png(&empty, temp_dir().join("e.png")), Err(Error::Format { .. })));
    let img = Image::filled(2, 2, 0.5);
    let bad = temp_dir().join("no-such-dir").join("x.png");
    assert!(matches!(save_png(&img, bad), Err(Error::Io { .. })));
}

#[test]
fn gray16_png_target() {
    let values: [u16; 6] = [0, 65535, 32768, 1000, 65000, 12345];
    let buf = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(3, 2, values.to_vec()).unwrap();
    let path = temp_dir().join("gray16.png");
    buf.save(&path).unwrap();
    let img = load_png_target(&path, TargetMode::Coverage).unwrap();
    assert_eq!((img.width(), img.height()), (3, 2));
    for (k, &v) in values.iter().enumerate() {
        assert!((img.data()[k] - v as f32 / 65535.0).abs() < 1e-6, "pixel {k}");
    }
    let hard = load_png_target(&path, TargetMode::Threshold(0.5)).unwrap();
    assert_eq!(hard.data(), &[0.0, 1.0, 1.0, 0.0, 1.0, 0.0]);
}

#[test]
fn rgba_png_target() {
    // white opaque, white half-transparent, black opaque, red opaque, white transparent, gray opaque
    let px: [[u8; 4]; 6] = [
        [255, 255, 255, 255],
        [255, 255, 255, 128],
        [0, 0, 0, 255],
        [255, 0, 0, 255],
        [255, 255, 255, 0],
        [128, 128, 128, 255],
    ];
    let buf = image::RgbaImage::from_raw(2, 3, px.concat()).unwrap();
    let path = temp_dir().join("rgba.png");
    buf.save(&path).unwrap();
    let img = load_png_target(&path, TargetMode::Coverage).unwrap();
    assert_eq!((img.width(), img.height()), (2, 3));
    let expected = [1.0, 128.0 / 255.0, 0.0, 0.2126, 0.0, 128.0 / 255.0];
    for (k, (&e, &v)) in expected.iter().zip(img.data()).enumerate() {
        assert!((e - v).abs() < 1e-5, "pixel {k}: {e} vs {v}");
    }
    let hard = load_png_target(&path, TargetMode::Threshold(0.5)).unwrap();
    assert_eq!(hard.data(), &[1.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
}

#[test]
fn rgb_and_gray_alpha_png_targets() {
    let rgb = image::RgbImage::from_raw(2, 1, vec![255, 255, 255, 0, 255, 0]).unwrap();
    let path = temp_dir().join("rgb.png");
    rgb.save(&path).unwrap();
    let img = load_png_target(&path, TargetMode::Coverage).unwrap();
    assert!((img.data()[0] - 1.0).abs() < 1e-6 && (img.data()[1] - 0.7152).abs() < 1e-5);

    let la = image::GrayAlphaImage::from_raw(2, 1, vec![255, 51, 102, 255]).unwrap();
    let path = temp_dir().join("la.png");
    la.save(&path).unwrap();
    let img = load_png_target(&path, TargetMode::Coverage).unwrap();
    assert!((img.data()[0] - 0.2).abs() < 1e-6 && (img.data()[1] - 0.4).abs() < 1e-6);
}

#[test]
fn threshold_mode_gives_only_zero_or_one() {
    let data: Vec<f32> = (0..64).map(|k| (k as f32 * 0.37).sin() * 0.5 + 0.5).collect();
    let path = temp_dir().join("soft.png");
    save_png(&Image::from_vec(8, 8, data).unwrap(), &path).unwrap();
    let soft = load_png_target(&path, TargetMode::Coverage).unwrap();
    for t in [0.0, 0.25, 0.5, 0.99, -1.0, 2.0, f32::INFINITY] {
        let hard = load_png_target(&path, TargetMode::Threshold(t)).unwrap();
        for (&h, &s) in hard.data().iter().zip(soft.data()) {
            assert!(h == 0.0 || h == 1.0);
            assert_eq!(h == 1.0, s > t);
        }
    }
    assert!(matches!(load_png_target(&path, TargetMode::Threshold(f32::NAN)), Err(Error::InvalidSettings(_))));
}

fn assets() -> PathBuf {
    PathBuf::from(std::env::var_os("DIFFSIL_ASSETS").expect("set DIFFSIL_ASSETS to the assets folder"))
}

#[test]
#[ignore = "needs DIFFSIL_ASSETS"]
fn real_meshes_load_and_weld() {
    for (name, file_vertices, file_faces) in [("stanford-bunny.obj", 35947, 69451), ("spot.obj", 2930, 5856)] {
        let mesh = load_obj(assets().join(name)).unwrap();
        let (v, t) = (mesh.positions().len(), mesh.triangles().len());
        let boundary = (0..mesh.topology().edges().len()).filter(|&e| mesh.topology().edge_faces(e).len() == 1).count();
        println!("{name}: {v} welded vertices ({file_vertices} `v` lines), {t} triangles ({file_faces} `f` lines), {boundary} open-boundary edges");
        assert!(v > 0 && v <= file_vertices);
        assert!(t >= file_faces);
        assert!(mesh.positions().iter().all(|p| p.is_finite()));
    }
}
