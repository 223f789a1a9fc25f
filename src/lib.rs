//! linelight: a headless compute-shader validation harness for line-light shading formulas.
//!
//! case file → sampler → configs → { GPU methods (f32), CPU references (f64) }
//! → errors → bins → reports → verdict.

// `!(a < b)` is how this crate says "not less, or NaN": the NaN-aware reading is the point.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

// The stages, in the order a command runs them (tests/layering.rs holds them to it):
// input → kernel → eval (the CPU evaluator) → reference → measure → analyse → report, under
// the app layer (one module per command). `io` reads and writes every file; `limits` holds
// the caps; `tuning` reads the environment once; `warnings` collects what a run warns of.
pub mod analyse;
pub mod app;
pub mod eval;
pub mod input;
pub mod io;
pub mod kernel;
pub mod limits;
pub mod measure;
pub mod reference;
pub mod report;
pub mod tuning;
pub mod warnings;
