//! Writers of a rock's fragility (`rockwatch fragility`; the computations are in
//! [`rockwatch_core::fragility`]): JSON, CSV, text and SVG/PNG plots.

pub mod plots;
pub mod report;
