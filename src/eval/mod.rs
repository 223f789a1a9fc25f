//! The CPU evaluator: a kernel's naga IR interpreted in f32 and in promoted f64
//! (`interp`), and its deterministic operation count (`cost`).

pub mod cost;
pub mod envelope;
pub mod interp;
