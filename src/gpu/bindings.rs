//! Bind groups from reflected bindings: `build/shaders.rs` reflects with naga which resources every
//! compute entry point uses ([`BINDINGS`](super::BINDINGS)); a stage's bind groups are made by
//! looking up each binding's WGSL variable name in a table of the frame's buffers (`BufferTable`), so no binding number is
//! written in Rust.

use super::stages::Stage;
use super::GpuContext;
use crate::{Error, Result};

/// How a shader declares a buffer binding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    /// `var<uniform>`.
    Uniform,
    /// `var<storage, read>`.
    Read,
    /// `var<storage, read_write>`.
    ReadWrite,
}

/// One resource binding of a compute entry point, as naga reflects it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Binding {
    /// `@group`.
    pub group: u32,
    /// `@binding`.
    pub binding: u32,
    /// The variable's name in WGSL.
    pub name: &'static str,
    /// How it is declared.
    pub access: Access,
    /// Whether the entry point (or a function it calls) reads it.
    pub reads: bool,
    /// Whether the entry point (or a function it calls) writes it.
    pub writes: bool,
}

/// The bindings entry point `entry_point` of `shader` uses, sorted by group and binding.
pub fn entry_bindings(shader: &str, entry_point: &str) -> Result<&'static [Binding]> {
    super::BINDINGS
        .iter()
        .find(|(s, e, _)| *s == shader && *e == entry_point)
        .map(|(_, _, b)| *b)
        .ok_or_else(|| Error::Gpu(format!("no reflected bindings for `{shader}` entry point `{entry_point}`")))
}

/// The buffers of a frame by WGSL variable name (the names are the same in every shader).
#[derive(Default)]
pub(crate) struct BufferTable<'a> {
    entries: Vec<(&'static str, &'a wgpu::Buffer)>,
}

impl<'a> BufferTable<'a> {
    /// Adds `buffer` as `name`.
    pub fn with(mut self, name: &'static str, buffer: &'a wgpu::Buffer) -> Self {
        self.entries.push((name, buffer));
        self
    }

    /// The buffer named `name`.
    pub fn get(&self, name: &str) -> Option<&'a wgpu::Buffer> {
        self.entries.iter().find(|(n, _)| *n == name).map(|(_, b)| *b)
    }
}

/// The bind groups of one stage, with their group indices.
pub(crate) type StageGroups = Vec<(u32, wgpu::BindGroup)>;

/// The bind groups of `stage` on `pipeline`: every binding its entry point uses, bound to the
/// buffer of the same name in `table`. A name missing from the table is an [`Error::Gpu`] naming
/// the stage and the variable.
pub(crate) fn bind_stage(
    ctx: &GpuContext,
    pipeline: &wgpu::ComputePipeline,
    stage: Stage,
    table: &BufferTable<'_>,
) -> Result<StageGroups> {
    let info = stage.info();
    let bindings = entry_bindings(info.shader, info.entry_point)?;
    let mut groups: StageGroups = Vec::new();
    let mut group_ids: Vec<u32> = bindings.iter().map(|b| b.group).collect();
    group_ids.dedup();
    for group in group_ids {
        let mut entries = Vec::new();
        for b in bindings.iter().filter(|b| b.group == group) {
            let buffer = table.get(b.name).ok_or_else(|| {
                Error::Gpu(format!(
                    "stage `{}` ({} entry point `{}`): no buffer for the shader variable `{}` (@group({}) @binding({}))",
                    info.name, info.shader, info.entry_point, b.name, b.group, b.binding
                ))
            })?;
            entries.push((b.binding, buffer));
        }
        groups.push((group, ctx.bind_entries(info.name, pipeline, group, &entries)?));
    }
    Ok(groups)
}
