//! Bad and degenerate input: one test each. Invalid input is an `Error` (never a panic), and
//! degenerate geometry renders and differentiates without NaN.

use std::sync::Arc;

use crate::common::scenes;
use diffsil::{loss, Camera, Error, Frame, Image, Mesh, RenderSettings, Renderer, ScreenView, Topology, Vec2, Vec3};

fn renderer() -> Renderer {
    Renderer::new(RenderSettings::default()).unwrap()
}

fn camera(width: u32, height: u32) -> Camera {
    Camera::perspective(Vec3::new(0.2, 0.1, 3.0), Vec3::ZERO, 0.9, width, height)
}

fn tri_mesh() -> Mesh {
    Mesh::new(vec![Vec3::new(-0.6, -0.5, 0.0), Vec3::new(0.7, -0.4, 0.1), Vec3::new(0.1, 0.6, -0.1)], vec![[0, 1, 2]])
        .unwrap()
}

fn ones(frame: &Frame) -> Vec<Image> {
    frame.images().iter().map(|i| Image::filled(i.width(), i.height(), 1.0)).collect()
}

/// Renders screen-space `vertices`/`triangles` in a `w × h` image and runs the backward with
/// `∂L/∂I = 1`: returns the image and the screen-space gradient, both checked free of NaN/inf.
fn render_and_grad_2d(vertices: Vec<Vec2>, triangles: Vec<[u32; 3]>, w: u32, h: u32) -> (Image, Vec<Vec2>) {
    let topology = Arc::new(Topology::new(vertices.len(), triangles).unwrap());
    let mut r = renderer();
    let frame = r.render_screen(&topology, &[ScreenView { vertices, width: w, height: h }]).unwrap();
    let grads = r.backward_screen(&frame, &ones(&frame)).unwrap().remove(0);
    let image = frame.images()[0].clone();
    assert!(image.data().iter().all(|v| v.is_finite()), "non-finite pixel");
    assert!(grads.iter().all(|g| g.is_finite()), "non-finite gradient");
    (image, grads)
}

fn close(a: &[Vec2], b: &[Vec2]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (*x - *y).length() <= 1e-6 * (1.0 + x.length()))
}

#[test]
fn nan_vertex_is_an_error() {
    let p = vec![Vec3::ZERO, Vec3::new(f32::NAN, 0.0, 0.0), Vec3::Y];
    assert!(matches!(Mesh::new(p.clone(), vec![[0, 1, 2]]), Err(Error::NonFiniteVertex { vertex: 1, .. })));
    let mut mesh = tri_mesh();
    assert!(matches!(mesh.set_positions(&p), Err(Error::NonFiniteVertex { vertex: 1, .. })));
    assert!(mesh.positions().iter().all(|v| v.is_finite()), "a rejected update must not change the mesh");
    let topology = mesh.topology().clone();
    assert!(matches!(Mesh::with_topology(p, topology.clone()), Err(Error::NonFiniteVertex { vertex: 1, .. })));
    let view = ScreenView { vertices: vec![Vec2::ZERO, Vec2::new(3.0, f32::NAN), Vec2::ONE], width: 8, height: 8 };
    assert!(matches!(renderer().render_screen(&topology, &[view]), Err(Error::NonFiniteVertex { vertex: 1, .. })));
}

#[test]
fn inf_vertex_is_an_error() {
    let p = vec![Vec3::ZERO, Vec3::X, Vec3::new(0.0, f32::NEG_INFINITY, 0.0)];
    assert!(matches!(Mesh::new(p, vec![[0, 1, 2]]), Err(Error::NonFiniteVertex { vertex: 2, .. })));
    let topology = tri_mesh().topology().clone();
    let view = ScreenView { vertices: vec![Vec2::new(f32::INFINITY, 1.0), Vec2::X, Vec2::ONE], width: 8, height: 8 };
    assert!(matches!(renderer().render_screen(&topology, &[view]), Err(Error::NonFiniteVertex { vertex: 0, .. })));
}

#[test]
fn index_out_of_range_is_an_error() {
    let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
    let err = Mesh::new(p, vec![[0, 1, 2], [2, 1, 3]]).unwrap_err();
    assert!(matches!(err, Error::IndexOutOfRange { triangle: 1, index: 3, vertex_count: 3 }), "{err}");
    assert!(matches!(Topology::new(3, vec![[0, u32::MAX, 1]]), Err(Error::IndexOutOfRange { .. })));
}

#[test]
fn zero_area_triangle_renders_nothing_and_has_zero_gradient() {
    // Three exactly collinear vertices, alone and next to a regular triangle.
    let line = vec![Vec2::new(2.0, 2.0), Vec2::new(10.0, 6.0), Vec2::new(18.0, 10.0)];
    let (image, grads) = render_and_grad_2d(line.clone(), vec![[0, 1, 2]], 20, 14);
    assert!(image.data().iter().all(|&v| v == 0.0));
    assert!(grads.iter().all(|g| *g == Vec2::ZERO));
    // With a regular triangle: the regular one renders and differentiates as if alone.
    let mut vertices = scenes::triangle().vertices;
    vertices.extend(line);
    let (image, grads) = render_and_grad_2d(vertices.clone(), vec![[0, 1, 2], [3, 4, 5]], 24, 24);
    let (alone_image, alone) = render_and_grad_2d(vertices[..3].to_vec(), vec![[0, 1, 2]], 24, 24);
    assert_eq!(image, alone_image);
    assert!(close(&grads[..3], &alone));
    assert!(grads[3..].iter().all(|g| *g == Vec2::ZERO));
    // In 3D, edge-on: a triangle in a plane through the eye.
    let mesh = Mesh::new(
        vec![Vec3::new(-0.5, 0.0, 0.0), Vec3::new(0.5, 0.0, 0.0), Vec3::new(0.0, 0.0, -1.0)],
        vec![[0, 1, 2]],
    )
    .unwrap();
    let cam = Camera::perspective(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 0.9, 16, 16);
    let mut r = renderer();
    let frame = r.render(&mesh, &[cam]).unwrap();
    let g = r.backward(&frame, &ones(&frame)).unwrap();
    assert!(frame.images()[0].data().iter().all(|&v| v == 0.0));
    assert!(g.iter().all(|g| g.is_finite()));
}

#[test]
fn zero_length_edges_contribute_nothing() {
    let base = scenes::triangle().vertices;
    let (alone_image, alone) = render_and_grad_2d(base.clone(), vec![[0, 1, 2]], 24, 24);
    // (a) Two coincident vertices (distinct indices): triangle 1–2–3 with vertex 3 on vertex 2,
    // glued to the regular triangle along edge 1–2.
    let mut v = base.clone();
    v.push(base[2]);
    let (image, grads) = render_and_grad_2d(v, vec![[0, 1, 2], [1, 2, 3]], 24, 24);
    assert_eq!(image, alone_image);
    assert!(close(&grads[..3], &alone), "{grads:?} vs {alone:?}");
    assert_eq!(grads[3], Vec2::ZERO);
    // (b) A repeated index: triangle 1–2–2.
    let (image, grads) = render_and_grad_2d(base.clone(), vec![[0, 1, 2], [1, 2, 2]], 24, 24);
    assert_eq!(image, alone_image);
    assert!(close(&grads, &alone));
    // (c) Alone, all three vertices at one point, and a repeated index in 3D.
    let (image, grads) = render_and_grad_2d(vec![Vec2::splat(5.5); 3], vec![[0, 1, 2]], 12, 12);
    assert!(image.data().iter().all(|&v| v == 0.0) && grads.iter().all(|g| *g == Vec2::ZERO));
    let mesh = Mesh::new(vec![Vec3::ZERO, Vec3::X * 0.5], vec![[0, 1, 1], [0, 0, 0]]).unwrap();
    let mut r = renderer();
    let frame = r.render(&mesh, &[camera(16, 16)]).unwrap();
    let g = r.backward(&frame, &ones(&frame)).unwrap();
    assert!(frame.images()[0].data().iter().all(|&v| v == 0.0));
    assert!(g.iter().all(|g| *g == Vec3::ZERO));
}

#[test]
fn duplicate_triangles_change_nothing() {
    let s = scenes::triangle();
    let (alone_image, alone) = render_and_grad_2d(s.vertices.clone(), vec![[0, 1, 2]], 24, 24);
    for triangles in [vec![[0, 1, 2], [0, 1, 2]], vec![[0, 1, 2], [2, 1, 0], [1, 2, 0]]] {
        let (image, grads) = render_and_grad_2d(s.vertices.clone(), triangles.clone(), 24, 24);
        assert_eq!(image, alone_image, "{triangles:?}");
        assert!(close(&grads, &alone), "{triangles:?}: {grads:?} vs {alone:?}");
    }
    // A closed mesh with every face listed twice.
    let sphere = diffsil::shapes::icosphere(1);
    let doubled: Vec<[u32; 3]> = sphere.triangles().iter().flat_map(|&t| [t, [t[0], t[2], t[1]]]).collect();
    let twice = Mesh::new(sphere.positions().to_vec(), doubled).unwrap();
    let mut r = renderer();
    let (f1, f2) = (r.render(&sphere, &[camera(24, 24)]).unwrap(), r.render(&twice, &[camera(24, 24)]).unwrap());
    assert_eq!(f1.images(), f2.images());
    let mut rng = crate::common::fd::Rng::new(3);
    let w = vec![Image::from_vec(24, 24, rng.weights(576)).unwrap()];
    let (g1, g2) = (r.backward(&f1, &w).unwrap(), r.backward(&f2, &w).unwrap());
    assert!(g1.iter().zip(&g2).all(|(a, b)| (*a - *b).length() <= 1e-5 * (1.0 + a.length())));
    assert!(g1.iter().any(|g| *g != Vec3::ZERO));
}

#[test]
fn vertex_behind_the_camera_clips_its_triangles() {
    let sphere = diffsil::shapes::icosphere(2);
    let cam = Camera::perspective(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 0.9, 32, 32);
    // Pull vertex 0 far behind the eye: its triangles cross the near plane and are drawn clipped
    // (tests/cpu/clip.rs checks such images and gradients against the exact-area oracle).
    let mut positions = sphere.positions().to_vec();
    positions[0] = Vec3::new(0.3, 0.2, 5.0);
    let mesh = Mesh::with_topology(positions.clone(), sphere.topology().clone()).unwrap();
    let incident = mesh.triangles().iter().filter(|t| t.contains(&0)).count() as u32;
    let mut r = renderer();
    let frame = r.render(&mesh, &[cam]).unwrap();
    assert_eq!((frame.stats()[0].clipped_triangles, frame.stats()[0].culled_triangles), (incident, 0));
    let mut rng = crate::common::fd::Rng::new(9);
    let w = vec![Image::from_vec(32, 32, rng.weights(1024)).unwrap()];
    let grads = r.backward(&frame, &w).unwrap();
    assert!(frame.images()[0].data().iter().all(|v| v.is_finite()));
    assert!(grads.iter().all(|g| g.is_finite()));
    assert_ne!(grads[0], Vec3::ZERO, "the vertex behind moves its clipped triangles");
    assert!(frame.images()[0].data().contains(&1.0), "the rest of the mesh must still render");
    // The eye inside the mesh (every triangle has some vertex behind it or not): no NaN either.
    let inside = Camera::perspective(Vec3::new(0.1, 0.0, 0.2), Vec3::new(0.0, 0.0, -1.0), 1.2, 16, 16);
    let frame = r.render(&sphere, &[inside]).unwrap();
    let grads = r.backward(&frame, &ones(&frame)).unwrap();
    assert!(frame.images()[0].data().iter().all(|v| v.is_finite()) && grads.iter().all(|g| g.is_finite()));
    // A screen vertex beyond the coordinate limit is culled the same way.
    let s = scenes::quad();
    let mut vertices = s.vertices.clone();
    vertices[1] = Vec2::new(1.0e7, 3.0);
    let frame = r.render_screen(&s.topology(), &[s.view_with(vertices)]).unwrap();
    assert_eq!(frame.stats()[0].culled_triangles, 1);
    let g = r.backward_screen(&frame, &ones(&frame)).unwrap();
    assert!(g[0].iter().all(|g| g.is_finite()) && g[0][1] == Vec2::ZERO);
}

#[test]
fn empty_mesh_renders_empty_image_and_zero_gradient() {
    let settings = RenderSettings { supersample: 4, inside: 1.0, outside: 0.25 };
    let mut r = Renderer::new(settings).unwrap();
    for mesh in [Mesh::new(vec![], vec![]).unwrap(), Mesh::new(vec![Vec3::ZERO, Vec3::X], vec![]).unwrap()] {
        let frame = r.render(&mesh, &[camera(16, 12)]).unwrap();
        assert!(frame.images()[0].data().iter().all(|&v| v == 0.25), "empty image is the outside value");
        assert_eq!(frame.stats()[0].culled_triangles, 0);
        let g = r.backward(&frame, &ones(&frame)).unwrap();
        assert_eq!(g.len(), mesh.positions().len());
        assert!(g.iter().all(|g| *g == Vec3::ZERO));
    }
    let empty = Arc::new(Topology::new(0, vec![]).unwrap());
    let frame = r.render_screen(&empty, &[ScreenView { vertices: vec![], width: 5, height: 7 }]).unwrap();
    assert!(frame.images()[0].data().iter().all(|&v| v == 0.25));
    assert_eq!(r.backward_screen(&frame, &ones(&frame)).unwrap(), vec![Vec::<Vec2>::new()]);
}

#[test]
fn resolution_zero_is_an_error() {
    let mesh = tri_mesh();
    for (w, h) in [(0, 16), (16, 0), (0, 0)] {
        let err = renderer().render(&mesh, &[camera(w, h)]).expect_err("error");
        assert!(matches!(err, Error::InvalidResolution { .. }), "{w}x{h}: {err}");
        let view = ScreenView { vertices: vec![Vec2::ZERO; 3], width: w, height: h };
        let err = renderer().render_screen(mesh.topology(), &[view]).expect_err("error");
        assert!(matches!(err, Error::InvalidResolution { .. }), "{w}x{h}: {err}");
    }
}

#[test]
fn resolution_too_large_is_an_error() {
    let mesh = tri_mesh();
    for (w, h) in [(100_000, 16), (16, 100_000), (u32::MAX, u32::MAX)] {
        let err = renderer().render(&mesh, &[camera(w, h)]).expect_err("error");
        assert!(matches!(err, Error::InvalidResolution { .. }), "{w}x{h}: {err}");
        let view = ScreenView { vertices: vec![Vec2::ZERO; 3], width: w, height: h };
        let err = renderer().render_screen(mesh.topology(), &[view]).expect_err("error");
        assert!(matches!(err, Error::InvalidResolution { .. }), "{w}x{h}: {err}");
    }
}

#[test]
fn supersample_zero_is_an_error() {
    let err = Renderer::new(RenderSettings { supersample: 0, ..RenderSettings::default() }).expect_err("error");
    assert!(matches!(err, Error::InvalidSupersample(0)), "{err}");
}

#[test]
fn supersample_seventeen_is_an_error() {
    let err = Renderer::new(RenderSettings { supersample: 17, ..RenderSettings::default() }).expect_err("error");
    assert!(matches!(err, Error::InvalidSupersample(17)), "{err}");
    assert!(Renderer::new(RenderSettings { supersample: 16, ..RenderSettings::default() }).is_ok());
}

#[test]
fn non_finite_pixel_values_are_an_error() {
    for (inside, outside) in [(f32::NAN, 0.0), (1.0, f32::INFINITY)] {
        let err = Renderer::new(RenderSettings { supersample: 4, inside, outside }).expect_err("error");
        assert!(matches!(err, Error::InvalidSettings(_)), "{err}");
    }
}

#[test]
fn target_size_mismatch_is_an_error() {
    let mut r = renderer();
    let frame = r.render(&tri_mesh(), &[camera(32, 24)]).unwrap();
    let image = &frame.images()[0];
    for target in [Image::filled(24, 32, 0.0), Image::filled(32, 23, 0.0), Image::filled(0, 0, 0.0)] {
        let err = loss::squared_error(image, &target).unwrap_err();
        assert!(matches!(err, Error::SizeMismatch { expected_width: 32, expected_height: 24, .. }), "{err}");
        assert!(matches!(loss::soft_iou(image, &target), Err(Error::SizeMismatch { .. })));
    }
    let ok = loss::squared_error(image, &Image::filled(32, 24, 0.0)).unwrap();
    assert!(ok.value.is_finite() && ok.grad.data().iter().all(|g| g.is_finite()));
}

#[test]
fn gradient_image_size_mismatch_is_an_error() {
    let mut r = renderer();
    let frame = r.render(&tri_mesh(), &[camera(32, 24)]).unwrap();
    for bad in [Image::filled(24, 32, 1.0), Image::filled(32, 25, 1.0)] {
        let err = r.backward(&frame, std::slice::from_ref(&bad)).unwrap_err();
        assert!(matches!(err, Error::SizeMismatch { expected_width: 32, expected_height: 24, .. }), "{err}");
        assert!(matches!(r.backward_screen(&frame, &[bad]), Err(Error::SizeMismatch { .. })));
    }
}

#[test]
fn wrong_number_of_gradient_images_is_an_error() {
    let mut r = renderer();
    let frame = r.render(&tri_mesh(), &[camera(16, 16), camera(8, 12)]).unwrap();
    for count in [0, 1, 3] {
        let d: Vec<Image> = (0..count).map(|_| Image::filled(16, 16, 1.0)).collect();
        let err = r.backward(&frame, &d).unwrap_err();
        assert!(matches!(err, Error::ViewCountMismatch { views: 2, .. }), "{count}: {err}");
        assert!(matches!(r.backward_screen(&frame, &d), Err(Error::ViewCountMismatch { .. })));
    }
    // One per view, each of its own size, is fine.
    assert!(r.backward(&frame, &ones(&frame)).is_ok());
}

#[test]
fn non_finite_gradient_image_is_an_error() {
    let mut r = renderer();
    let frame = r.render(&tri_mesh(), &[camera(16, 16)]).unwrap();
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let mut d = Image::filled(16, 16, 0.5);
        d.data_mut()[37] = bad;
        assert!(r.backward(&frame, std::slice::from_ref(&d)).is_err(), "{bad} accepted");
        assert!(r.backward_screen(&frame, &[d]).is_err(), "{bad} accepted");
    }
    // A NaN in the image or target of a loss is an error too.
    let mut img = Image::filled(4, 4, 0.0);
    img.data_mut()[3] = f32::NAN;
    assert!(loss::squared_error(&img, &Image::filled(4, 4, 0.0)).is_err());
    assert!(loss::squared_error(&Image::filled(4, 4, 0.0), &img).is_err());
}

#[test]
fn screen_view_vertex_count_mismatch_is_an_error() {
    let topology = tri_mesh().topology().clone();
    let view = ScreenView { vertices: vec![Vec2::ZERO; 2], width: 8, height: 8 };
    assert!(matches!(
        renderer().render_screen(&topology, &[view]),
        Err(Error::LengthMismatch { expected: 3, got: 2, .. })
    ));
}

#[test]
fn backward_of_a_screen_frame_is_an_error() {
    let s = scenes::triangle();
    let mut r = renderer();
    let frame = r.render_screen(&s.topology(), &[s.view()]).unwrap();
    assert!(matches!(r.backward(&frame, &ones(&frame)), Err(Error::InvalidFrame(_))));
}

#[test]
fn invalid_cameras_are_errors() {
    let mesh = tri_mesh();
    let mut cams = vec![
        Camera::perspective(Vec3::ONE, Vec3::ONE, 0.9, 8, 8), // eye == target
        Camera::perspective(Vec3::Z * 3.0, Vec3::ZERO, 0.0, 8, 8), // fov 0
        Camera::perspective(Vec3::Z * 3.0, Vec3::ZERO, f32::NAN, 8, 8), // fov NaN
        Camera::orthographic(Vec3::Z * 3.0, Vec3::ZERO, -1.0, 8, 8), // negative height
        Camera::perspective(Vec3::new(0.0, f32::NAN, 3.0), Vec3::ZERO, 0.9, 8, 8),
    ];
    let mut up = camera(8, 8);
    up.up = Vec3::new(0.2, 0.1, 3.0); // parallel to the viewing direction
    cams.push(up);
    let mut near = camera(8, 8);
    near.near = 0.0; // perspective needs near > 0
    cams.push(near);
    for (k, cam) in cams.iter().enumerate() {
        let err = renderer().render(&mesh, &[*cam]).err().unwrap_or_else(|| panic!("camera {k} accepted"));
        assert!(matches!(err, Error::InvalidCamera(_)), "camera {k}: {err}");
    }
}

// ---------------------------------------------------------------------------------------------
// Extreme but finite values (issue 13): an error naming the value and the fix, or a finite result.

/// The message of an `Err`, checked to mention every word.
fn error_mentions<T: std::fmt::Debug>(result: diffsil::Result<T>, words: &[&str]) -> String {
    let message = match result {
        Err(e) => e.to_string(),
        Ok(v) => panic!("expected an error mentioning {words:?}, got {v:?}"),
    };
    for word in words {
        assert!(message.contains(word), "`{message}` should mention `{word}`");
    }
    message
}

#[test]
fn a_render_above_the_memory_budget_is_an_error_naming_size_and_limit() {
    let s = scenes::triangle();
    let settings = RenderSettings { supersample: 16, ..RenderSettings::default() };
    let mut r = Renderer::new(settings).unwrap();
    let view = ScreenView { vertices: s.vertices.clone(), width: 16384, height: 16384 };
    let needed = diffsil::frame_bytes(16384, 16384, 16);
    assert!(needed > diffsil::MAX_FRAME_BYTES);
    let message = error_mentions(
        r.render_screen(&s.topology(), &[view]),
        &["16384x16384", "F = 16", &needed.to_string(), &diffsil::MAX_FRAME_BYTES.to_string(), "lower the resolution"],
    );
    println!("{message}");
    // The same through cameras, and summed over views: 3 views of 8192² at F = 16 (2.25 GiB each).
    let mut cams = vec![camera(8192, 8192); 3];
    error_mentions(r.render(&tri_mesh(), &cams), &["3 view(s)", "8192x8192", "GiB"]);
    cams.truncate(1);
    cams[0] = camera(64, 64);
    assert!(r.render(&tri_mesh(), &cams).is_ok(), "a small render still works");
}

#[test]
fn extreme_pixel_values_are_rejected_with_the_setting_named() {
    let s = scenes::triangle();
    for (inside, outside, name) in [(f32::MAX, 0.0, "inside"), (1.0, -3e38, "outside"), (2e18, 0.0, "inside")] {
        let settings = RenderSettings { inside, outside, ..RenderSettings::default() };
        error_mentions(settings.validate(), &[&format!("RenderSettings::{name}"), "1e18", "use e.g. 1 and 0"]);
        error_mentions(Renderer::new(settings), &[&format!("RenderSettings::{name}"), "1e18"]);
    }
    // At the limit everything stays finite, even with ∂L/∂I of 1e18.
    let mut r = Renderer::new(RenderSettings { inside: 1e18, outside: -1e18, ..RenderSettings::default() }).unwrap();
    let frame = r.render_screen(&s.topology(), &[s.view()]).unwrap();
    assert!(frame.images()[0].data().iter().all(|v| v.is_finite()));
    let d: Vec<Image> = frame.images().iter().map(|i| Image::filled(i.width(), i.height(), 1e18)).collect();
    match r.backward_screen(&frame, &d) {
        Ok(g) => assert!(g[0].iter().all(|g| g.is_finite())),
        Err(e) => assert!(e.to_string().contains("overflowed f32") && e.to_string().contains("vertex"), "{e}"),
    }
}

#[test]
fn overflowing_gradients_are_errors_not_infinities() {
    let s = scenes::triangle();
    let mut r = renderer();
    let frame = r.render_screen(&s.topology(), &[s.view()]).unwrap();
    // ∂L/∂I of 1e38 on every pixel: each vertex gradient sums far beyond f32.
    let d: Vec<Image> = frame.images().iter().map(|i| Image::filled(i.width(), i.height(), 1e38)).collect();
    let message = error_mentions(r.backward_screen(&frame, &d), &["overflowed f32", "view 0", "scale them down"]);
    println!("{message}");
    // Sub-1e-37 geometry in front of a perspective camera: nothing non-finite comes back as Ok.
    let tiny = Mesh::new(
        vec![Vec3::new(-1e-38, -1e-38, 2.9), Vec3::new(1e-38, 0.0, 2.9), Vec3::new(0.0, 1e-38, 2.9)],
        vec![[0, 1, 2]],
    )
    .unwrap();
    let frame = r.render(&tiny, &[camera(16, 16)]).unwrap();
    assert!(frame.images()[0].data().iter().all(|v| v.is_finite()));
    if let Ok(g) = r.backward(&frame, &ones(&frame)) {
        assert!(g.iter().all(|g| g.is_finite()), "{g:?}");
    }
}

#[test]
fn squared_error_of_huge_targets_is_an_error_naming_the_pixel() {
    let image = Image::filled(2, 2, 0.0);
    let mut target = Image::filled(2, 2, 0.0);
    target.data_mut()[3] = -3e38;
    error_mentions(loss::squared_error(&image, &target), &["squared error", "pixel 3", "within ±1e18"]);
    let mut image = Image::filled(2, 2, 0.0);
    image.data_mut()[1] = 3e38;
    error_mentions(loss::squared_error(&image, &target), &["pixel 1"]);
    // Large but representable differences stay finite.
    target.data_mut()[3] = -1e18;
    let ok = loss::squared_error(&Image::filled(2, 2, 0.0), &target).unwrap();
    assert!(ok.value.is_finite() && ok.grad.data().iter().all(|g| g.is_finite()));
}

#[test]
fn extreme_cameras_are_errors_that_say_what_is_wrong() {
    let mesh = tri_mesh();
    let mut r = renderer();
    // A huge `up` is a direction like any other… up to a length whose cross product f32 cannot
    // normalise: that is refused with its length, not rendered as an empty image.
    let mut cam = camera(8, 8);
    cam.up = Vec3::new(0.0, 1e6, 0.0);
    assert!(r.render(&mesh, &[cam]).unwrap().images()[0].data().iter().any(|&v| v > 0.0));
    cam.up = Vec3::new(0.0, 1e30, 0.0);
    error_mentions(r.render(&mesh, &[cam]), &["`up` has length 1e30", "(0, 1, 0)"]);
    cam.up = Vec3::new(0.0, 1e-30, 0.0);
    error_mentions(r.render(&mesh, &[cam]), &["`up` has length"]);
    // An eye farther than ~1.8e19 overflowed `|target − eye|²` and was reported as `up` parallel.
    for far in [2e19f32, 3e38] {
        let cam = Camera::perspective(Vec3::new(0.0, 0.0, far), Vec3::ZERO, 0.9, 8, 8);
        let message =
            error_mentions(r.render(&mesh, &[cam]), &["eye or target", "beyond ±1e18", "closer to the origin"]);
        assert!(!message.contains("parallel"), "{message}");
    }
}

#[test]
fn out_of_range_indices_have_checked_variants() {
    let image = Image::from_vec(3, 2, (0..6).map(|v| v as f32).collect()).unwrap();
    assert_eq!(image.checked_get(1, 2), Some(5.0));
    assert_eq!(image.get(1, 2), 5.0);
    // Column 3 of row 0 would be pixel (1, 0) in the row-major data: not a pixel of row 0.
    assert_eq!(image.checked_get(0, 3), None);
    assert_eq!(image.checked_get(2, 0), None);
    let caught = std::panic::catch_unwind(|| image.get(0, 3)).unwrap_err();
    let text = caught.downcast_ref::<String>().cloned().unwrap_or_default();
    assert!(text.contains("(row 0, column 3)") && text.contains("3x2"), "{text}");

    let topology = tri_mesh().topology().clone();
    assert_eq!(topology.checked_edge_faces(0), Some(&[0u32][..]));
    assert_eq!(topology.checked_edge_faces(3), None);
    assert_eq!(topology.checked_edge_faces(usize::MAX), None);
    let mut r = renderer();
    let frame = r.render(&tri_mesh(), &[camera(8, 8)]).unwrap();
    assert!(frame.screen_vertices(0).is_some());
    assert_eq!(frame.screen_vertices(1), None);
}

#[test]
fn adam_rejects_bad_learning_rates_and_survives_huge_ones() {
    use diffsil::optim::Adam;
    for lr in [f32::NAN, f32::INFINITY, -0.5, 0.0] {
        let mut params = vec![0.5f32; 3];
        error_mentions(Adam::new(lr).step(&mut params, &[1.0; 3]), &["learning_rate", "finite number > 0"]);
        assert_eq!(params, [0.5; 3], "a rejected step must not move the parameters");
    }
    let mut params = vec![0.5f32; 3];
    let mut adam = Adam::new(1e30);
    for _ in 0..10 {
        adam.step(&mut params, &[1e38, -1e38, 1e-38]).unwrap();
    }
    assert!(params.iter().all(|p| p.is_finite()), "{params:?}");
}
