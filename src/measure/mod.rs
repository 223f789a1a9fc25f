//! The measure stage: kernels run over configurations on the GPU (`gpu`), with their CPU
//! evaluator columns and references — a sweep, a search, a bench's raw times, a scan, and the
//! rows of `eval`. No statistics and no files here beyond what each run hands on.

pub mod bench;
pub mod chain;
pub mod envelope;
pub mod eval_rows;
pub mod fit;
pub mod gpu;
pub mod objectives;
pub mod progress;
pub mod render;
pub mod resolution;
pub mod scan;
pub mod search;
pub mod setup;
pub mod sweep;
