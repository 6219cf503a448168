//! Golden hashes: the bits of images, gradients, losses and fitted poses on the test scenes,
//! recorded before the redesign (#10) and compared after it. Any change to the arithmetic of a
//! stage changes a hash. `DIFFSIL_GOLDEN_PRINT=1` prints the table instead of comparing.
//!
//! Here: CPU half (the GPU half is in `tests/gpu`, the pose fit in `tests/pose`); the shared machinery is `common::golden`.

use crate::common::golden::{compare, hashes};
use diffsil::{RenderSettings, Renderer};

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
#[test]
fn cpu_outputs_match_the_golden_hashes() {
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    compare("CPU", &hashes(&mut renderer), CPU);
}
