//! Writers of the intensity-measure study's results (the computations are in
//! [`rockwatch_core::study`]): CSV, Markdown and JSON reports, SVG/PNG plots.

pub mod plots;
pub mod report;
