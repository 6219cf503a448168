//! References the engines are checked against: the per-segment closed form of the derivative and
//! an exact-area rasteriser (slow, simple, `f64`). Tests take finite differences of the oracle.

pub mod closed_form;
pub mod oracle;
