//! The GGX error chain, measured (`linelight chain`; docs in src/app/chain.rs): per
//! configuration and method, the GGX truth T, the exact LTC integrals of every feed (the exact
//! fit, our table's f32 and binary16 look-ups, the published table's), and the method's GPU,
//! CPU f32 and f64 values on our feed, and the Fresnel link's two sides (the fed
//! f0·magnitude + (1 − f0)·fresnel and the exact ∫D·F). The links between them are the analyse stage's
//! (`analyse::chain`).

use crate::eval::interp::CpuColumns;
use crate::input::case::Case;
use crate::input::geometry::{v3, DVec3};
use crate::input::ltc::Feed;
use crate::input::sampler::{self, Sample};
use crate::input::scene::{Config, GpuScene, Material};
use crate::input::target::Target;
use crate::kernel::methods::{self, Method};
use crate::measure::gpu::Gpu;
use crate::reference::reference;
use indicatif::ProgressBar;
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::time::Instant;

/// One configuration's measured chain for one method: every value the links compare.
#[derive(Clone, Debug)]
pub struct Point {
    pub config: usize,
    pub method: String,
    pub family: String,
    pub alpha: f64,
    pub view_angle: f64,
    pub anisotropy: f64,
    /// α_min/α_max as shaded (after each α is clamped to 1); 1 for isotropic roughness.
    pub ratio: f64,
    /// The f64 reference of the `ggx` lobe.
    pub truth: f64,
    /// Exact LTC integrals (times the magnitude) of the exact fit, of our table's f32 and
    /// binary16 look-ups (isotropic or anisotropic table), and of the published table's
    /// look-up (NaN where there is none).
    pub fit: f64,
    pub table: f64,
    pub table16: f64,
    pub published_exact: f64,
    /// The method on our feed: GPU, CPU f32 (the evaluator) and f64.
    pub gpu: f64,
    pub cpu_f32: f64,
    pub f64: f64,
    /// The method's GPU value fed the published table (isotropic configurations without a
    /// Fresnel term only: the published table has no Fresnel channel).
    pub published_gpu: Option<f64>,
    /// Schlick's F0 of the material (1 without one).
    pub f0: f64,
    /// The Fresnel link's two sides: what our feed multiplies an LTC method by,
    /// `f0·magnitude + (1 − f0)·fresnel` from the table's channels, and the exact ∫D·F of the
    /// configuration's own lobe (`Ggx::moments`, [`FRESNEL_GRID`]) with its error estimate.
    pub fed_norm: f64,
    pub exact_norm: f64,
    pub exact_norm_error: f64,
    /// Angle (degrees) between the mirror direction of the view and the segment's nearest
    /// direction: how close the light comes to the lobe's peak.
    pub miss: f64,
}

/// Samples per axis of the exact ∫D and ∫D(1 − v·h)⁵ behind the Fresnel link (the fitter's
/// visible-normal quadrature, `Ggx::moments`), and the coarser grid whose difference from it is
/// the exact value's error estimate: the quadrature converges slowly for sharp lobes (512² and
/// 1024² differ by up to 8e-4 of ∫D at α = 0.03 seen head-on, and ∫D(1 − v·h)⁵ alone, the
/// whole of ∫D·F at F0 = 0, by far more there), so the link carries its own resolution.
pub const FRESNEL_GRID: [usize; 2] = [1024, 512];

/// ∫D·F = f0·∫D + (1 − f0)·∫D(1 − v·h)⁵ of the configuration's own GGX lobe, and its error
/// estimate (the difference to the coarser grid).
fn exact_norm(c: &Config) -> (f64, f64) {
    let Material::Ggx { alpha, view, .. } = &c.material else {
        return (f64::NAN, f64::NAN);
    };
    let [ax, ay] = alpha.xy();
    let g = crate::input::ltc::ggx::Ggx { ax, ay, view: *view };
    let f0 = c.material.f0();
    let [fine, coarse] = FRESNEL_GRID.map(|n| {
        let (norm, fresnel, _) = g.moments(n);
        f0 * norm + (1.0 - f0) * fresnel
    });
    (fine, (fine - coarse).abs())
}

/// A measured chain: every configuration × method.
pub struct ChainRun {
    pub points: Vec<Point>,
    pub seconds: f64,
    pub configurations: usize,
    pub adapter: String,
}

/// The angle (degrees) between the mirror direction and the nearest direction of the segment.
fn miss_angle(c: &Config) -> f64 {
    let Material::Ggx { view, .. } = &c.material else {
        return f64::NAN;
    };
    let r = DVec3::new(-view[0], -view[1], view[2]);
    let (p1, p2) = (v3(c.p1), v3(c.p2));
    let cos_at = |t: f64| {
        let p = p1 + t * (p2 - p1);
        p.dot(r) / p.length()
    };
    // A dense look, then golden-section refinement around the best sample.
    let n = 256;
    let best = (0..=n)
        .map(|i| i as f64 / n as f64)
        .max_by(|a, b| cos_at(*a).total_cmp(&cos_at(*b)))
        .unwrap_or(0.0);
    let (mut lo, mut hi) = ((best - 1.0 / n as f64).max(0.0), (best + 1.0 / n as f64).min(1.0));
    for _ in 0..60 {
        let (m1, m2) = (lo + (hi - lo) * 0.382, lo + (hi - lo) * 0.618);
        if cos_at(m1) < cos_at(m2) {
            lo = m1;
        } else {
            hi = m2;
        }
    }
    cos_at(0.5 * (lo + hi)).clamp(-1.0, 1.0).acos().to_degrees()
}

fn bar(len: usize, what: &str) -> ProgressBar {
    crate::measure::progress::bar(len as u64, what)
}

/// The same configuration with its LTC fed from `feed`.
fn with_feed(c: &Config, feed: Feed) -> Result<Config, String> {
    let Material::Ggx { alpha, view, f0, .. } = &c.material else {
        return Err(format!("`{}`: the chain needs ggx materials", c.id));
    };
    Ok(Config {
        material: Material::ggx_fresnel(*alpha, *view, *f0, Some(feed.name()))?,
        ..c.clone()
    })
}

/// The exact integral of the fed LTC (times its magnitude), by the f64 references.
fn ltc_exact(c: &Config, target: Target) -> f64 {
    let (fed, magnitude) = c.fed();
    reference(&fed, target).map_or(f64::NAN, |e| e.value * magnitude)
}

/// Evaluated values of one method on one feed, per configuration: (GPU, CPU f32, f64).
type Values = Vec<(f64, f64, f64)>;

fn run_method(gpu: &Gpu, m: &Method, configs: &[Config], chunk: usize) -> anyhow::Result<Values> {
    let pipeline = gpu.pipeline(m)?;
    let scenes: Vec<GpuScene> = configs.iter().map(GpuScene::from).collect();
    let out = gpu.run(&pipeline, &scenes, chunk, &mut |_| {})?;
    Ok(configs
        .par_iter()
        .zip(out.values)
        .map(|(c, v)| {
            let cpu = m.eval_f32_cpu(c).map_or(f64::NAN, f64::from);
            let f64v = m.eval_f64(c).unwrap_or(f64::NAN);
            (f64::from(v), cpu, f64v)
        })
        .collect())
}

/// Measures the chain for every configuration of the case and every method in it.
pub fn measure(case: &Case, gpu: &Gpu, chunk: usize) -> anyhow::Result<ChainRun> {
    let start = Instant::now();
    let kernels = methods::kernel_set(&[], &crate::kernel::Includes::none())?;
    let methods: Vec<Method> = case
        .methods
        .iter()
        .map(|s| methods::resolve(s, &kernels))
        .collect::<anyhow::Result<_>>()?;
    let samples: Vec<Sample> = sampler::sample_case(case);
    let base: Vec<Config> = samples.iter().map(|s| s.config.clone()).collect();
    let iso: Vec<bool> = base
        .iter()
        .map(|c| matches!(&c.material, Material::Ggx { alpha, .. } if alpha.xy()[0] == alpha.xy()[1]))
        .collect();
    let published_ok = match crate::input::ltc::table::published() {
        Ok(_) => true,
        Err(e) => {
            // Never dropped in silence: the report's table loses a row.
            crate::warnings::raise(crate::warnings::Warning::PublishedFeedLeftOut { reason: e.to_string() });
            false
        }
    };

    // Every feed of every configuration (the exact fits are the slow part).
    let pb = bar(base.len(), "fits and look-ups");
    let feeds: Vec<BTreeMap<&'static str, Config>> = base
        .par_iter()
        .zip(&iso)
        .map(|(c, &iso)| {
            let mut list = vec![Feed::Fit];
            if iso {
                list.extend([Feed::Table, Feed::TableF16]);
                // The published table has no Fresnel channel: with f0 < 1 it is not fed.
                if published_ok && c.material.f0() == 1.0 {
                    list.push(Feed::Published);
                }
            } else {
                list.extend([Feed::Aniso, Feed::AnisoF16]);
            }
            let m = list
                .into_iter()
                .map(|f| with_feed(c, f).map(|c| (f.name(), c)))
                .collect::<Result<BTreeMap<_, _>, _>>();
            pb.inc(1);
            m
        })
        .collect::<Result<_, _>>()
        .map_err(|e| anyhow::anyhow!("case `{}`: {e}", case.name))?;
    pb.finish_and_clear();

    // The Fresnel link's two sides, per configuration (the same for every method).
    let pb = bar(base.len(), "fresnel link");
    let norms: Vec<(f64, (f64, f64))> = (0..base.len())
        .into_par_iter()
        .map(|i| {
            let ours = if iso[i] { "table" } else { "aniso" };
            let fed = feeds[i][ours].material.fed_magnitude().unwrap_or(f64::NAN);
            pb.inc(1);
            (fed, exact_norm(&base[i]))
        })
        .collect();
    pb.finish_and_clear();

    let mut points = Vec::new();
    for m in &methods {
        let target = m.target();
        let ours_feed = |i: usize| if iso[i] { "table" } else { "aniso" };
        let ours: Vec<Config> = (0..base.len()).map(|i| feeds[i][ours_feed(i)].clone()).collect();
        let v_ours = run_method(gpu, m, &ours, chunk)?;
        let published: Vec<Option<&Config>> = feeds.iter().map(|f| f.get("published")).collect();
        let pub_configs: Vec<Config> = published.iter().flatten().map(|c| (*c).clone()).collect();
        let v_pub = run_method(gpu, m, &pub_configs, chunk)?;
        let mut pub_iter = v_pub.into_iter();
        let v_pub: Vec<Option<(f64, f64, f64)>> = published.iter().map(|p| p.and_then(|_| pub_iter.next())).collect();

        let pb = bar(base.len(), &format!("references {}", target.name()));
        let refs: Vec<[f64; 5]> = (0..base.len())
            .into_par_iter()
            .map(|i| {
                let f = &feeds[i];
                let truth = reference(&base[i], target).map_or(f64::NAN, |e| e.value);
                let get = |k: &str| f.get(k).map_or(f64::NAN, |c| ltc_exact(c, target));
                let (t32, t16) = if iso[i] {
                    ("table", "table_f16")
                } else {
                    ("aniso", "aniso_f16")
                };
                let r = [truth, get("fit"), get(t32), get(t16), get("published")];
                pb.inc(1);
                r
            })
            .collect();
        pb.finish_and_clear();
        for i in 0..base.len() {
            let [truth, fit, table, table16, published_exact] = refs[i];
            let (gpu_v, cpu_v, f64_v) = v_ours[i];
            let s = &samples[i];
            points.push(Point {
                config: i,
                method: m.describe(),
                family: case.materials[s.material].name.clone(),
                alpha: s.axes.alpha,
                view_angle: s.axes.view_angle,
                anisotropy: s.axes.anisotropy,
                ratio: match &base[i].material {
                    Material::Ggx { alpha, .. } => {
                        let [x, y] = alpha.xy();
                        x.min(y) / x.max(y)
                    }
                    _ => f64::NAN,
                },
                truth,
                fit,
                table,
                table16,
                published_exact,
                gpu: gpu_v,
                cpu_f32: cpu_v,
                f64: f64_v,
                published_gpu: v_pub[i].map(|v| v.0),
                f0: base[i].material.f0(),
                fed_norm: norms[i].0,
                exact_norm: norms[i].1 .0,
                exact_norm_error: norms[i].1 .1,
                miss: miss_angle(&base[i]),
            });
        }
    }
    Ok(ChainRun {
        points,
        seconds: start.elapsed().as_secs_f64(),
        configurations: base.len(),
        adapter: gpu.adapter.to_string(),
    })
}
