//! `linelight scan`: a stability scan on the GPU. Configurations are generated on the device
//! from the case's seed and distributions with a counter-based RNG (`generate.wgsl`), each
//! method runs on them, and the device only counts NaN, ±inf, negative and above-bound
//! values; the first offending configurations are captured for replay with `linelight eval`.
//! No value is read back, so 10⁹ configurations cost only the arithmetic.
//!
//! The result is counts per method and family; the analyse stage makes them a rate with an exact
//! (Clopper–Pearson) 95 % interval (`analyse::scan`).

use crate::input::case::{Case, Dist, MaterialKind};
use crate::input::scene::{Config, Material};
use crate::input::target::Target;
use crate::kernel::compose_with;
use crate::kernel::methods::Method;
use crate::limits::MAX_CAPTURE;
use crate::measure::gpu::{count_trips, override_constants, scoped, truncated, Gpu};
use anyhow::Context;
use bytemuck::{Pod, Zeroable};
use serde::Serialize;

const GENERATE: &str = include_str!("generate.wgsl");
const ENTRY: &str = "ll_scan_main";
const WORKGROUP: u64 = 64;
/// Configurations per dispatch, at most (the device's workgroup limit may lower it).
const PER_DISPATCH: u64 = 1 << 22;
/// Dispatches per submit (one readback of the counts each).
const PER_SUBMIT: u64 = 8;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Params {
    base_lo: u32,
    base_hi: u32,
    count: u32,
    family: u32,
    seed_lo: u32,
    seed_hi: u32,
    material: u32,
    capture: u32,
    bound: f32,
    has_bound: u32,
    /// Loop trips at which a configuration counts as cut short by the driver (0: not counted).
    trip_limit: u32,
    pad: u32,
    dists: [[f32; 4]; 16],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Debug)]
struct Captured {
    p1: [f32; 4],
    p2: [f32; 4],
    rows: [[f32; 4]; 3],
    index_lo: u32,
    index_hi: u32,
    value: f32,
    why: u32,
}

/// What a scan of one method over one family counted (the analyse stage adds the rate and its
/// interval, `analyse::scan`).
#[derive(Clone, Debug, Serialize)]
pub struct ScanCounts {
    pub method: String,
    pub family: String,
    /// Configurations evaluated: those generated, less the degenerate ones.
    pub configurations: u64,
    /// Generated configurations the sweep's sampler would redraw (not representable in f32,
    /// the shading point on the segment, a singular M⁻¹): skipped, never evaluated.
    pub degenerate: u64,
    pub nan: u64,
    pub inf: u64,
    pub negative: u64,
    pub above_bound: Option<u64>,
    /// Values above the light's bound B (docs/scan.md): the same light with D replaced by an
    /// upper bound of its maximum, a bound every method's true value lies under.
    pub above_light_bound: u64,
}

/// A scan of one method over one family, raw: the counts, the time, the first offenders.
#[derive(Clone, Debug)]
pub struct Scanned {
    pub counts: ScanCounts,
    /// Offending values: the sum of the NaN, inf, negative, above-bound and above-B counts.
    pub offending: u64,
    pub seconds: f64,
    /// The first offending configurations, in the eval input format.
    pub captured: Vec<Config>,
}

/// The case's distributions for one family, in the generator's slots.
fn dists(case: &Case, family: usize) -> [[f32; 4]; 16] {
    let f = &case.materials[family];
    let g = case.geometry_of(f);
    let enc = |d: Option<&Dist>, default: f64| -> [f32; 4] {
        match d {
            None => [4.0, 0.0, 0.0, default as f32],
            Some(Dist::Fixed { value }) => [0.0, *value as f32, 0.0, 0.0],
            Some(Dist::Uniform { min, max }) => [1.0, *min as f32, *max as f32, 0.0],
            Some(Dist::LogUniform { min, max }) => [2.0, *min as f32, *max as f32, 0.0],
            Some(Dist::SignedLogUniform { min, max }) => [3.0, *min as f32, *max as f32, 0.0],
        }
    };
    let mut out = [[4.0, 0.0, 0.0, 0.0]; 16];
    let slots = [
        enc(Some(&g.distance), 1.0),
        enc(Some(&g.elevation), 0.0),
        enc(Some(&g.azimuth), 0.0),
        enc(Some(&g.tilt_angle), 0.0),
        enc(Some(&g.length), 1.0),
        enc(Some(&g.center), 0.0),
        enc(g.endpoint_height.as_ref(), 0.0),
        enc(f.alpha.as_ref(), 1.0),
        enc(f.aspect.as_ref(), 1.0),
        enc(f.peak.as_ref(), 0.0),
        enc(f.shear.as_ref(), 0.0),
        enc(f.rotation.as_ref(), 0.0),
    ];
    out[..slots.len()].copy_from_slice(&slots);
    out
}

/// Whether the device can generate a family's materials: diffuse and synthetic LTC lobes; a
/// `ggx` or `ltc_ggx` family takes its M⁻¹ from a fitted table on the CPU.
pub fn generated_on_device(kind: MaterialKind) -> bool {
    matches!(
        kind,
        MaterialKind::Diffuse | MaterialKind::LtcSparse | MaterialKind::LtcFull
    )
}

/// How much to scan: configurations per family, offenders to capture, the optional bound.
#[derive(Clone, Copy, Debug)]
pub struct ScanSize {
    pub count: u64,
    pub capture: usize,
    pub bound: Option<f64>,
}

/// Scans `method` over `size.count` generated configurations of `family`; `progress` gets the
/// configurations done and the offenders so far.
pub fn scan(
    gpu: &Gpu,
    case: &Case,
    method: &Method,
    family: usize,
    size: ScanSize,
    progress: &mut dyn FnMut(u64, u64),
) -> anyhow::Result<Scanned> {
    let ScanSize { count, capture, bound } = size;
    anyhow::ensure!(
        capture <= MAX_CAPTURE,
        "--capture {capture}: at most {MAX_CAPTURE} offending configurations are kept per method and family"
    );
    if !matches!(method.target(), Target::Line | Target::LineUpper) {
        anyhow::bail!(
            "scan generates line configurations only: `{}` approximates `{}`",
            method.label,
            method.target()
        );
    }
    let fam = &case.materials[family];
    let material = match fam.kind {
        MaterialKind::Diffuse => 0u32,
        MaterialKind::LtcSparse => 1,
        MaterialKind::LtcFull => 2,
        // Their M⁻¹ comes from a fitted table or fit on the CPU: not generated on the device.
        MaterialKind::Ggx | MaterialKind::LtcGgx => anyhow::bail!(
            "scan generates diffuse and synthetic LTC families only; `{}` is a {:?} family",
            fam.name,
            fam.kind
        ),
    };
    // The driver's loop limit, as every command applies it (gpu/loops.rs): a static trip
    // count past it is refused here; loops of no static trip count are counted in the same
    // dispatch, and a configuration that reaches `trip_limit` stops the scan.
    let trip_limit = gpu.check_loops(method)?;
    let mut composed = compose_with(
        &method.kernel,
        method.inner.as_deref().map(|m| &m.kernel),
        gpu.capabilities,
    )?;
    if trip_limit.is_some() {
        composed.source = count_trips(&composed.source);
    }
    let trip_limit = trip_limit.map_or(0, |l| u32::try_from(l.max(1)).unwrap_or(u32::MAX));
    let (_, _, constants) = override_constants(method, &composed)?;
    let constants: Vec<(&str, f64)> = constants.iter().map(|(n, v)| (n.as_str(), *v)).collect();
    let scene = if method.kernel.uses_line {
        "ll_scene"
    } else {
        "let ll_scene"
    };
    let source = format!("{}\n{}", composed.source, GENERATE.replace("{scene}", scene));
    let device = &gpu.device;
    let pipeline = scoped(device, || {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("linelight scan"),
            source: wgpu::ShaderSource::Wgsl(source.as_str().into()),
        });
        device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("linelight scan"),
            layout: None,
            module: &module,
            entry_point: Some(ENTRY),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants: &constants,
                ..Default::default()
            },
            cache: None,
        })
    })
    .with_context(|| format!("{}: the scan pipeline does not build", method.kernel.path))?;

    use wgpu::BufferUsages as U;
    let buffer = |label, size: u64, usage| {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage,
            mapped_at_creation: false,
        })
    };
    let slots = capture.max(1) as u64;
    let capture_bytes = slots * std::mem::size_of::<Captured>() as u64;
    let params_size = std::mem::size_of::<Params>() as u64;
    // One uniform slot per dispatch of a submit (256-byte aligned), written before the submit.
    let stride = params_size.div_ceil(256) * 256;
    let params_buf = buffer("ll_scan params", stride * PER_SUBMIT, U::UNIFORM | U::COPY_DST);
    let counts = buffer("ll_scan counts", 32, U::STORAGE | U::COPY_DST | U::COPY_SRC);
    let captured_buf = buffer("ll_scan captured", capture_bytes, U::STORAGE | U::COPY_SRC);
    let readback = buffer("ll_scan readback", 32 + capture_bytes, U::MAP_READ | U::COPY_DST);
    let layout = pipeline.get_bind_group_layout(0);
    let groups: Vec<wgpu::BindGroup> = (0..PER_SUBMIT)
        .map(|k| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("linelight scan"),
                layout: &layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 3,
                        resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                            buffer: &params_buf,
                            offset: k * stride,
                            size: std::num::NonZeroU64::new(params_size),
                        }),
                    },
                    wgpu::BindGroupEntry {
                        binding: 4,
                        resource: counts.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 5,
                        resource: captured_buf.as_entire_binding(),
                    },
                ],
            })
        })
        .collect();

    let per_dispatch = PER_DISPATCH.min(u64::from(device.limits().max_compute_workgroups_per_dimension) * WORKGROUP);
    let start = std::time::Instant::now();
    let (mut totals, mut captured) = ([0u64; 4], Vec::<Captured>::new());
    let mut above_light = 0u64;
    let (mut done, mut degenerate) = (0u64, 0u64);
    // As the sweep's sampler: past 1 % (+10) the skipped ones would change the distribution.
    let allowed = crate::input::sampler::redraw_limit(usize::try_from(count).unwrap_or(usize::MAX)) as u64;
    let too_many = |degenerate: u64| {
        anyhow::anyhow!(
            "case `{}`: family `{}`: {degenerate} of {count} generated configurations were degenerate (more than \
             the {allowed} the sweep would redraw, which would change the distribution): not representable in \
             f32 (size outside 2^±60, an M⁻¹ entry above 2^60), the shading point on the segment or a singular \
             M⁻¹; check distance, length, center or the lobe's alpha, aspect, peak, shear",
            case.name,
            fam.name
        )
    };
    while done < count {
        let mut encoder = device.create_command_encoder(&Default::default());
        encoder.clear_buffer(&counts, 0, None);
        let mut in_submit = 0u64;
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline);
            for (k, group) in groups.iter().enumerate() {
                let base = done + in_submit;
                if base >= count {
                    break;
                }
                let n = per_dispatch.min(count - base);
                let params = Params {
                    base_lo: base as u32,
                    base_hi: (base >> 32) as u32,
                    count: n as u32,
                    family: family as u32,
                    seed_lo: case.seed as u32,
                    seed_hi: (case.seed >> 32) as u32,
                    material,
                    capture: (capture - captured.len().min(capture)) as u32,
                    bound: bound.unwrap_or(0.0) as f32,
                    has_bound: bound.is_some() as u32,
                    trip_limit,
                    pad: 0,
                    dists: dists(case, family),
                };
                gpu.queue
                    .write_buffer(&params_buf, k as u64 * stride, bytemuck::bytes_of(&params));
                pass.set_bind_group(0, group, &[]);
                pass.dispatch_workgroups(n.div_ceil(WORKGROUP) as u32, 1, 1);
                in_submit += n;
            }
        }
        encoder.copy_buffer_to_buffer(&counts, 0, &readback, 0, 32);
        encoder.copy_buffer_to_buffer(&captured_buf, 0, &readback, 32, capture_bytes);
        gpu.queue.submit([encoder.finish()]);

        let slice = readback.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        // A device lost or a failed readback is the GPU failing at run time (exit 4).
        let failed = |message: String| crate::measure::gpu::GpuError::Run {
            method: method.label.clone(),
            message,
        };
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| failed(format!("the device was lost during the scan: {e}")))?;
        rx.recv()?
            .map_err(|e| failed(format!("cannot read the scan's counts: {e}")))?;
        {
            let view = slice
                .get_mapped_range()
                .map_err(|e| failed(format!("cannot read the scan's counts: {e}")))?;
            let c: &[u32] = bytemuck::cast_slice(&view[..32]);
            for (t, &n) in totals.iter_mut().zip(c) {
                *t += u64::from(n);
            }
            degenerate += u64::from(c[6]);
            above_light += u64::from(c[7]);
            if degenerate > allowed {
                return Err(too_many(degenerate));
            }
            if c[5] > 0 {
                // Earlier submits had none: these are of the first done + in_submit.
                return Err(truncated(
                    &format!("{} on family `{}`", method.describe(), fam.name),
                    u64::from(c[5]),
                    done + in_submit,
                    None,
                    u64::from(trip_limit),
                )
                .into());
            }
            // This submit wrote min(offenders, slots asked for) records, from slot 0.
            let asked = capture - captured.len().min(capture);
            let wrote = (c[4] as usize).min(asked);
            let records: &[Captured] = bytemuck::cast_slice(&view[32..]);
            captured.extend_from_slice(&records[..wrote]);
        }
        readback.unmap();
        done += in_submit;
        progress(done, totals.iter().sum::<u64>() + above_light);
    }
    let seconds = start.elapsed().as_secs_f64();
    let evaluated = count - degenerate;
    let offending: u64 = totals.iter().sum::<u64>() + above_light;
    let captured = captured
        .iter()
        .map(|c| {
            let v = |a: [f32; 4]| [a[0] as f64, a[1] as f64, a[2] as f64];
            let why = ["nan", "inf", "negative", "above", "above_light"][(c.why.clamp(1, 5) - 1) as usize];
            let index = (u64::from(c.index_hi) << 32) | u64::from(c.index_lo);
            Config {
                id: format!("scan-{}-{}-{index}-{why}", method.label, fam.name),
                p1: v(c.p1),
                p2: v(c.p2),
                radius: None,
                rect: None,
                material: if material == 0 {
                    Material::Diffuse
                } else {
                    Material::Ltc { minv: c.rows.map(v) }
                },
                texture: None,
            }
        })
        .collect();
    Ok(Scanned {
        counts: ScanCounts {
            method: method.label.clone(),
            family: fam.name.clone(),
            configurations: evaluated,
            degenerate,
            nan: totals[0],
            inf: totals[1],
            negative: totals[2],
            above_bound: bound.map(|_| totals[3]),
            above_light_bound: above_light,
        },
        offending,
        seconds,
        captured,
    })
}
