//! The views of a call, validated: cameras into projection and raster constants, screen-space
//! views into screen vertices, and the chain from screen gradients back to 3D.

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::RenderSettings;
use crate::mirror::{RasterParams, ScreenVertex, ViewParams, COORD_LIMIT};
use crate::scene::mesh::Topology;
use crate::{Camera, Error, Result, ScreenView};

/// Raster constants for a `width × height` view with these settings.
pub(super) fn raster_params(settings: &RenderSettings, width: u32, height: u32) -> Result<RasterParams> {
    settings.validate()?;
    RasterParams::new(width, height, settings.supersample, settings.inside, settings.outside)
}

/// Each camera's projection constants and raster parameters, validated.
pub(super) fn world_views(
    settings: &RenderSettings,
    cameras: &[Camera],
) -> Result<(Vec<ViewParams>, Vec<RasterParams>)> {
    let mut views = Vec::with_capacity(cameras.len());
    let mut params = Vec::with_capacity(cameras.len());
    for camera in cameras {
        camera.validate()?;
        views.push(camera.params());
        params.push(raster_params(settings, camera.width, camera.height)?);
    }
    super::settings::check_frame_memory(&params)?;
    Ok((views, params))
}

/// Each screen-space view's raster parameters and screen vertices, validated: one finite vertex
/// per topology vertex; vertices beyond [`COORD_LIMIT`] are marked invalid (their triangles are
/// culled).
pub(super) fn screen_views(
    settings: &RenderSettings,
    topology: &Topology,
    views: &[ScreenView],
) -> Result<(Vec<RasterParams>, Vec<Vec<ScreenVertex>>)> {
    let mut params = Vec::with_capacity(views.len());
    let mut screens = Vec::with_capacity(views.len());
    for view in views {
        params.push(raster_params(settings, view.width, view.height)?);
        if view.vertices.len() != topology.vertex_count() {
            return Err(Error::LengthMismatch {
                what: "screen vertices",
                expected: topology.vertex_count(),
                got: view.vertices.len(),
            });
        }
        if let Some(vertex) = view.vertices.iter().position(|v| !v.is_finite()) {
            let v = view.vertices[vertex];
            return Err(Error::NonFiniteVertex { vertex, value: [v.x, v.y, 0.0] });
        }
        let screen = view
            .vertices
            .iter()
            .map(|v| {
                let valid = v.x.abs() < COORD_LIMIT && v.y.abs() < COORD_LIMIT;
                ScreenVertex { position: if valid { v.to_array() } else { [0.0; 2] }, valid: valid as u32, pad: 0 }
            })
            .collect();
        screens.push(screen);
    }
    super::settings::check_frame_memory(&params)?;
    Ok((params, screens))
}

/// One view's gradient on its way to 3D.
pub(super) enum ViewGradient<'a> {
    /// `∂L/∂(screen vertex)`, one per mesh vertex.
    Screen(&'a [Vec2]),
    /// Already chained to `∂L/∂(3D vertex)` (a clipped view, `render/clip.rs`).
    World(Vec<Vec3>),
}

/// `∂L/∂(screen vertex)` per view → `∂L/∂(3D vertex)` through each view's projection Jacobian,
/// summed over views (in view order). The same code for both engines, so the 3D gradient is
/// bit-identical given the same 2D gradients. `what` names the call in the error returned when
/// a vertex's gradient overflows f32 (as [`check_finite_gradients`] words it); only the vertices
/// with a non-zero term are checked (the others are zero).
pub(super) fn chain_to_3d(
    what: &str,
    positions: &[Vec3],
    views: &[ViewParams],
    view_grads: &[ViewGradient<'_>],
) -> Result<Vec<Vec3>> {
    // View by view (so each vertex's terms are added in view order, the same sums whatever the
    // thread count), over chunks of vertices in parallel; a vertex without a term stays zero.
    let mut grads: Vec<Vec3> = bytemuck::zeroed_vec(positions.len());
    let mut overflowed = false;
    for (view, grad) in views.iter().zip(view_grads) {
        overflowed |= grads
            .par_chunks_mut(CHAIN_CHUNK)
            .enumerate()
            .map(|(c, chunk)| {
                let first = c * CHAIN_CHUNK;
                let mut overflowed = false;
                let mut add = |g: &mut Vec3, term: Vec3| {
                    *g += term;
                    overflowed |= !g.is_finite();
                };
                match grad {
                    ViewGradient::Screen(g2) => {
                        let g2 = &g2[first.min(g2.len())..(first + chunk.len()).min(g2.len())];
                        for_nonzero(g2, |i, &d| {
                            if d != Vec2::ZERO {
                                add(&mut chunk[i], screen_term(view, positions[first + i], d));
                            }
                        });
                    }
                    ViewGradient::World(g3) => {
                        let g3 = &g3[first.min(g3.len())..(first + chunk.len()).min(g3.len())];
                        for_nonzero(g3, |i, &d| {
                            if d != Vec3::ZERO {
                                add(&mut chunk[i], d);
                            }
                        });
                    }
                }
                overflowed
            })
            .reduce(|| false, |a, b| a | b);
    }
    if overflowed {
        check_finite_gradients(what, None, &grads, |g: Vec3| g.is_finite())?;
    }
    Ok(grads)
}

/// Calls `f(i, &items[i])` for the items of every block of [`ZERO_BLOCK`] in which one has a
/// bit set other than a sign bit (so for every non-zero item, and for some zeros beside them):
/// most of a gradient is zero, and a block of zeros is skipped in a few vector operations.
fn for_nonzero<T: bytemuck::Pod>(items: &[T], mut f: impl FnMut(usize, &T)) {
    for (b, block) in items.chunks(ZERO_BLOCK).enumerate() {
        let words: &[u32] = bytemuck::cast_slice(block);
        if words.iter().fold(0, |acc, w| acc | w << 1) == 0 {
            continue;
        }
        for (i, item) in block.iter().enumerate() {
            f(b * ZERO_BLOCK + i, item);
        }
    }
}

/// Items per block of [`for_nonzero`].
const ZERO_BLOCK: usize = 16;

/// Vertices per parallel task of [`chain_to_3d`].
const CHAIN_CHUNK: usize = 4096;

/// One view's `∂L/∂(screen vertex)` → its share of `∂L/∂(3D vertex)`: the terms
/// [`chain_to_3d`] adds for a [`ViewGradient::Screen`], computed alike.
pub(super) fn view_to_3d(view: &ViewParams, positions: &[Vec3], screen_grads: &[Vec2]) -> Vec<Vec3> {
    positions
        .par_iter()
        .with_min_len(4096)
        .enumerate()
        .map(|(v, &p)| {
            let d = screen_grads.get(v).copied().unwrap_or(Vec2::ZERO);
            if d == Vec2::ZERO {
                return Vec3::ZERO;
            }
            screen_term(view, p, d)
        })
        .collect()
}

/// The term a screen gradient `d` at vertex position `p` adds to `∂L/∂p` through the view's
/// projection Jacobian: the one expression [`chain_to_3d`] and [`view_to_3d`] share.
#[inline]
fn screen_term(view: &ViewParams, p: Vec3, d: Vec2) -> Vec3 {
    let [jx, jy] = view.jacobian(p);
    jx * d.x + jy * d.y
}

/// Each view's clipped geometry, or `None` for a view rendered as without clipping.
pub(super) fn clip_views(
    views: &[ViewParams],
    mesh: &crate::Mesh,
    cache: &mut super::clip::TopologyCache,
) -> Result<Vec<Option<super::clip::ClipView>>> {
    views.iter().map(|view| super::clip::ClipView::new(view, mesh.positions(), mesh.triangles(), cache)).collect()
}

/// [`Error::InvalidSettings`] when a gradient overflowed f32 (finite inputs can: ∂L/∂I near the f32
/// limit, or vertices at tiny depths before a perspective camera), naming the view and vertex.
pub(super) fn check_finite_gradients<T: Copy + std::fmt::Debug>(
    what: &str,
    view: Option<usize>,
    grads: &[T],
    finite: impl Fn(T) -> bool,
) -> Result<()> {
    let Some(v) = grads.iter().position(|&g| !finite(g)) else {
        return Ok(());
    };
    let in_view = view.map_or(String::new(), |k| format!(" in view {k}"));
    Err(Error::InvalidSettings(format!(
        "{what}: the gradient of vertex {v}{in_view} overflowed f32 ({:?}): ∂L/∂I, the inside/outside values or \
         the scene are too large (or vertices too close to a perspective camera); scale them down",
        grads[v]
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`for_nonzero`] visits every item that is not ±0 (subnormals, NaN and infinities
    /// included, at either end of a block and in a short last block), each with its own index,
    /// and skips the blocks that hold only zeros of either sign.
    #[test]
    fn for_nonzero_visits_every_nonzero_item_and_skips_zero_blocks() {
        let n = 7 * ZERO_BLOCK + 5;
        let mut items = vec![Vec2::ZERO; n];
        items[ZERO_BLOCK..2 * ZERO_BLOCK].fill(Vec2::splat(-0.0));
        let specials = [
            (0, Vec2::new(2.0, 0.0)),
            (3 * ZERO_BLOCK - 1, Vec2::new(0.0, f32::from_bits(1))),
            (3 * ZERO_BLOCK, Vec2::new(-0.0, f32::NAN)),
            (5 * ZERO_BLOCK + 7, Vec2::new(f32::NEG_INFINITY, -0.0)),
            (n - 1, Vec2::new(-f32::MIN_POSITIVE, 0.0)),
        ];
        for (i, v) in specials {
            items[i] = v;
        }
        let mut visited = Vec::new();
        for_nonzero(&items, |i, item| {
            assert_eq!(item.to_array().map(f32::to_bits), items[i].to_array().map(f32::to_bits), "item {i}");
            visited.push(i);
        });
        for (i, _) in specials {
            assert!(visited.contains(&i), "item {i} is not zero but was skipped");
        }
        for block in [1, 4, 6] {
            assert!(!visited.iter().any(|&i| i / ZERO_BLOCK == block), "block {block} holds only zeros");
        }
        assert!(visited.windows(2).all(|w| w[0] < w[1]), "in order, once each");
    }

    /// The chain to 3D sums each vertex's views in order, leaves vertices without a term at zero,
    /// and names the first vertex whose sum overflows f32 (only a vertex with a term can).
    #[test]
    fn chain_to_3d_sums_views_and_names_an_overflow() {
        let camera = Camera::perspective(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 0.8, 64, 64);
        let views = [camera.params(), camera.params()];
        let positions = vec![Vec3::new(0.1, 0.2, 0.3); 5000];
        let mut screen = vec![Vec2::ZERO; 5000];
        screen[4321] = Vec2::new(1.0, -2.0);
        let mut world: Vec<Vec3> = (0..5000).map(|v| Vec3::splat((v == 17) as u32 as f32)).collect();
        world[4321] = Vec3::new(0.5, 0.0, -0.25);
        let grads = [ViewGradient::Screen(&screen), ViewGradient::World(world)];
        let got = chain_to_3d("test", &positions, &views, &grads).unwrap();
        let [jx, jy] = views[0].jacobian(positions[4321]);
        assert_eq!(got[4321], Vec3::ZERO + (jx * 1.0 + jy * -2.0) + Vec3::new(0.5, 0.0, -0.25));
        assert_eq!(got[17], Vec3::ONE);
        assert_eq!(got.iter().filter(|g| **g != Vec3::ZERO).count(), 2);
        screen[4000] = Vec2::splat(f32::MAX);
        screen[4100] = Vec2::splat(f32::MAX);
        let grads = [ViewGradient::Screen(&screen), ViewGradient::Screen(&screen)];
        let e = chain_to_3d("the step", &positions, &views, &grads).unwrap_err().to_string();
        assert!(e.contains("the step") && e.contains("vertex 4000") && e.contains("overflowed f32"), "{e}");
    }
}
