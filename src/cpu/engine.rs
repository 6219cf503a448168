//! The CPU engine: the stages of this module behind the [`Engine`] interface.

use std::any::Any;
use std::sync::Arc;

use glam::Vec2;
use rayon::prelude::*;

use super::project;
use super::view::{backward_view, forward_view, ViewState};
use crate::engine::{BackwardStats, Engine, FrameRef, FrameState, RenderStats, Rendered, ViewInput};
use crate::mirror::RasterParams;
use crate::scene::mesh::Topology;
use crate::{Error, Image, Result};

/// The CPU engine: Rust, parallel with rayon across views and inside each stage.
#[derive(Clone, Copy, Debug, Default)]
pub struct CpuEngine;

/// What a CPU forward keeps: every view's state.
struct CpuFrame(Vec<ViewState>);

impl FrameState for CpuFrame {
    fn as_any(&self) -> &dyn Any {
        self
    }

    fn screen_vertices(&self, view: usize) -> Option<Vec<Vec2>> {
        self.0.get(view).map(|v| v.screen.iter().map(|s| Vec2::from(s.position)).collect())
    }
}

impl Engine for CpuEngine {
    fn describe(&self) -> String {
        "cpu".into()
    }

    fn forward(&mut self, topology: &Arc<Topology>, params: &[RasterParams], input: ViewInput<'_>) -> Result<Rendered> {
        // The views are independent: they run side by side (each parallel inside too), and come
        // back in order.
        let render_one = |k: usize| {
            let params = params[k];
            let (screen, snapped) = match input {
                ViewInput::World { positions, cameras } => {
                    let (mut screen, mut snapped) = (Vec::new(), Vec::new());
                    project::project_and_snap(&cameras[k], &params, positions, &mut screen, &mut snapped);
                    (screen, snapped)
                }
                ViewInput::Screen(screens) => {
                    let screen = screens[k].clone();
                    let mut snapped = vec![[0; 2]; screen.len()];
                    project::snap(&params, &screen, &mut snapped);
                    (screen, snapped)
                }
            };
            let (state, image) = forward_view(params, screen, snapped, topology);
            (state, Image::from_vec(params.width, params.height, image).expect("image sized by the raster"))
        };
        let rendered: Vec<(ViewState, Image)> = (0..params.len()).into_par_iter().map(render_one).collect();
        let stats = rendered
            .iter()
            .map(|(state, _)| RenderStats {
                culled_triangles: state.culled_triangles,
                candidate_edges: state.candidates.len() as u32,
                tile_size: state.params.tile_size,
                clipped_triangles: 0, // clipping runs before the engine (render/clip.rs)
            })
            .collect();
        let (views, images) = rendered.into_iter().unzip();
        Ok(Rendered { images, stats, state: Box::new(CpuFrame(views)) })
    }

    fn backward(&mut self, frame: FrameRef<'_>, d_images: &[&[f32]]) -> Result<(Vec<Vec<Vec2>>, Vec<BackwardStats>)> {
        let Some(CpuFrame(views)) = frame.state.as_any().downcast_ref::<CpuFrame>() else {
            return Err(Error::InvalidFrame(
                "this frame was rendered by the GPU engine, but this renderer runs on the CPU engine: \
                 differentiate a frame with a renderer on the engine that rendered it"
                    .into(),
            ));
        };
        // Views side by side, as in the forward.
        Ok(views.par_iter().zip(d_images).map(|(state, d_image)| backward_view(state, frame.topology, d_image)).unzip())
    }
}
