//! Bind groups from reflected bindings: `build/shaders.rs` reflects with naga which resources every
//! compute entry point uses ([`BINDINGS`](super::BINDINGS)); a bind group is made by looking up
//! each binding's variable name in a table of buffers, so no binding number is written in Rust.

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
