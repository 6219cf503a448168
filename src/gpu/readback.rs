//! Reading results back: [`GpuContext::read_staging`] and the reusable [`Readback`].

use std::sync::mpsc;

use bytemuck::Pod;

use super::alloc::padded_size;
use super::GpuContext;
use crate::{Error, Result};

impl GpuContext {
    /// Maps the first `bytes` bytes (a multiple of 4) of `staging` after all submitted work has
    /// finished, copies them out and unmaps.
    pub fn read_staging(&self, staging: &wgpu::Buffer, bytes: u64) -> Result<Vec<u8>> {
        if bytes == 0 {
            return Ok(Vec::new());
        }
        let slice = staging.slice(..bytes);
        let (sender, receiver) = mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |result| {
            let _ = sender.send(result);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| Error::Gpu(format!("waiting for the GPU: {e}")))?;
        let mapped = receiver.recv().map_err(|_| Error::Gpu("the map callback never ran".into()))?;
        if let Err(e) = mapped {
            self.check_errors()?;
            return Err(Error::Gpu(format!("mapping a staging buffer failed: {e}")));
        }
        let data = slice.get_mapped_range().map(|view| view.to_vec());
        staging.unmap();
        self.check_errors()?;
        data.map_err(|e| Error::Gpu(format!("reading a staging buffer: {e}")))
    }
}

/// A reusable `MAP_READ` staging buffer for copying GPU buffers back to the CPU.
///
/// Keep one per output and reuse it across frames: it grows to the largest read and is
/// recreated only then.
#[derive(Debug)]
pub struct Readback {
    label: String,
    staging: Option<wgpu::Buffer>,
}

impl Readback {
    /// An empty readback; `label` names its staging buffer.
    pub fn new(label: &str) -> Self {
        Readback { label: label.to_owned(), staging: None }
    }

    /// Copies the first `count` elements of `source` (which needs `COPY_SRC`) back, waiting for
    /// all previously submitted work.
    pub fn read<T: Pod>(&mut self, ctx: &GpuContext, source: &wgpu::Buffer, count: usize) -> Result<Vec<T>> {
        let encoder = ctx.encoder(&self.label);
        self.submit_and_read(ctx, encoder, source, count)
    }

    /// Appends the copy of the first `count` elements of `source` to `encoder` (which may hold
    /// the compute passes that produce them: one submission for both), submits it, waits, and
    /// returns the elements.
    pub fn submit_and_read<T: Pod>(
        &mut self,
        ctx: &GpuContext,
        mut encoder: wgpu::CommandEncoder,
        source: &wgpu::Buffer,
        count: usize,
    ) -> Result<Vec<T>> {
        let bytes = count
            .checked_mul(std::mem::size_of::<T>())
            .ok_or_else(|| Error::Gpu(format!("readback `{}`: {count} elements overflow", self.label)))?
            as u64;
        if bytes == 0 {
            ctx.submit(encoder)?;
            return Ok(vec![T::zeroed(); count]);
        }
        let size = padded_size(bytes);
        if size > source.size() {
            return Err(Error::Gpu(format!(
                "readback `{}`: {bytes} bytes ({size} with padding) requested from a buffer of {} bytes",
                self.label,
                source.size()
            )));
        }
        let staging = match &self.staging {
            Some(buffer) if buffer.size() >= size => buffer.clone(),
            _ => {
                let buffer = ctx.create_buffer(
                    &self.label,
                    size,
                    wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                    None,
                )?;
                self.staging = Some(buffer.clone());
                buffer
            }
        };
        encoder.copy_buffer_to_buffer(source, 0, &staging, 0, size);
        ctx.submit(encoder)?;

        let slice = staging.slice(..size);
        let (sender, receiver) = mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |result| {
            // The receiver waits below; if it is gone there is nobody to tell.
            let _ = sender.send(result);
        });
        ctx.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| Error::Gpu(format!("readback `{}`: waiting for the GPU: {e}", self.label)))?;
        let mapped = receiver
            .recv()
            .map_err(|_| Error::Gpu(format!("readback `{}`: the map callback never ran", self.label)))?;
        if let Err(e) = mapped {
            ctx.check_errors()?;
            return Err(Error::Gpu(format!("readback `{}`: mapping failed: {e}", self.label)));
        }
        let result = slice.get_mapped_range().map(|view| bytemuck::pod_collect_to_vec(&view[..bytes as usize]));
        staging.unmap();
        ctx.check_errors()?;
        result.map_err(|e| Error::Gpu(format!("readback `{}`: {e}", self.label)))
    }
}
