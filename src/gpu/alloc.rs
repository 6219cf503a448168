//! Buffer creation on a [`GpuContext`]: storage, uniform, indirect and staging buffers, checked
//! against the device's limits ([`Error::GpuLimit`]).

use bytemuck::Pod;

use super::GpuContext;
use crate::{Error, Result};

impl GpuContext {
    /// A `MAP_READ | COPY_DST` staging buffer of at least `bytes` bytes (rounded up to a multiple
    /// of 4), to copy results into and read them with [`GpuContext::read_staging`].
    pub fn staging_buffer(&self, label: &str, bytes: u64) -> Result<wgpu::Buffer> {
        let size = padded_size(bytes);
        self.check_size("max_buffer_size", size, self.limits.max_buffer_size)?;
        self.create_buffer(label, size, wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST, None)
    }

    fn check_size(&self, limit: &'static str, needed: u64, max: u64) -> Result<()> {
        if needed > max {
            Err(Error::GpuLimit { limit, needed, max })
        } else {
            Ok(())
        }
    }

    fn check_storage_size(&self, bytes: u64) -> Result<()> {
        self.check_size("max_storage_buffer_binding_size", bytes, self.limits.max_storage_buffer_binding_size)?;
        self.check_size("max_buffer_size", bytes, self.limits.max_buffer_size)
    }

    pub(super) fn create_buffer(
        &self,
        label: &str,
        size: u64,
        usage: wgpu::BufferUsages,
        data: Option<&[u8]>,
    ) -> Result<wgpu::Buffer> {
        let buffer = self.scoped(&format!("creating buffer `{label}` ({size} bytes)"), || {
            self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: data.is_some(),
            })
        })?;
        if let Some(data) = data {
            let mut view = buffer
                .get_mapped_range_mut(..)
                .map_err(|e| Error::Gpu(format!("initialising buffer `{label}`: {e}")))?;
            view.slice(..data.len()).copy_from_slice(data);
            drop(view);
            buffer.unmap();
        }
        Ok(buffer)
    }

    /// A zero-filled storage buffer of at least `bytes` bytes (rounded up to a multiple of 4, at
    /// least 4), usable as `STORAGE | COPY_SRC | COPY_DST`. Checks the device's buffer limits
    /// ([`Error::GpuLimit`]).
    pub fn storage_buffer(&self, label: &str, bytes: u64) -> Result<wgpu::Buffer> {
        let size = padded_size(bytes);
        self.check_storage_size(size)?;
        self.create_buffer(label, size, storage_usage(), None)
    }

    /// A zero-filled `STORAGE | INDIRECT` buffer of at least `bytes` bytes, for dispatch arguments
    /// a shader writes.
    pub fn indirect_buffer(&self, label: &str, bytes: u64) -> Result<wgpu::Buffer> {
        let size = padded_size(bytes);
        self.check_storage_size(size)?;
        self.create_buffer(label, size, wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::INDIRECT, None)
    }

    /// A storage buffer holding `data` (padded with zeros to a multiple of 4 bytes, at least 4),
    /// usable as `STORAGE | COPY_SRC | COPY_DST`.
    pub fn storage_buffer_init<T: Pod>(&self, label: &str, data: &[T]) -> Result<wgpu::Buffer> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let size = padded_size(bytes.len() as u64);
        self.check_storage_size(size)?;
        self.create_buffer(label, size, storage_usage(), Some(bytes))
    }

    /// A uniform buffer holding `value` (padded with zeros to a multiple of 16 bytes), usable as
    /// `UNIFORM | COPY_DST` (update it with `queue().write_buffer`).
    pub fn uniform_buffer_init<T: Pod>(&self, label: &str, value: &T) -> Result<wgpu::Buffer> {
        let bytes: &[u8] = bytemuck::bytes_of(value);
        let size = (bytes.len() as u64).div_ceil(16).max(1) * 16;
        self.check_size("max_uniform_buffer_binding_size", size, self.limits.max_uniform_buffer_binding_size)?;
        self.create_buffer(label, size, wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST, Some(bytes))
    }
}

fn storage_usage() -> wgpu::BufferUsages {
    wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST
}

/// Rounds up to a multiple of `wgpu::COPY_BUFFER_ALIGNMENT` (4), and to at least 4 bytes.
pub(super) fn padded_size(bytes: u64) -> u64 {
    bytes.div_ceil(wgpu::COPY_BUFFER_ALIGNMENT).max(1) * wgpu::COPY_BUFFER_ALIGNMENT
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn padding() {
        assert_eq!(padded_size(0), 4);
        assert_eq!(padded_size(1), 4);
        assert_eq!(padded_size(4), 4);
        assert_eq!(padded_size(5), 8);
    }
}
