//! The CPU evaluator: a kernel's naga IR (`program`) walked once (`walk`) over value
//! domains: interpreted in f32 and in promoted f64 and on intervals (`interp`), compiled
//! bit-identically (`interp::compiled`); and its deterministic operation count (`cost`).

pub mod cost;
mod digits;
pub mod envelope;
pub mod interp;
pub mod program;
pub mod walk;
