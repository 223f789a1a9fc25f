//! The error envelope a kernel may show on any conforming driver (docs/envelope.md):
//! the WGSL spec's accuracy rules as data (`accuracy`) and f32 interval arithmetic with
//! outward rounding (`interval`). The interval evaluation of a kernel's IR is in
//! `interp::envelope`, beside the other modes of the evaluator.

pub mod accuracy;
pub mod interval;
