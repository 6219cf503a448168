//! Scenes whose silhouette edges coincide (several mesh edges projecting onto the same screen
//! segment, on the same side), and the check they need: the derivative along a rigid translation.
//!
//! Where edges coincide the area is not differentiable in one vertex alone (moving one of two
//! coincident edges outward grows the area, inward leaves it), so per-vertex finite differences
//! measure a mean of one-sided derivatives that no choice of which edge carries the stretch
//! matches. Moving the whole mesh keeps the edges together and the area differentiable: the
//! analytic `Σ_v ∂L/∂p_v` along an axis is compared with central differences of the oracle.

use super::*;
use diffsil::{Camera, Mesh};

/// The closed box `[lo, hi]` (8 vertices, 12 triangles wound outwards).
pub fn cuboid(lo: Vec3, hi: Vec3) -> Mesh {
    let corner = |k: u32| {
        Vec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        )
    };
    let positions = (0..8).map(corner).collect();
    // Each face as a quad (counter-clockwise seen from outside), split along one diagonal.
    let quads = [[0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3], [0, 2, 3, 1], [4, 5, 7, 6]];
    let triangles = quads.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
    Mesh::new(positions, triangles).expect("valid box")
}

/// The cube: `[−0.5, 0.5]³` shifted by `(2⁻⁷, 3·2⁻⁸, 0)` (off the pixel grid), seen face-on
/// by an orthographic camera from `(0, 0, 5)` with a view height of 2 at 64²: the side faces are
/// edge-on, so the front and back outlines coincide.
pub fn cube_orthographic() -> Scene3d {
    let shift = Vec3::new(0.0078125, 0.01171875, 0.0);
    Scene3d {
        name: "cube face-on, orthographic",
        mesh: cuboid(Vec3::splat(-0.5) + shift, Vec3::splat(0.5) + shift),
        cameras: vec![Camera::orthographic(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, 2.0, 64, 64)],
    }
}

/// The same cube seen face-on by a perspective camera from `(0, 0, 5)` at 64²: the side faces
/// are seen from inside their planes (back faces within the front outline), so nothing coincides;
/// with [`doubled`] every outline edge coincides with its copy's.
pub fn cube_perspective() -> Scene3d {
    let shift = Vec3::new(0.0078125, 0.01171875, 0.0);
    Scene3d {
        name: "cube face-on, perspective",
        mesh: cuboid(Vec3::splat(-0.5) + shift, Vec3::splat(0.5) + shift),
        cameras: vec![Camera::perspective(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, 30f32.to_radians(), 64, 64)],
    }
}

/// Two boxes of different depths whose top faces lie in one plane, seen face-on by an orthographic
/// camera: their top outlines (each a front and a back edge) overlap on a stretch of one line;
/// where one box's side outline lies inside the other's silhouette it is occluded.
pub fn boxes_sharing_a_plane() -> Scene3d {
    let a = cuboid(Vec3::new(-0.61, -0.43, 0.05), Vec3::new(0.23, 0.3125, 0.55));
    let b = cuboid(Vec3::new(-0.07, -0.19, -0.65), Vec3::new(0.57, 0.3125, -0.1));
    Scene3d {
        name: "two boxes sharing a face plane",
        mesh: super::super::scenes::merged(&[a, b]),
        cameras: vec![Camera::orthographic(Vec3::new(0.013, 0.0, 5.0), Vec3::new(0.013, 0.0, 0.0), 1.9, 48, 40)],
    }
}

/// `scene`'s mesh concatenated with an exact copy of itself (vertices `n..2n` repeat `0..n`).
pub fn doubled(scene: &Scene3d, name: &'static str) -> Scene3d {
    let mesh = super::super::scenes::merged(&[scene.mesh.clone(), scene.mesh.clone()]);
    Scene3d { name, mesh, cameras: scene.cameras.clone() }
}

/// The coincident-edge scenes of the tests, each with the scene its oracle reference renders: the
/// same union of triangles, so the same exact image, but without exact copies (for [`doubled`], the
/// mesh alone), because the reference's rounding compensation uses per-vertex derivatives, which at
/// coincident edges are means of one-sided ones (module docs).
pub fn coincident_scenes() -> Vec<(Scene3d, Scene3d)> {
    let sphere = super::super::scenes::icosphere_3d();
    let with_copy = |scene: Scene3d, name| (doubled(&scene, name), scene);
    vec![
        (cube_orthographic(), cube_orthographic()),
        (cube_perspective(), cube_perspective()),
        (boxes_sharing_a_plane(), boxes_sharing_a_plane()),
        with_copy(sphere, "icosphere + its copy"),
        with_copy(cube_orthographic(), "cube + its copy, orthographic"),
        with_copy(cube_perspective(), "cube + its copy, perspective"),
    ]
}

/// `Σ_v ∂L/∂p_v` per axis from a flattened world gradient `[x0, y0, z0, x1, ...]`.
pub fn translation_gradient(grad: &[f64]) -> [f64; 3] {
    [0, 1, 2].map(|c| grad.iter().skip(c).step_by(3).sum())
}

/// The derivative of `L = Σ w·I` (random weights, `options.seed`) along a translation of the whole
/// mesh of `scene`, analytic against central differences of the exact-area oracle of `reference`
/// (a scene with the same union of triangles, see [`coincident_scenes`]), per axis along which it
/// is not ~0 (an orthographic camera's depth axis moves nothing). `options.h` is in pixels.
pub fn check_translation(scene: &Scene3d, reference: &Scene3d, options: FdOptions) -> Check {
    let mut rng = Rng::new(options.seed);
    let weights: Vec<Vec<f32>> = scene.cameras.iter().map(|c| rng.weights((c.width * c.height) as usize)).collect();
    let analytic = translation_gradient(&analytic_3d(scene, &weights, options.settings));
    let references = translation_references(reference, &weights, options);
    Check { name: scene.name.to_string(), ..translation_check(reference, &references, analytic, options) }
}

/// The oracle references of every view of `scene` for [`translation_check`].
pub fn translation_references(scene: &Scene3d, weights: &[Vec<f32>], options: FdOptions) -> Vec<ViewReference> {
    (0..scene.cameras.len())
        .map(|k| ViewReference::new(scene, k, weights[k].clone(), options.settings, true, options.h.max(H_G2)))
        .collect()
}

/// [`check_translation`] from given analytic translation derivatives (another engine's) and the
/// view references of `scene` (the reference scene).
pub fn translation_check(
    scene: &Scene3d,
    references: &[ViewReference],
    analytic: [f64; 3],
    options: FdOptions,
) -> Check {
    // A power of two: with an orthographic camera every moved point is then exactly representable
    // and the rounding compensation (whose per-vertex `g₂` is a mean of one-sided derivatives at
    // coincident edges) is zero.
    let h = 2f64.powi(world_step(scene, options.h).log2().floor() as i32);
    let base: Vec<DVec3> = scene.mesh.positions().iter().map(|p| p.as_dvec3()).collect();
    let fd = [0, 1, 2].map(|c| {
        let mut step = DVec3::ZERO;
        step[c] = h;
        let plus: Vec<DVec3> = base.iter().map(|&p| p + step).collect();
        let minus: Vec<DVec3> = base.iter().map(|&p| p - step).collect();
        let dl: f64 = references.iter().map(|r| r.loss_difference(&plus, &minus)).sum();
        dl / (2.0 * h)
    });
    let norm = fd.iter().map(|d| d * d).sum::<f64>().sqrt();
    let mut check = summarise(scene.name, &analytic, &fd, Vec::new());
    // Per axis, where the translation moves the silhouette (not the depth axis of an orthographic
    // camera, whose derivatives are exactly zero).
    check.directions =
        (0..3).filter(|&c| fd[c].abs() > 1e-3 * norm).map(|c| (analytic[c] - fd[c]).abs() / fd[c].abs()).collect();
    check
}
