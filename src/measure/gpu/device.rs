//! The one device every method runs on: Vulkan only, headless, lavapipe by default so
//! results do not depend on whichever GPU the machine happens to have.

use crate::kernel::caps::{naga_capabilities, OPTIONAL_FEATURES};
use naga::valid::Capabilities;
use std::fmt;

/// What the user is told to install when lavapipe is missing.
const INSTALL_HINT: &str = "linelight runs its kernels on Mesa's lavapipe (a CPU Vulkan driver); \
on Debian/Ubuntu install it with `apt-get install mesa-vulkan-drivers`";

/// An adapter as the user sees it in messages and reports.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct AdapterSummary {
    pub name: String,
    pub backend: String,
    pub device_type: String,
    pub driver: String,
    pub driver_info: String,
}

impl From<wgpu::AdapterInfo> for AdapterSummary {
    fn from(info: wgpu::AdapterInfo) -> Self {
        AdapterSummary {
            name: info.name,
            backend: format!("{:?}", info.backend),
            device_type: format!("{:?}", info.device_type),
            driver: info.driver,
            driver_info: info.driver_info,
        }
    }
}

impl fmt::Display for AdapterSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} — {}, {}, driver {} {}",
            self.name, self.backend, self.device_type, self.driver, self.driver_info
        )
    }
}

#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// No adapter matched; `found` lists the Vulkan adapters that exist.
    #[error("{}", no_adapter_message(requested.as_deref(), found))]
    NoAdapter {
        requested: Option<String>,
        found: Vec<AdapterSummary>,
    },
    #[error("cannot open a device on {adapter}: {message}")]
    Device { adapter: String, message: String },
    /// The GPU failed at run time: a dispatch, a readback, a lost device (exit 4).
    #[error("GPU run of {method} failed: {message}")]
    Run { method: String, message: String },
    /// The run is refused: the method's loops reached the driver's loop limit, so its
    /// results may be cut short (exit 2, the method's parameters are to blame).
    #[error("{method} is refused: {message}")]
    LoopLimit { method: String, message: String },
}

fn no_adapter_message(requested: Option<&str>, found: &[AdapterSummary]) -> String {
    let mut m = match (requested, found.is_empty()) {
        (_, true) => format!("no Vulkan adapter found: {INSTALL_HINT}"),
        (None, false) => format!(
            "no lavapipe (llvmpipe) Vulkan adapter found: {INSTALL_HINT}, or pick one of these adapters by name:"
        ),
        (Some(name), false) => format!("no Vulkan adapter's name contains `{name}`; the adapters found are:"),
    };
    for a in found {
        m.push_str(&format!("\n  {a}"));
    }
    m
}

fn instance() -> wgpu::Instance {
    wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: wgpu::Backends::VULKAN,
        // Not the build's default: debug builds would load the Vulkan validation layers,
        // which print to stdout. WGPU_VALIDATION=1 and friends still turn them on.
        flags: wgpu::InstanceFlags::empty().with_env(),
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    })
}

/// The Vulkan adapters on this machine.
pub fn list_adapters() -> Vec<AdapterSummary> {
    pollster::block_on(instance().enumerate_adapters(wgpu::Backends::VULKAN))
        .iter()
        .map(|a| a.get_info().into())
        .collect()
}

fn is_lavapipe(info: &wgpu::AdapterInfo) -> bool {
    info.name.contains("llvmpipe") && info.device_type == wgpu::DeviceType::Cpu
}

/// The device, its queue and what every method pipeline shares.
pub struct Gpu {
    pub adapter: AdapterSummary,
    pub(crate) device: wgpu::Device,
    pub(crate) queue: wgpu::Queue,
    pub(crate) pipeline_layout: wgpu::PipelineLayout,
    pub(crate) bind_group_layout: wgpu::BindGroupLayout,
    pub(crate) capabilities: Capabilities,
    /// The loop limit, once probed (loops.rs).
    pub(crate) loop_limit: std::sync::OnceLock<Option<u64>>,
    /// Our LTC tables (binding 4, `ll_ltc`; src/input/ltc/device.rs), uploaded once: every
    /// chunk's bind group binds this buffer.
    pub(crate) ltc_tables: wgpu::Buffer,
}

impl Gpu {
    /// Opens lavapipe, or with `Some(name)` the first Vulkan adapter whose name contains
    /// `name` (case-insensitive).
    pub fn new(adapter: Option<&str>) -> Result<Gpu, GpuError> {
        let adapters = pollster::block_on(instance().enumerate_adapters(wgpu::Backends::VULKAN));
        let chosen = adapters.iter().find(|a| {
            let info = a.get_info();
            match adapter {
                None => is_lavapipe(&info),
                Some(name) => info.name.to_lowercase().contains(&name.to_lowercase()),
            }
        });
        let Some(chosen) = chosen else {
            return Err(GpuError::NoAdapter {
                requested: adapter.map(str::to_string),
                found: adapters.iter().map(|a| a.get_info().into()).collect(),
            });
        };
        let summary = AdapterSummary::from(chosen.get_info());
        let features = chosen.features() & OPTIONAL_FEATURES;
        let (device, queue) = pollster::block_on(chosen.request_device(&wgpu::DeviceDescriptor {
            label: Some("linelight"),
            required_features: features,
            // The adapter's own limits: large storage buffers mean fewer, larger chunks.
            required_limits: chosen.limits(),
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device {
            adapter: summary.to_string(),
            message: e.to_string(),
        })?;

        let (bind_group_layout, pipeline_layout) =
            scoped(&device, || layouts(&device)).map_err(|e| GpuError::Device {
                adapter: summary.to_string(),
                message: e.to_string(),
            })?;
        let ltc_tables = ltc_table_buffer(&device, &queue);
        Ok(Gpu {
            ltc_tables,
            adapter: summary,
            capabilities: naga_capabilities(device.features()),
            loop_limit: std::sync::OnceLock::new(),
            device,
            queue,
            pipeline_layout,
            bind_group_layout,
        })
    }

    pub fn device(&self) -> &wgpu::Device {
        &self.device
    }

    pub fn queue(&self) -> &wgpu::Queue {
        &self.queue
    }

    /// Whether the device writes timestamp queries (`device().features()` tells whether
    /// also inside encoders and passes).
    pub fn has_timestamps(&self) -> bool {
        self.device.features().contains(wgpu::Features::TIMESTAMP_QUERY)
    }

    /// The naga capabilities kernels are validated with: those of the device's features.
    pub fn capabilities(&self) -> Capabilities {
        self.capabilities
    }
}

/// The one bind group layout every method pipeline shares: it matches the bindings of
/// the entry point in compose.rs.
fn layouts(device: &wgpu::Device) -> (wgpu::BindGroupLayout, wgpu::PipelineLayout) {
    let storage = |binding, read_only| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    };
    let bind_group_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("linelight chunk"),
        entries: &[
            storage(0, true),
            storage(1, false),
            wgpu::BindGroupLayoutEntry {
                binding: 2,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            },
            // The light textures' texels.
            storage(3, true),
            // Our LTC tables, read by the device look-ups of kernels/ltc/.
            storage(4, true),
        ],
    });
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("linelight method"),
        bind_group_layouts: &[Some(&bind_group_layout)],
        immediate_size: 0,
    });
    (bind_group_layout, pipeline_layout)
}

/// The buffer of binding 4, `ll_ltc`: our LTC tables as the device look-ups read them
/// (`input::ltc::device::ours`, about 280 kB).
fn ltc_table_buffer(device: &wgpu::Device, queue: &wgpu::Queue) -> wgpu::Buffer {
    let data = crate::input::ltc::device::ours();
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("ll_ltc"),
        size: std::mem::size_of_val(data) as u64,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    queue.write_buffer(&buffer, 0, bytemuck::cast_slice(data));
    buffer
}

/// Runs `f` inside validation and out-of-memory error scopes, so wgpu's errors come back
/// as values instead of the default handler's panic.
pub(crate) fn scoped<T>(device: &wgpu::Device, f: impl FnOnce() -> T) -> Result<T, wgpu::Error> {
    let memory = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
    let validation = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let value = f();
    let validation = pollster::block_on(validation.pop());
    let memory = pollster::block_on(memory.pop());
    match validation.or(memory) {
        Some(e) => Err(e),
        None => Ok(value),
    }
}
