//! Running a renderer's call from inside rayon's thread pool.
//!
//! The CPU engine's stages split their loops over rayon's pool. Called from a thread outside the
//! pool (a program's main thread), every such loop hands its work to the pool and puts the
//! calling thread to sleep until it is done: two thread wake-ups per stage, about ten stages per
//! step, which on two cores cost 5–7% of a step of the bunny from 16² to 256². So the renderer moves each
//! call into the pool once, and the stages then start their loops from a thread of the pool.
//! From a thread of a pool already (a rayon task, or [`rayon::ThreadPool::install`]), the call
//! runs where it is, in that pool. The GPU engine's calls run where they are called.

use super::Renderer;

impl Renderer {
    /// Runs `op` with this renderer on a thread of rayon's pool when the engine runs its stages
    /// there and the calling thread is not one of a pool; otherwise on the calling thread.
    pub(super) fn on_pool<R: Send>(&mut self, op: impl FnOnce(&mut Renderer) -> R + Send) -> R {
        if self.engine.uses_thread_pool() && rayon::current_thread_index().is_none() {
            rayon::scope(|_| op(self))
        } else {
            op(self)
        }
    }
}

#[cfg(test)]
mod tests {
    use std::thread::{self, ThreadId};

    use crate::{RenderSettings, Renderer};

    /// The thread that runs a call of `renderer`, and its index in its pool if it has one.
    fn thread_of_call(renderer: &mut Renderer) -> (ThreadId, Option<usize>) {
        renderer.on_pool(|_| (thread::current().id(), rayon::current_thread_index()))
    }

    #[test]
    fn cpu_calls_from_outside_the_pool_run_on_it() {
        let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
        assert_eq!(rayon::current_thread_index(), None, "the test harness's thread is not a pool's");
        let (thread, index) = thread_of_call(&mut renderer);
        assert_ne!(thread, thread::current().id());
        assert!(index.is_some());
    }

    #[test]
    fn cpu_calls_from_a_pool_run_where_they_are() {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
        let (caller, call) = pool.install(|| (thread::current().id(), thread_of_call(&mut renderer)));
        assert_eq!(call.0, caller);
    }
}
