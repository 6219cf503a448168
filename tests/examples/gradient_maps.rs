//! The `gradient_maps` example's functions, at small sizes: per-pixel analytic derivatives for
//! three motions against central differences of the exact-area oracle, exact zeros away from the
//! silhouette, the lattice seeds against one-hot seeds, the GPU backend against the CPU one, and
//! bad command lines.

#[allow(dead_code)]
#[path = "../../examples/gradient_maps/main.rs"]
mod example;

use std::sync::Arc;

use crate::common;
use common::scenes::{self, Scene2d};
use diffsil::mirror::ScreenVertex;
use diffsil::{Image, RenderSettings, Renderer, ScreenView, Topology};
use example::*;
use glam::DVec2;

/// The example's scene for the built-in mesh at its default view.
fn builtin(resolution: u32) -> Scene {
    let o = Options::default();
    Scene::new(&builtin_mesh(), resolution, o.azimuth, o.elevation).unwrap()
}

/// A square test scene from `tests/common/scenes.rs` as the example's [`Scene`].
fn from_2d(s: Scene2d) -> Scene {
    assert_eq!(s.width, s.height, "{}: the example draws square images", s.name);
    let topology = Arc::new(Topology::new(s.vertices.len(), s.triangles).unwrap());
    Scene { topology, screen: s.vertices, resolution: s.width }
}

fn velocities(scene: &Scene) -> Vec<Vec<DVec2>> {
    Motion::ALL.iter().map(|m| scene.velocities(*m)).collect()
}

fn cpu_maps(scene: &Scene) -> AnalyticMaps {
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    analytic_maps(&mut renderer, scene, &velocities(scene), false).unwrap()
}

#[test]
fn analytic_maps_match_finite_differences_on_the_builtin_mesh() {
    let scene = builtin(48);
    let analytic = cpu_maps(&scene);
    for ((motion, a), v) in Motion::ALL.iter().zip(&analytic.maps).zip(velocities(&scene)) {
        let fd = finite_difference_map(&scene, &v, 1e-4);
        let agreement = agreement(a, &fd);
        let touched = a.iter().filter(|x| **x != 0.0).count();
        assert!(touched > 100, "{motion:?}: only {touched} pixels have a derivative");
        assert!(agreement.cosine >= 0.999, "{motion:?}: {agreement:?}");
        // Measured ~2e-8 (f32 gradients); the bound leaves room for other platforms' rounding.
        assert!(agreement.relative_error <= 1e-4, "{motion:?}: {agreement:?}");
    }
}

#[test]
fn analytic_maps_match_finite_differences_on_folds_overlaps_and_open_edges() {
    for s in [scenes::torus_fold(), scenes::two_spheres(), scenes::hemisphere(), scenes::open_patch()] {
        let name = s.name;
        let scene = from_2d(s);
        let analytic = cpu_maps(&scene);
        for ((motion, a), v) in Motion::ALL.iter().zip(&analytic.maps).zip(velocities(&scene)) {
            let agreement = agreement(a, &finite_difference_map(&scene, &v, 1e-4));
            assert!(agreement.cosine >= 0.999, "{name} {motion:?}: {agreement:?}");
            assert!(agreement.relative_error <= 1e-4, "{name} {motion:?}: {agreement:?}");
        }
    }
}

/// Pixels that a candidate (contour or boundary) edge passes through, sampled densely along each
/// candidate: those of interior contours lie inside the silhouette.
fn candidate_pixels(scene: &Scene) -> Vec<bool> {
    let screen: Vec<ScreenVertex> =
        scene.screen.iter().map(|p| ScreenVertex { position: p.to_array(), valid: 1, pad: 0 }).collect();
    let topology = &scene.topology;
    let mut orientation = vec![0i8; topology.triangles().len()];
    diffsil::cpu::edges::face_orientations(&screen, topology.triangles(), &mut orientation);
    let mut candidates = Vec::new();
    diffsil::cpu::edges::edges(&orientation, topology, &mut candidates);
    let n = scene.resolution as usize;
    let mut hit = vec![false; n * n];
    for &(e, _side) in &candidates {
        let edge = topology.edges()[e as usize];
        let (a, b) = (scene.screen[edge[0] as usize], scene.screen[edge[1] as usize]);
        let steps = ((b - a).length() * 64.0).ceil() as usize + 1;
        for k in 0..=steps {
            let p = a + (b - a) * (k as f32 / steps as f32);
            let (i, j) = (p.y.floor() as isize, p.x.floor() as isize);
            if (0..n as isize).contains(&i) && (0..n as isize).contains(&j) {
                hit[i as usize * n + j as usize] = true;
            }
        }
    }
    hit
}

#[test]
fn analytic_maps_are_exactly_zero_away_from_the_silhouette() {
    let cases = [
        ("built-in blob", builtin(48)),
        ("torus_fold", from_2d(scenes::torus_fold())),
        ("two_spheres", from_2d(scenes::two_spheres())),
    ];
    for (name, scene) in cases {
        let coverage = scene.exact_coverage();
        let away = away_from_silhouette(&coverage, scene.resolution);
        let inside = away.iter().zip(&coverage).filter(|(a, c)| **a && **c > 0.5).count();
        let outside = away.iter().zip(&coverage).filter(|(a, c)| **a && **c < 0.5).count();
        assert!(inside > 100 && outside > 100, "{name}: {inside} pixels away inside, {outside} outside");
        let analytic = cpu_maps(&scene);
        for (motion, map) in Motion::ALL.iter().zip(&analytic.maps) {
            for (p, (value, away)) in map.iter().zip(&away).enumerate() {
                assert!(!away || *value == 0.0, "{name} {motion:?}: pixel {p} away from the silhouette has {value}");
            }
        }
        // The folds and the overlap put contour edges deep inside the silhouette: the zeros there
        // are the visibility test at work, not the absence of edges.
        if name != "built-in blob" {
            let hidden = candidate_pixels(&scene)
                .iter()
                .zip(&away)
                .zip(&coverage)
                .filter(|((hit, away), c)| **hit && **away && **c > 0.5)
                .count();
            assert!(hidden > 0, "{name}: no contour edge inside the silhouette");
        }
    }
}

#[test]
fn lattice_seeds_give_the_one_hot_maps_bit_for_bit() {
    for scene in [builtin(16), from_2d(scenes::two_spheres())] {
        let n = scene.resolution;
        let v = velocities(&scene);
        let lattice = cpu_maps(&scene);
        assert!(lattice.passes < n * n, "{} passes: no compression", lattice.passes);

        // One backward per pixel with a one-hot seed: row (i, j) of the Jacobian, dotted with v.
        let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
        let view = ScreenView { vertices: scene.screen.clone(), width: n, height: n };
        let frame = renderer.render_screen(&scene.topology, &[view]).unwrap();
        let mut one_hot = vec![vec![0.0f64; (n * n) as usize]; v.len()];
        for p in 0..(n * n) as usize {
            let mut seed = Image::filled(n, n, 0.0);
            seed.data_mut()[p] = 1.0;
            let grads = renderer.backward_screen(&frame, &[seed]).unwrap();
            for (map, v) in one_hot.iter_mut().zip(&v) {
                for (g, vk) in grads[0].iter().zip(v) {
                    if *g != diffsil::Vec2::ZERO {
                        map[p] += g.as_dvec2().dot(*vk);
                    }
                }
            }
        }
        assert_eq!(lattice.maps, one_hot);
        assert_eq!(&lattice.silhouette, &frame.images()[0]);
    }
}

#[test]
fn gpu_maps_match_cpu_maps() {
    let Some(context) = common::gpu::gpu_or_skip("gpu_maps_match_cpu_maps") else { return };
    let scene = builtin(32);
    let mut gpu = Renderer::with_gpu_context(RenderSettings::default(), context).unwrap();
    let on_gpu = analytic_maps(&mut gpu, &scene, &velocities(&scene), false).unwrap();
    let on_cpu = cpu_maps(&scene);
    assert_eq!(on_gpu.silhouette, on_cpu.silhouette, "images are bit-identical for screen-space input");
    for ((motion, g), c) in Motion::ALL.iter().zip(&on_gpu.maps).zip(&on_cpu.maps) {
        let agreement = agreement(g, c);
        assert!(agreement.relative_error <= 1e-5, "{motion:?}: {agreement:?}");
    }
}

#[test]
fn agreement_is_never_nan() {
    let zero = vec![0.0; 4];
    let some = vec![0.0, 1.0, -2.0, 0.0];
    assert_eq!(agreement(&zero, &zero).cosine, 1.0);
    assert_eq!(agreement(&zero, &zero).relative_error, 0.0);
    assert_eq!(agreement(&some, &zero).cosine, 0.0);
    assert_eq!(agreement(&zero, &some).relative_error, 1.0);
    let same = agreement(&some, &some);
    assert!((same.cosine - 1.0).abs() < 1e-15 && same.relative_error == 0.0 && same.scale == 2.0);
    let opposite: Vec<f64> = some.iter().map(|x| -x).collect();
    assert!((agreement(&opposite, &some).cosine + 1.0).abs() < 1e-15);
}

#[test]
fn colour_map_is_white_at_zero_blue_below_red_above() {
    assert_eq!(diverging(0.0, 3.0), image::Rgb([255, 255, 255]));
    assert_eq!(diverging(0.5, 0.0), image::Rgb([255, 255, 255]), "a zero scale draws white, not NaN");
    assert_eq!(diverging(-3.0, 3.0), image::Rgb([59, 76, 192]));
    assert_eq!(diverging(7.0, 3.0), image::Rgb([180, 4, 38]), "clamped beyond the scale");
    let half = diverging(1.5, 3.0);
    assert!(half.0[0] > half.0[2] && half.0[1] < 255);
}

#[test]
fn bad_command_lines_are_errors_not_panics() {
    use clap::{error::ErrorKind, CommandFactory, Parser};
    Options::command().debug_assert();
    let parse = |args: &[&str]| Options::try_parse_from(std::iter::once("gradient_maps").chain(args.iter().copied()));
    assert_eq!(parse(&["--help"]).unwrap_err().kind(), ErrorKind::DisplayHelp);
    let o = parse(&[]).unwrap();
    assert_eq!(o, Options::default());
    assert_eq!((o.resolution, o.azimuth, o.elevation, o.backend), (128, 30.0, 20.0, BackendName::Cpu));
    for (args, says) in [
        (&["--resolution"][..], "a value is required for '--resolution <N>'"),
        (&["--resolution", "0"], "8..=1024"),
        (&["--resolution", "-3"], "unexpected argument '-3'"),
        (&["--resolution", "4096"], "8..=1024"),
        (&["--backend", "tpu"], "[possible values: cpu, gpu, auto]"),
        (&["--elevation", "90"], "strictly between -90 and 90"),
        (&["--azimuth", "NaN"], "finite"),
        (&["--frobnicate", "1"], "unexpected argument '--frobnicate'"),
    ] {
        let error = parse(args).unwrap_err().to_string();
        assert!(error.contains(says), "{args:?}: {error}");
    }
    let missing = diffsil::io::gltf::load_mesh("no/such/mesh.obj").unwrap_err();
    assert!(missing.to_string().contains("no/such/mesh.obj"), "{missing}");
}
