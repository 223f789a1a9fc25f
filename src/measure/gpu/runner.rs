//! Method pipelines and chunked runs: one pipeline per method, configurations uploaded
//! and read back a chunk at a time through buffers reused across chunks.

use super::device::{scoped, Gpu, GpuError};
use crate::input::scene::GpuScene;
use crate::kernel::methods::Method;
use crate::kernel::KernelFile;
use crate::kernel::{compose_with, inner_name, KernelError, ENTRY_NAME, WORKGROUP_SIZE};
use std::time::{Duration, Instant};

/// Configurations per chunk when the caller passes 0.
pub const DEFAULT_CHUNK: usize = 65536;

const SCENE_BYTES: u64 = std::mem::size_of::<GpuScene>() as u64;
const RESULT_BYTES: u64 = std::mem::size_of::<f32>() as u64;

/// A method kernel compiled for the device, with its params fixed.
pub struct MethodPipeline {
    /// The method with its inner line method spelled out, for messages.
    pub id: String,
    /// The kernel's own params it was compiled with, in header order.
    pub params: Vec<(String, f64)>,
    /// A composite's inner line method's params, in its header order.
    pub inner_params: Vec<(String, f64)>,
    pub(crate) pipeline: wgpu::ComputePipeline,
    /// Whether a fed `ggx` scene's magnitude multiplies the result (an LTC method's does; a
    /// `minv: ggx` kernel evaluates the GGX lobe itself: `Method::scaled_by_magnitude`).
    pub(crate) scaled: bool,
    /// For a method with loops of no static trip count on a device with a loop limit: the
    /// variant that counts loop trips, and the limit (loops.rs).
    pub(crate) counter: Option<(Box<MethodPipeline>, u64)>,
    /// Group 1: the kernel's textures and samplers (textures.rs); None without any.
    pub(crate) resources: Option<std::sync::Arc<super::textures::KernelResources>>,
}

/// A run's raw results, one `f32` per configuration (NaN and infinities kept), and the
/// wall-clock time of upload, dispatch and readback.
#[derive(Clone, Debug)]
pub struct RunOutput {
    pub values: Vec<f32>,
    pub wall: Duration,
}

impl Gpu {
    /// Compiles `method`: its kernel with its params (those not given keep the header's
    /// defaults), and for a composite its inner line method with the inner's params.
    pub fn pipeline(&self, method: &Method) -> Result<MethodPipeline, KernelError> {
        // The kernel's own errors first, then its loops against the driver's limit.
        let mut pipeline = self.build(method, false)?;
        if let Some(limit) = self.check_loops(method)? {
            // Loops without a static trip count: every run also counts their trips.
            pipeline.counter = Some((Box::new(self.build(method, true)?), limit));
        }
        Ok(pipeline)
    }

    /// [`Gpu::pipeline`] without the loop-limit check (the probe's own pipeline).
    pub(crate) fn pipeline_unchecked(&self, method: &Method) -> Result<MethodPipeline, KernelError> {
        self.build(method, false)
    }

    /// The method's pipeline, or with `counting` its variant that returns, per
    /// configuration, the loop-body executions of one invocation (loops.rs).
    fn build(&self, method: &Method, counting: bool) -> Result<MethodPipeline, KernelError> {
        let kernel = &method.kernel;
        let inner = method.inner.as_deref();
        let mut composed = compose_with(kernel, inner.map(|m| &m.kernel), self.capabilities)?;
        if counting {
            composed.source = super::loops::counting_source(&composed.source);
        }
        let (params, inner_params, constants) = override_constants(method, &composed)?;
        let constants: Vec<(&str, f64)> = constants.iter().map(|(n, v)| (n.as_str(), *v)).collect();

        let resources = scoped(&self.device, || {
            super::textures::kernel_resources(self, kernel, &composed.module)
        })
        .map_err(|e| KernelError::plain(&kernel.path, format!("wgpu rejected the kernel's textures: {e}")))??;
        let own_layout = resources.as_ref().map(|r| {
            self.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("linelight method with textures"),
                bind_group_layouts: &[Some(&self.bind_group_layout), Some(&r.layout)],
                immediate_size: 0,
            })
        });
        let pipeline = scoped(&self.device, || {
            let module = self.device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(&kernel.path),
                source: wgpu::ShaderSource::Wgsl(composed.source.as_str().into()),
            });
            self.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(&kernel.id),
                layout: Some(own_layout.as_ref().unwrap_or(&self.pipeline_layout)),
                module: &module,
                entry_point: Some(ENTRY_NAME),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants: &constants,
                    ..Default::default()
                },
                cache: None,
            })
        })
        .map_err(|e| {
            let show = |ps: &[(String, f64)]| ps.iter().map(|(n, v)| format!(" {n}={v}")).collect::<String>();
            let mut with = show(&params);
            if !inner_params.is_empty() {
                with.push_str(&format!(" and line method{}", show(&inner_params)));
            }
            let with = if with.is_empty() { with } else { format!(" with{with}") };
            KernelError::plain(&kernel.path, format!("wgpu rejected the kernel{with}: {e}"))
        })?;
        Ok(MethodPipeline {
            id: method.describe(),
            params,
            inner_params,
            pipeline,
            scaled: method.scaled_by_magnitude() && !counting,
            counter: None,
            resources: resources.map(std::sync::Arc::new),
        })
    }

    /// Evaluates the method on every scene, `chunk` configurations per dispatch (0: the
    /// default), calling `progress` with the number done after each chunk.
    pub fn run(
        &self,
        pipeline: &MethodPipeline,
        scenes: &[GpuScene],
        chunk: usize,
        progress: &mut dyn FnMut(usize),
    ) -> Result<RunOutput, GpuError> {
        self.run_textured(pipeline, scenes, &[], chunk, progress)
    }

    /// [`Gpu::run`] with the texel buffer of textured scenes: `texels` as
    /// `crate::input::scene::gpu_scenes` lays them out, bound whole for every chunk (each
    /// scene's `tex_offset` indexes it); empty when no scene is textured.
    pub fn run_textured(
        &self,
        pipeline: &MethodPipeline,
        scenes: &[GpuScene],
        texels: &[f32],
        chunk: usize,
        progress: &mut dyn FnMut(usize),
    ) -> Result<RunOutput, GpuError> {
        let start = Instant::now();
        if scenes.is_empty() {
            return Ok(RunOutput {
                values: Vec::new(),
                wall: start.elapsed(),
            });
        }
        let fail = |message: String| GpuError::Run {
            method: pipeline.id.clone(),
            message,
        };
        let chunk = if chunk == 0 { DEFAULT_CHUNK } else { chunk }
            .min(self.max_chunk())
            .min(scenes.len());
        let limits = self.device.limits();
        let texel_bytes = (texels.len().max(1) * 4) as u64;
        if texel_bytes > limits.max_storage_buffer_binding_size.min(limits.max_buffer_size) {
            return Err(fail(format!(
                "the textures' {} texels ({texel_bytes} bytes) do not fit one storage binding on this device \
                 ({} bytes): evaluate fewer or smaller textures at once",
                texels.len(),
                limits.max_storage_buffer_binding_size
            )));
        }
        let buffers =
            scoped(&self.device, || ChunkBuffers::new(self, chunk, texels)).map_err(|e| fail(e.to_string()))?;

        let mut values = Vec::with_capacity(scenes.len());
        for part in scenes.chunks(chunk) {
            let from = values.len();
            self.run_chunk(pipeline, &buffers, part, &mut values).map_err(fail)?;
            // A fed `ggx` configuration's magnitude, in f32 (scene.rs, FLAG_GGX).
            if pipeline.scaled {
                for (v, s) in values[from..].iter_mut().zip(part) {
                    *v *= s.magnitude();
                }
            }
            progress(values.len());
        }
        // The method's own time: the trip count below is a check, not part of its cost.
        let wall = start.elapsed();
        self.check_trips(pipeline, scenes, chunk)?;
        Ok(RunOutput { values, wall })
    }

    /// For a method with loops of no static trip count: runs its counting variant on `scenes`
    /// and refuses the run when any configuration's loops reached the limit (its value was
    /// cut short by the driver: never a result). Nothing to do for other methods.
    pub(crate) fn check_trips(
        &self,
        pipeline: &MethodPipeline,
        scenes: &[GpuScene],
        chunk: usize,
    ) -> Result<(), GpuError> {
        let Some((counter, limit)) = &pipeline.counter else {
            return Ok(());
        };
        let trips = self.run(counter, scenes, chunk, &mut |_| {})?.values;
        let cut: Vec<usize> = (0..trips.len()).filter(|&i| trips[i] >= *limit as f32).collect();
        match cut.first() {
            Some(&first) => Err(super::loops::truncated(
                &pipeline.id,
                cut.len() as u64,
                trips.len() as u64,
                Some(first as u64 + 1),
                *limit,
            )),
            None => Ok(()),
        }
    }

    fn run_chunk(
        &self,
        pipeline: &MethodPipeline,
        buffers: &ChunkBuffers,
        scenes: &[GpuScene],
        values: &mut Vec<f32>,
    ) -> Result<(), String> {
        if let Some(message) = injected_failure() {
            return Err(message);
        }
        let count = scenes.len() as u32;
        let result_bytes = u64::from(count) * RESULT_BYTES;
        scoped(&self.device, || {
            self.queue
                .write_buffer(&buffers.scenes, 0, bytemuck::cast_slice(scenes));
            self.queue.write_buffer(&buffers.count, 0, bytemuck::bytes_of(&count));
            let mut encoder = self.device.create_command_encoder(&Default::default());
            {
                let mut pass = encoder.begin_compute_pass(&Default::default());
                pass.set_pipeline(&pipeline.pipeline);
                pass.set_bind_group(0, &buffers.bind_group, &[]);
                if let Some(r) = &pipeline.resources {
                    pass.set_bind_group(1, &r.bind_group, &[]);
                }
                pass.dispatch_workgroups(count.div_ceil(WORKGROUP_SIZE), 1, 1);
            }
            encoder.copy_buffer_to_buffer(&buffers.results, 0, &buffers.readback, 0, result_bytes);
            self.queue.submit([encoder.finish()]);
        })
        .map_err(|e| e.to_string())?;

        let slice = buffers.readback.slice(..result_bytes);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| e.to_string())?;
        rx.recv()
            .map_err(|_| "the readback was never mapped".to_string())?
            .map_err(|e| format!("cannot map the results: {e}"))?;
        {
            let view = slice.get_mapped_range().map_err(|e| e.to_string())?;
            values.extend_from_slice(bytemuck::cast_slice(&view));
        }
        buffers.readback.unmap();
        Ok(())
    }

    /// The largest chunk one dispatch and one binding can hold on this device.
    fn max_chunk(&self) -> usize {
        let limits = self.device.limits();
        let by_dispatch = u64::from(limits.max_compute_workgroups_per_dimension) * u64::from(WORKGROUP_SIZE);
        let by_binding = limits.max_storage_buffer_binding_size / SCENE_BYTES;
        let by_buffer = limits.max_buffer_size / SCENE_BYTES;
        by_dispatch.min(by_binding).min(by_buffer).max(1) as usize
    }
}

/// The test hook `LINELIGHT_TEST_FAIL_DISPATCH=N` (src/tuning.rs), not for users: every chunk
/// dispatch after the first N of the process fails as a lost device would.
fn injected_failure() -> Option<String> {
    static DISPATCHED: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let pass = crate::tuning::tuning().fail_dispatch?;
    let n = DISPATCHED.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    (n >= pass).then(|| {
        format!(
            "dispatch {} failed (injected by LINELIGHT_TEST_FAIL_DISPATCH={pass})",
            n + 1
        )
    })
}

/// The buffers of one chunk, reused for every chunk of a run.
struct ChunkBuffers {
    scenes: wgpu::Buffer,
    results: wgpu::Buffer,
    readback: wgpu::Buffer,
    count: wgpu::Buffer,
    /// Kept alive with the bind group.
    _texels: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
}

impl ChunkBuffers {
    fn new(gpu: &Gpu, chunk: usize, texels: &[f32]) -> ChunkBuffers {
        let buffer = |label, size, usage| {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        };
        use wgpu::BufferUsages as U;
        let chunk = chunk as u64;
        let scenes = buffer("ll_scenes", chunk * SCENE_BYTES, U::STORAGE | U::COPY_DST);
        let results = buffer("ll_results", chunk * RESULT_BYTES, U::STORAGE | U::COPY_SRC);
        let readback = buffer("ll_readback", chunk * RESULT_BYTES, U::MAP_READ | U::COPY_DST);
        let count = buffer("ll_count", std::mem::size_of::<u32>() as u64, U::UNIFORM | U::COPY_DST);
        let texel_buffer = texel_buffer(gpu, texels);
        let bind_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("linelight chunk"),
            layout: &gpu.bind_group_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: scenes.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: results.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: count.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: texel_buffer.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: gpu.ltc_tables.as_entire_binding(),
                },
            ],
        });
        ChunkBuffers {
            scenes,
            results,
            readback,
            count,
            _texels: texel_buffer,
            bind_group,
        }
    }
}

/// The texel buffer (binding 3, `ll_texels`): `texels`, or one 0 when there are none (a
/// binding cannot be empty).
pub(crate) fn texel_buffer(gpu: &Gpu, texels: &[f32]) -> wgpu::Buffer {
    let data: &[f32] = if texels.is_empty() { &[0.0] } else { texels };
    let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("ll_texels"),
        size: std::mem::size_of_val(data) as u64,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    gpu.queue.write_buffer(&buffer, 0, bytemuck::cast_slice(data));
    buffer
}

/// `values` for `kernel`'s header params, in order; params not given keep their defaults.
/// A method's params, its inner's, and the pipeline-overridable constants they set (the inner's
/// overrides renamed in composition, compose.rs).
#[allow(clippy::type_complexity)]
pub(crate) fn override_constants(
    method: &Method,
    composed: &crate::kernel::Composed,
) -> Result<(Vec<(String, f64)>, Vec<(String, f64)>, Vec<(String, f64)>), KernelError> {
    let params = param_values(&method.kernel, &method.params)?;
    let inner_params = match (method.inner.as_deref(), &composed.inner) {
        (Some(m), _) => param_values(&m.kernel, &m.params)?,
        (None, Some(default)) => param_values(default, &[])?,
        (None, None) => Vec::new(),
    };
    let constants = params
        .iter()
        .map(|(n, v)| (n.clone(), *v))
        .chain(inner_params.iter().map(|(n, v)| (inner_name(n), *v)))
        .collect();
    Ok((params, inner_params, constants))
}

fn param_values(kernel: &KernelFile, values: &[f64]) -> Result<Vec<(String, f64)>, KernelError> {
    if values.len() > kernel.params.len() {
        let names: Vec<_> = kernel.params.iter().map(|p| p.name.as_str()).collect();
        let names = if names.is_empty() {
            "none".to_string()
        } else {
            names.join(", ")
        };
        return Err(KernelError::plain(
            &kernel.path,
            format!(
                "{} takes {} param(s) ({names}), {} given",
                kernel.id,
                kernel.params.len(),
                values.len()
            ),
        ));
    }
    Ok(kernel
        .params
        .iter()
        .enumerate()
        .map(|(i, p)| (p.name.clone(), values.get(i).copied().unwrap_or(p.default)))
        .collect())
}
