//! `project` — CPU twin of `shaders/project.wgsl`: 3D vertices → screen vertices for one view.

use glam::Vec3;
use rayon::prelude::*;

use crate::mirror::ViewParams;
use crate::mirror::{RasterParams, ScreenVertex};

/// Projects every vertex with `view`; clipped vertices get `valid = 0` and position zero.
/// Reads `positions`, writes `screen` (same length).
pub fn project(view: &ViewParams, positions: &[Vec3], screen: &mut [ScreenVertex]) {
    screen.par_iter_mut().with_min_len(4096).zip(positions.par_iter()).for_each(|(out, &p)| {
        let (position, valid) = view.project(p);
        *out = ScreenVertex { position: position.to_array(), valid: valid as u32, pad: 0 };
    });
}

/// Snaps every screen vertex to the fixed-point grid of `params` (the `snap` step that ends
/// `shaders/project.wgsl`); clipped vertices become [`INVALID_SNAPPED_VERTEX`](crate::mirror::INVALID_SNAPPED_VERTEX).
/// Reads `screen`, writes `snapped` (same length).
pub fn snap(params: &RasterParams, screen: &[ScreenVertex], snapped: &mut [[i32; 2]]) {
    snapped.par_iter_mut().with_min_len(4096).zip(screen.par_iter()).for_each(|(out, v)| {
        *out = params.snap_vertex(v);
    });
}

/// [`project`] then [`snap`] in one pass (what `shaders/project.wgsl` does): fills `screen` and
/// `snapped` (resized to the number of positions) for one view.
pub fn project_and_snap(
    view: &ViewParams,
    params: &RasterParams,
    positions: &[Vec3],
    screen: &mut Vec<ScreenVertex>,
    snapped: &mut Vec<[i32; 2]>,
) {
    positions
        .par_iter()
        .with_min_len(4096)
        .map(|&p| {
            let (position, valid) = view.project(p);
            let s = ScreenVertex { position: position.to_array(), valid: valid as u32, pad: 0 };
            (s, params.snap_vertex(&s))
        })
        .unzip_into_vecs(screen, snapped);
}
