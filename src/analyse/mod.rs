//! The analyse stage: measured values and references into statistics, comparisons, claims
//! and the summary a report formats. Pure: no device, no files.

pub mod analysis;
pub mod bench;
pub mod chain;
pub mod claims;
pub mod diff;
pub mod envelope;
pub mod fit;
pub mod gate;
pub mod measured;
pub mod objectives;
pub mod observations;
pub mod pareto;
pub mod partial;
pub mod render;
pub mod render_gate;
pub mod resolution;
pub mod scan;
pub mod ship;
pub mod stats;
pub mod summary;
