//! linelight: a headless compute-shader validation harness for line-light shading formulas.
//!
//! case file → sampler → configs → { GPU methods (f32), CPU references (f64) }
//! → errors → bins → reports → verdict.

// `!(a < b)` is how this crate says "not less, or NaN": the NaN-aware reading is the point.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod analysis;
pub mod app;
pub mod baseline;
pub mod bench;
pub mod case;
/// The case value checks live in `case::values`; this name stays for callers.
pub use case::values as case_values;
pub mod chain;
pub mod claims;
pub mod cost;
pub mod diff;
pub mod eval;
pub mod gpu;
pub mod interp;
pub mod io;
pub mod kernel;
pub mod limits;
pub mod ltc;
pub mod methods;
pub mod names;
pub mod reference;
pub mod report;
pub mod sampler;
pub mod scan;
pub mod scene;
pub mod search;
pub mod stats;
pub mod summary;
pub mod sweep;
pub mod target;
