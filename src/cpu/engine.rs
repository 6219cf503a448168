//! The CPU engine: the stages of this module behind the [`Engine`] interface.

use std::any::Any;
use std::sync::{Arc, Mutex};

use glam::Vec2;
use rayon::prelude::*;

use super::project;
use super::view::{backward_view, render_view, BackwardScratch, ViewState};
use crate::engine::{BackwardStats, Engine, FrameRef, FrameState, RenderStats, Rendered, ViewInput};
use crate::mirror::RasterParams;
use crate::scene::mesh::Topology;
use crate::{Error, Image, Result};

/// The CPU engine: Rust, parallel with rayon across views and inside each stage.
///
/// It keeps the view states of the frames it rendered once they are dropped (a fit loop drops
/// each step's frame before the next), and the next forward fills those buffers again instead
/// of allocating new ones: in a loop of steps of the same mesh and image sizes, a forward
/// allocates only the images it returns.
#[derive(Clone, Debug, Default)]
pub struct CpuEngine {
    /// View states of dropped frames, for reuse.
    spare: Arc<Mutex<Vec<ViewState>>>,
    /// Sample-mask buffers of earlier forwards (a frame does not keep its masks: the backward
    /// does not read them).
    spare_masks: Vec<Vec<u32>>,
    /// The backward's buffers, one per view of the largest backward so far (at most
    /// `MAX_SPARE_VIEWS`).
    backward_scratch: Vec<BackwardScratch>,
}

/// Most view states [`CpuEngine`] keeps for reuse.
const MAX_SPARE_VIEWS: usize = 64;

/// What a CPU forward keeps: every view's state, and where to give the states back.
struct CpuFrame {
    views: Vec<ViewState>,
    spare: Arc<Mutex<Vec<ViewState>>>,
}

impl Drop for CpuFrame {
    fn drop(&mut self) {
        // A poisoned lock only loses the reuse.
        if let Ok(mut spare) = self.spare.lock() {
            let room = MAX_SPARE_VIEWS.saturating_sub(spare.len());
            spare.extend(self.views.drain(..).take(room));
        }
    }
}

impl FrameState for CpuFrame {
    fn as_any(&self) -> &dyn Any {
        self
    }

    fn screen_vertices(&self, view: usize) -> Option<Vec<Vec2>> {
        self.views.get(view).map(|v| v.screen.iter().map(|s| Vec2::from(s.position)).collect())
    }
}

impl CpuEngine {
    /// `count` view states to fill: kept ones first, then new ones.
    fn take_states(&self, count: usize) -> Vec<ViewState> {
        let mut states = match self.spare.lock() {
            Ok(mut spare) => {
                let keep = spare.len().saturating_sub(count);
                spare.split_off(keep)
            }
            Err(_) => Vec::new(),
        };
        states.resize_with(count, ViewState::default);
        states
    }
}

impl Engine for CpuEngine {
    fn describe(&self) -> String {
        "cpu".into()
    }

    fn uses_thread_pool(&self) -> bool {
        true
    }

    fn forward(&mut self, topology: &Arc<Topology>, params: &[RasterParams], input: ViewInput<'_>) -> Result<Rendered> {
        // The views are independent: they run side by side (each parallel inside too), and come
        // back in order.
        let render_one = |(k, mut state): (usize, ViewState)| {
            let params = params[k];
            match input {
                ViewInput::World { positions, cameras } => {
                    project::project_and_snap(&cameras[k], &params, positions, &mut state.screen, &mut state.snapped);
                }
                ViewInput::Screen(screens) => {
                    state.screen.clear();
                    state.screen.extend_from_slice(&screens[k]);
                    state.snapped.resize(state.screen.len(), [0; 2]);
                    project::snap(&params, &state.screen, &mut state.snapped);
                }
            }
            let image = render_view(params, &mut state, topology);
            (state, Image::from_vec(params.width, params.height, image).expect("image sized by the raster"))
        };
        let mut states = self.take_states(params.len());
        for state in &mut states {
            state.masks = self.spare_masks.pop().unwrap_or_default();
        }
        let mut rendered: Vec<(ViewState, Image)> = states.into_par_iter().enumerate().map(render_one).collect();
        self.spare_masks.extend(rendered.iter_mut().map(|(state, _)| std::mem::take(&mut state.masks)));
        self.spare_masks.truncate(MAX_SPARE_VIEWS);
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
        Ok(Rendered { images, stats, state: Box::new(CpuFrame { views, spare: self.spare.clone() }) })
    }

    fn backward(&mut self, frame: FrameRef<'_>, d_images: &[&[f32]]) -> Result<(Vec<Vec<Vec2>>, Vec<BackwardStats>)> {
        let Some(CpuFrame { views, .. }) = frame.state.as_any().downcast_ref::<CpuFrame>() else {
            return Err(Error::InvalidFrame(
                "this frame was rendered by the GPU engine, but this renderer runs on the CPU engine: \
                 differentiate a frame with a renderer on the engine that rendered it"
                    .into(),
            ));
        };
        // Views side by side, as in the forward, each with buffers of an earlier backward (at
        // most MAX_SPARE_VIEWS of them are kept).
        let scratch = &mut self.backward_scratch;
        if scratch.len() < views.len() {
            scratch.resize_with(views.len(), BackwardScratch::default);
        }
        let result = views
            .par_iter()
            .zip(d_images)
            .zip(scratch.par_iter_mut())
            .map(|((state, d_image), scratch)| backward_view(state, frame.topology, d_image, scratch))
            .unzip();
        scratch.truncate(MAX_SPARE_VIEWS);
        Ok(result)
    }
}
