//! Timing one method's dispatch (the measuring half of `linelight bench`; `bench.rs`
//! analyses and reports).
//!
//! The scenes are uploaded once into a [`DispatchTimer`]; every [`DispatchTimer::time`]
//! is then one submission of one compute pass, dispatching the method over all of them,
//! waited on before it returns. The pass is timed by the GPU itself when the device has
//! `TIMESTAMP_QUERY` (lavapipe has): timestamps written at the beginning and the end of the
//! pass (`ComputePassTimestampWrites`), resolved and read back, `(end − begin) × period`
//! ns. Without timestamps the timer falls back to the wall-clock time of submit + wait,
//! which also counts the submission and the wait's own latency, and says so:
//! [`Clock::Wall`].
//!
//! Nothing is read back but the timestamps: the results stay on the device (the kernel
//! still writes them, so nothing can be optimised away).

use super::device::{scoped, Gpu, GpuError};
use crate::input::scene::GpuScene;
use crate::kernel::methods::Method;
use crate::kernel::WORKGROUP_SIZE;
use std::fmt;
use std::time::Instant;

const SCENE_BYTES: u64 = std::mem::size_of::<GpuScene>() as u64;
const RESULT_BYTES: u64 = std::mem::size_of::<f32>() as u64;
/// Two timestamps: the beginning and the end of the pass.
const TIMESTAMP_BYTES: u64 = 2 * wgpu::QUERY_SIZE as u64;

/// What a dispatch was timed with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Clock {
    /// The GPU's own timestamps at the beginning and end of the compute pass.
    #[serde(rename = "gpu-timestamp")]
    GpuTimestamp,
    /// Wall-clock time of submit + wait on the CPU (the device has no timestamp queries).
    #[serde(rename = "wall")]
    Wall,
}

impl Clock {
    pub fn name(self) -> &'static str {
        match self {
            Clock::GpuTimestamp => "gpu-timestamp",
            Clock::Wall => "wall",
        }
    }
}

impl fmt::Display for Clock {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A method compiled for timing: the same kernel, params and override constants as
/// [`Gpu::pipeline`] compiles for a run.
pub struct TimedPipeline {
    /// The method with its inner line method spelled out, for messages.
    pub id: String,
    pipeline: wgpu::ComputePipeline,
    /// Group 1: the kernel's textures and samplers, as the run binds them.
    resources: Option<std::sync::Arc<super::textures::KernelResources>>,
}

/// One slice of the scenes that fits one dispatch and one binding.
struct Chunk {
    count: u32,
    bind_group: wgpu::BindGroup,
    // Kept alive with their bind group, for clarity (wgpu would keep them anyway).
    _buffers: [wgpu::Buffer; 4],
}

/// The query set and the buffers the two timestamps go through on their way back.
struct Timestamps {
    query_set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    readback: wgpu::Buffer,
    /// Nanoseconds per timestamp tick (`Queue::get_timestamp_period`).
    period_ns: f64,
}

/// Scenes uploaded once, ready to time any method's dispatch over all of them.
pub struct DispatchTimer<'g> {
    gpu: &'g Gpu,
    chunks: Vec<Chunk>,
    /// The scenes, for the loop-trip check of a method with loops of no static trip count.
    scenes: Vec<GpuScene>,
    configurations: usize,
    timestamps: Option<Timestamps>,
}

/// The repeats of one method timed with [`Gpu::time_method`].
#[derive(Clone, Debug, serde::Serialize)]
pub struct DispatchTiming {
    pub id: String,
    pub clock: Clock,
    /// Configurations per dispatch.
    pub configurations: usize,
    /// Untimed dispatches run first.
    pub warmup: usize,
    /// Nanoseconds of each timed dispatch (all configurations), in the order run.
    pub ns: Vec<f64>,
}

impl Gpu {
    /// Uploads `scenes` for timing, with the GPU's timestamps when the device has them
    /// and the wall clock otherwise.
    pub fn dispatch_timer(&self, scenes: &[GpuScene]) -> Result<DispatchTimer<'_>, GpuError> {
        self.dispatch_timer_textured(scenes, &[])
    }

    /// [`Gpu::dispatch_timer`] with the texel buffer of textured scenes: `texels` as
    /// `crate::input::scene::gpu_scenes` lays them out, bound whole to every dispatch, so a
    /// texture method is timed reading its scenes' own texels.
    pub fn dispatch_timer_textured(&self, scenes: &[GpuScene], texels: &[f32]) -> Result<DispatchTimer<'_>, GpuError> {
        let clock = if self.has_timestamps() {
            Clock::GpuTimestamp
        } else {
            Clock::Wall
        };
        self.dispatch_timer_inner(scenes, texels, clock)
    }

    /// Uploads `scenes` for timing with `clock`; [`Clock::GpuTimestamp`] is an error on a
    /// device without timestamp queries.
    pub fn dispatch_timer_with(&self, scenes: &[GpuScene], clock: Clock) -> Result<DispatchTimer<'_>, GpuError> {
        self.dispatch_timer_inner(scenes, &[], clock)
    }

    fn dispatch_timer_inner(
        &self,
        scenes: &[GpuScene],
        texels: &[f32],
        clock: Clock,
    ) -> Result<DispatchTimer<'_>, GpuError> {
        let fail = |message: String| GpuError::Run {
            method: "timing".to_string(),
            message,
        };
        let texel_bytes = (texels.len().max(1) * 4) as u64;
        let limits = self.device.limits();
        if texel_bytes > limits.max_storage_buffer_binding_size || texel_bytes > limits.max_buffer_size {
            return Err(fail(format!(
                "the textures' {} texels ({texel_bytes} bytes) do not fit one storage binding on this device \
                 (at most {} bytes): time fewer or smaller textured configurations",
                texels.len(),
                limits.max_storage_buffer_binding_size.min(limits.max_buffer_size)
            )));
        }
        if scenes.is_empty() {
            return Err(fail("no configurations to time".to_string()));
        }
        if clock == Clock::GpuTimestamp && !self.has_timestamps() {
            return Err(fail(format!(
                "{} has no timestamp queries (TIMESTAMP_QUERY)",
                self.adapter.name
            )));
        }
        let per_dispatch = self.max_dispatch();
        scoped(&self.device, || {
            let chunks = scenes
                .chunks(per_dispatch)
                .map(|part| self.upload_chunk(part, texels))
                .collect();
            let timestamps = (clock == Clock::GpuTimestamp).then(|| self.timestamps());
            DispatchTimer {
                gpu: self,
                chunks,
                scenes: scenes.to_vec(),
                configurations: scenes.len(),
                timestamps,
            }
        })
        .map_err(|e| fail(e.to_string()))
    }

    /// Times `method` over `scenes`: uploads them once, runs `warmup` untimed dispatches,
    /// then `repeats` timed ones, each its own submission, waited on.
    pub fn time_method(
        &self,
        method: &Method,
        scenes: &[GpuScene],
        warmup: usize,
        repeats: usize,
    ) -> anyhow::Result<DispatchTiming> {
        let timer = self.dispatch_timer(scenes)?;
        let pipeline = timer.pipeline(method)?;
        for _ in 0..warmup {
            timer.time(&pipeline)?;
        }
        let ns = (0..repeats).map(|_| timer.time(&pipeline)).collect::<Result<_, _>>()?;
        Ok(DispatchTiming {
            id: pipeline.id,
            clock: timer.clock(),
            configurations: timer.configurations(),
            warmup,
            ns,
        })
    }

    /// The most configurations one dispatch and one binding can hold on this device
    /// (the runner's chunk limit).
    fn max_dispatch(&self) -> usize {
        let limits = self.device.limits();
        let by_dispatch = u64::from(limits.max_compute_workgroups_per_dimension) * u64::from(WORKGROUP_SIZE);
        let by_binding = limits.max_storage_buffer_binding_size / SCENE_BYTES;
        let by_buffer = limits.max_buffer_size / SCENE_BYTES;
        by_dispatch.min(by_binding).min(by_buffer).max(1) as usize
    }

    fn upload_chunk(&self, scenes: &[GpuScene], texels: &[f32]) -> Chunk {
        use wgpu::BufferUsages as U;
        let count = scenes.len() as u32;
        let buffer = |label, size, usage| {
            self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        };
        let scene_buffer = buffer(
            "ll_timed_scenes",
            u64::from(count) * SCENE_BYTES,
            U::STORAGE | U::COPY_DST,
        );
        let results = buffer("ll_timed_results", u64::from(count) * RESULT_BYTES, U::STORAGE);
        let count_buffer = buffer(
            "ll_timed_count",
            std::mem::size_of::<u32>() as u64,
            U::UNIFORM | U::COPY_DST,
        );
        // The textured scenes' texels (their offsets index the whole buffer), or one 0.
        let texels = super::runner::texel_buffer(self, texels);
        self.queue.write_buffer(&scene_buffer, 0, bytemuck::cast_slice(scenes));
        self.queue.write_buffer(&count_buffer, 0, bytemuck::bytes_of(&count));
        let bind_group = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("linelight timed chunk"),
            layout: &self.bind_group_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: scene_buffer.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: results.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: count_buffer.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: texels.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: self.ltc_tables.as_entire_binding(),
                },
            ],
        });
        Chunk {
            count,
            bind_group,
            _buffers: [scene_buffer, results, count_buffer, texels],
        }
    }

    fn timestamps(&self) -> Timestamps {
        use wgpu::BufferUsages as U;
        let query_set = self.device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("linelight pass timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count: 2,
        });
        let buffer = |label, usage| {
            self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: TIMESTAMP_BYTES,
                usage,
                mapped_at_creation: false,
            })
        };
        Timestamps {
            query_set,
            resolve: buffer("ll_timestamps", U::QUERY_RESOLVE | U::COPY_SRC),
            readback: buffer("ll_timestamps_readback", U::MAP_READ | U::COPY_DST),
            period_ns: f64::from(self.queue.get_timestamp_period()),
        }
    }
}

impl DispatchTimer<'_> {
    pub fn clock(&self) -> Clock {
        if self.timestamps.is_some() {
            Clock::GpuTimestamp
        } else {
            Clock::Wall
        }
    }

    /// Configurations per timed dispatch: all the scenes.
    pub fn configurations(&self) -> usize {
        self.configurations
    }

    /// `dispatch_workgroups` calls per timed pass (more than 1 only when the scenes do
    /// not fit one dispatch or one binding on this device).
    pub fn dispatches(&self) -> usize {
        self.chunks.len()
    }

    /// Compiles `method` exactly as [`Gpu::pipeline`] does for a run (the same composition,
    /// override names and values), so what is timed is what is measured; and, as a run does,
    /// refuses a method whose loops reach the driver's limit on these scenes (a time of loops
    /// the driver cut short is not the method's).
    pub fn pipeline(&self, method: &Method) -> anyhow::Result<TimedPipeline> {
        let compiled = self.gpu.pipeline(method)?;
        self.gpu.check_trips(&compiled, &self.scenes, 0)?;
        Ok(TimedPipeline {
            id: compiled.id,
            pipeline: compiled.pipeline,
            resources: compiled.resources,
        })
    }

    /// Runs `pipeline` once over every scene, in one compute pass and one submission,
    /// waits for it, and returns its duration in nanoseconds by [`Self::clock`].
    pub fn time(&self, pipeline: &TimedPipeline) -> Result<f64, GpuError> {
        let fail = |message: String| GpuError::Run {
            method: pipeline.id.clone(),
            message,
        };
        let gpu = self.gpu;
        let submitted = scoped(&gpu.device, || {
            let mut encoder = gpu.device.create_command_encoder(&Default::default());
            {
                let timestamp_writes = self.timestamps.as_ref().map(|t| wgpu::ComputePassTimestampWrites {
                    query_set: &t.query_set,
                    beginning_of_pass_write_index: Some(0),
                    end_of_pass_write_index: Some(1),
                });
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("linelight timed pass"),
                    timestamp_writes,
                });
                pass.set_pipeline(&pipeline.pipeline);
                for chunk in &self.chunks {
                    pass.set_bind_group(0, &chunk.bind_group, &[]);
                    if let Some(r) = &pipeline.resources {
                        pass.set_bind_group(1, &r.bind_group, &[]);
                    }
                    pass.dispatch_workgroups(chunk.count.div_ceil(WORKGROUP_SIZE), 1, 1);
                }
            }
            if let Some(t) = &self.timestamps {
                encoder.resolve_query_set(&t.query_set, 0..2, &t.resolve, 0);
                encoder.copy_buffer_to_buffer(&t.resolve, 0, &t.readback, 0, TIMESTAMP_BYTES);
            }
            let command_buffer = encoder.finish();
            // The wall clock starts at the submission: encoding is not the dispatch.
            let start = Instant::now();
            gpu.queue.submit([command_buffer]);
            start
        })
        .map_err(|e| fail(e.to_string()))?;
        gpu.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| fail(e.to_string()))?;
        let wall_ns = submitted.elapsed().as_nanos() as f64;
        match &self.timestamps {
            None => Ok(wall_ns),
            Some(t) => {
                let [begin, end] = read_timestamps(gpu, &t.readback).map_err(fail)?;
                if end < begin {
                    return Err(fail(format!(
                        "the pass's end timestamp ({end}) is before its beginning ({begin})"
                    )));
                }
                Ok((end - begin) as f64 * t.period_ns)
            }
        }
    }
}

/// The two resolved timestamps, in ticks.
fn read_timestamps(gpu: &Gpu, readback: &wgpu::Buffer) -> Result<[u64; 2], String> {
    let slice = readback.slice(..);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    gpu.device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| e.to_string())?;
    rx.recv()
        .map_err(|_| "the timestamps were never mapped".to_string())?
        .map_err(|e| format!("cannot map the timestamps: {e}"))?;
    let ticks = {
        let view = slice.get_mapped_range().map_err(|e| e.to_string())?;
        let ticks: &[u64] = bytemuck::cast_slice(&view);
        [ticks[0], ticks[1]]
    };
    readback.unmap();
    Ok(ticks)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gpu() -> &'static Gpu {
        crate::measure::gpu::test_gpu()
    }

    fn tiny_method() -> Method {
        let text = "//! id: test.tiny\n//! target: line\n\
                    fn method(scene: Scene) -> f32 { return atan(scene.p1.x) + sqrt(abs(scene.p2.y)); }\n";
        Method {
            label: "test.tiny".to_string(),
            kernel: crate::kernel::KernelFile::parse("tiny.wgsl", text).unwrap(),
            params: Vec::new(),
            inner: None,
            judged: None,
        }
    }

    fn scenes(n: usize) -> Vec<GpuScene> {
        (0..n)
            .map(|i| GpuScene {
                p1: [i as f32, 0.0, 1.0],
                p2: [1.0, 0.5 * i as f32, 1.0],
                ..Default::default()
            })
            .collect()
    }

    fn assert_durations(ns: &[f64], repeats: usize) {
        assert_eq!(ns.len(), repeats, "{ns:?}");
        for &t in ns {
            assert!(
                t.is_finite() && t > 0.0,
                "not a positive finite duration: {t} in {ns:?}"
            );
        }
    }

    #[test]
    fn lavapipe_times_a_tiny_kernel_with_gpu_timestamps() {
        let g = gpu();
        assert!(g.has_timestamps(), "lavapipe writes timestamp queries");
        let timing = g.time_method(&tiny_method(), &scenes(1000), 1, 4).unwrap();
        assert_eq!(timing.clock, Clock::GpuTimestamp);
        assert_eq!(timing.configurations, 1000);
        assert_eq!(timing.warmup, 1);
        assert_eq!(timing.id, "test.tiny");
        assert_durations(&timing.ns, 4);
        assert_eq!(serde_json::to_value(timing.clock).unwrap(), "gpu-timestamp");
    }

    #[test]
    fn the_wall_clock_when_asked() {
        let g = gpu();
        let timer = g.dispatch_timer_with(&scenes(300), Clock::Wall).unwrap();
        assert_eq!(timer.clock(), Clock::Wall);
        assert_eq!(timer.configurations(), 300);
        assert_eq!(timer.dispatches(), 1);
        let pipeline = timer.pipeline(&tiny_method()).unwrap();
        let ns: Vec<f64> = (0..3).map(|_| timer.time(&pipeline).unwrap()).collect();
        assert_durations(&ns, 3);
        assert_eq!(serde_json::to_value(Clock::Wall).unwrap(), "wall");
    }

    #[test]
    fn nothing_to_time_and_a_bad_param_count_are_errors() {
        let g = gpu();
        let e = g.dispatch_timer(&[]).err().expect("no scenes is an error");
        assert!(e.to_string().contains("no configurations"), "{e}");
        let timer = g.dispatch_timer(&scenes(10)).unwrap();
        let mut m = tiny_method();
        m.params = vec![3.0];
        let e = timer.pipeline(&m).err().expect("a param the kernel lacks is an error");
        assert!(
            e.to_string().contains("takes 0 param(s)") && e.to_string().contains("1 given"),
            "{e}"
        );
    }
}
