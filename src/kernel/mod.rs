//! Method kernels without a device: the kernel file and its `//!` header (`file`), GLSL
//! and HLSL kernels translated to WGSL (`glsl`, `hlsl`), and composition: prelude + kernel + entry point
//! (+ a composite's inner line method), validated by naga, with errors mapped back to the
//! file and line that caused them. The GPU (src/measure/gpu) and the CPU evaluator (src/eval)
//! both run what this module composes; neither is needed to compose or check a kernel.
//!
//! - `caps`: the shader capabilities a kernel may use.
//! - `file`: the kernel file, its header, the built-in kernels.
//! - `glsl`: a GLSL kernel, parsed by naga's GLSL front end and written back as WGSL.
//! - `hlsl`: an HLSL kernel, compiled by glslang to SPIR-V, read by naga, written back as WGSL.
//! - `include`: `#include` of GLSL and HLSL kernels, expanded before either front end.
//! - `pieces`: `#include` of WGSL kernels: the shared pieces of `kernels/lib/`, as parts.
//! - `written`: the written digits of a translated kernel's float constants (f64 column).
//! - `compose`: prelude + kernel + entry point; a composite with its inner line method.
//! - `rename`: the token pass that renames the inner line method's identifiers.
//! - `diagnostic`: kernel errors mapped back to the file and line that caused them.

pub(crate) mod caps;
mod compose;
mod diagnostic;
mod file;
pub mod glsl;
pub mod hlsl;
mod include;
pub mod methods;
mod pieces;
pub(crate) mod rename;
mod written;

pub use caps::kernel_capabilities;
#[cfg(test)]
pub(crate) use compose::compose_parts;
pub use compose::{compose, compose_with, entry_point, Composed, GLUE_PATH, KERNEL_GROUP, WORKGROUP_SIZE};
pub(crate) use compose::{inner_name, ENTRY_NAME, INNER_METHOD};
pub use diagnostic::{KernelError, ENTRY_PATH};
pub use file::*;
pub use include::Includes;
pub use pieces::lib_pieces;

/// The line method a composite uses when its spec names none: it handles every M⁻¹.
pub const DEFAULT_INNER: &str = "line.ltc2023_full";

/// The inner method of a `//! uses: line_isotropic` composite when its spec names none: the
/// horizon-clipped line irradiance, exact for isotropic emitters on the diffuse material.
pub const DEFAULT_INNER_ISOTROPIC: &str = "line_isotropic.karis2013_clip";

#[cfg(test)]
mod tests;
