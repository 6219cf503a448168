//! References the engines are checked against: the per-segment closed form of the derivative and
//! an exact-area rasteriser (slow, simple, `f64`), and near/far clipping in `f64` to feed it. Tests take
//! finite differences of the oracle.

pub mod clip;
pub mod closed_form;
pub mod oracle;
