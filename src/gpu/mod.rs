//! Running method kernels on the GPU (DESIGN §6): one device, one pipeline per method,
//! configurations in chunks with one readback each.
//!
//! - `driver_env`: keeps Mesa's stderr noise away from the user.
//! - `device`: picks the adapter (lavapipe by default) and opens the device.
//! - `compose`: prelude + kernel + entry point, validated by naga; a composite with its
//!   inner line method.
//! - `rename`: the token pass that renames the inner line method's identifiers.
//! - `diagnostic`: kernel errors mapped back to the file and line that caused them.
//! - `runner`: pipelines with their override params, chunked runs.
//! - `loops`: the driver's loop limit, probed once, checked for every method.
//! - `timing`: one method's dispatch timed by GPU timestamps (or the wall clock).

mod compose;
mod device;
mod diagnostic;
mod driver_env;
mod loops;
mod rename;
mod runner;
mod timing;

#[cfg(test)]
mod tests;

pub(crate) use compose::inner_name;
pub use compose::{compose, compose_with, entry_point, Composed, GLUE_PATH, WORKGROUP_SIZE};
pub(crate) use device::scoped;
pub use device::{kernel_capabilities, list_adapters, AdapterSummary, Gpu, GpuError};
pub use diagnostic::{KernelError, ENTRY_PATH};
pub use driver_env::quiet_driver_environment;
pub use loops::PROBE_TRIPS;
pub(crate) use runner::override_constants;
pub use runner::{MethodPipeline, RunOutput, DEFAULT_CHUNK};
pub use timing::{Clock, DispatchTimer, DispatchTiming, TimedPipeline};
