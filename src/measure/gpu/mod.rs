//! Running method kernels on the GPU: one device, one pipeline per method,
//! configurations in chunks with one readback each.
//!
//! - `driver_env`: keeps Mesa's stderr noise away from the user.
//! - `device`: picks the adapter (lavapipe by default) and opens the device.
//! - `runner`: pipelines with their override params, chunked runs.
//! - `loops`: the driver's loop limit, probed once, checked for every method.
//! - `timing`: one method's dispatch timed by GPU timestamps (or the wall clock).

mod device;
mod driver_env;
mod loops;
mod runner;
mod textures;
mod timing;

#[cfg(test)]
mod tests;

/// The one GPU of the unit tests (lavapipe by default), opened once with the driver quiet.
#[cfg(test)]
pub(crate) fn test_gpu() -> &'static Gpu {
    static GPU: std::sync::OnceLock<Gpu> = std::sync::OnceLock::new();
    GPU.get_or_init(|| {
        quiet_driver_environment();
        Gpu::new(None).unwrap_or_else(|e| panic!("{e}"))
    })
}

pub use crate::kernel::kernel_capabilities;
pub(crate) use device::scoped;
pub use device::{list_adapters, AdapterSummary, Gpu, GpuError};
pub use driver_env::quiet_driver_environment;
pub use loops::PROBE_TRIPS;
pub(crate) use loops::{count_trips, truncated};
pub(crate) use runner::override_constants;
pub use runner::{MethodPipeline, RunOutput, DEFAULT_CHUNK};
pub use timing::{Clock, DispatchTimer, DispatchTiming, TimedPipeline};
