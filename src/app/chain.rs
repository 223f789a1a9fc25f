//! `linelight chain`: the error chain from the GGX BRDF to the pixel, per configuration, for
//! a case of `ggx` materials (cases/ggx.toml → reports/ggx-chain/chain.md, chain.csv, chain.json).
//!
//! Every link is measured against the GGX truth T (the f64 reference of the `ggx` lobe), so
//! the links add up to the total:
//!
//! | link | value compared | with |
//! |---|---|---|
//! | fit | exact integral of the exact per-configuration fit (× its magnitude) | T |
//! | table | exact integral of the table's bilinear f32 look-up | the exact fit's |
//! | storage | the same with binary16 texels | the f32 look-up's |
//! | formula | the method in f64 on the look-up | the look-up's exact integral |
//! | rounding | the method in f32 on the CPU | the method in f64 |
//! | driver | the GPU | the CPU f32 |
//!
//! each as |a − b|/T. The look-up is our isotropic table for isotropic roughness and our
//! anisotropic table (seed 004, `data/ltc_ggx_aniso.csv`, quadrilinear) for anisotropic
//! roughness. The published table (Heitz et al. 2016, shipped in data/ltc_code/) is run through
//! the same look-up beside ours on isotropic configurations.

use crate::analyse::stats::{bin_index, Quantiles};
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
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

/// The links, in chain order.
pub const LINKS: [&str; 6] = ["fit", "table", "storage", "formula", "rounding", "driver"];

/// One configuration's chain for one method.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    pub config: usize,
    pub method: String,
    pub family: String,
    pub alpha: f64,
    pub view_angle: f64,
    pub anisotropy: f64,
    /// α_min/α_max as shaded (after each α is clamped to 1); 1 for isotropic roughness.
    pub ratio: f64,
    pub truth: f64,
    /// Relative size of each link (NaN where it does not apply).
    pub links: [f64; 6],
    /// |GPU − T|/T with our feed (the isotropic table, or the anisotropic one).
    pub total: f64,
    /// Isotropic only: the same method fed the published table (f32 bilinear): |GPU − T|/T,
    /// and that look-up's exact LTC integral against T.
    pub published_total: f64,
    pub published_fit: f64,
    /// Our table's look-up (isotropic or anisotropic), exact LTC integral against T.
    pub table_fit: f64,
    /// Angle (degrees) between the mirror direction of the view and the segment's nearest
    /// direction: how close the light comes to the lobe's peak.
    pub miss: f64,
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
    let Material::Ggx { alpha, view, .. } = &c.material else {
        return Err(format!("`{}`: the chain needs ggx materials", c.id));
    };
    Ok(Config {
        material: Material::ggx(*alpha, *view, Some(feed.name()))?,
        ..c.clone()
    })
}

/// The exact integral of the fed LTC (times its magnitude), by the f64 references.
fn ltc_exact(c: &Config, target: Target) -> f64 {
    let (fed, magnitude) = c.fed();
    reference(&fed, target).map_or(f64::NAN, |e| e.value * magnitude)
}

fn rel(a: f64, b: f64, truth: f64) -> f64 {
    (a - b).abs() / truth.abs()
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

pub struct ChainRun {
    pub rows: Vec<Row>,
    pub seconds: f64,
    pub configurations: usize,
    pub adapter: String,
}

/// `linelight chain CASE [--out DIR] [--count N]`: the output folder (default
/// `reports/<case>-chain`, a chain report folder of its own) and the run's size checked before
/// any work, then measured and written.
pub fn run(
    case_path: &Path,
    out: Option<std::path::PathBuf>,
    count: Option<usize>,
    options: &super::GpuOptions,
) -> anyhow::Result<super::Status> {
    let case = Case::load(case_path)?;
    let dir = out.unwrap_or_else(|| Path::new("reports").join(format!("{}-chain", case.name)));
    let mut plan = crate::io::OutputPlan::new();
    plan.input("the case file", case_path);
    plan.set("--out", &dir, crate::io::SetKind::Chain).check()?;
    let case = sized(&case, count)?;
    let device = super::open_gpu(options.adapter.as_deref())?;
    let run = measure(&case, &device, None, options.chunk)?;
    for path in write(&dir, &case_path.display().to_string(), &case, &run)? {
        eprintln!("wrote {}", path.display());
    }
    Ok(super::Status::Ok)
}

/// The case with `--count` applied, refused when a count or the memory it takes is past the
/// limits: the chain holds every configuration, its feeds and rows.
fn sized(case: &Case, count: Option<usize>) -> anyhow::Result<Case> {
    let mut case = case.clone();
    if let Some(n) = count {
        crate::limits::check_count("--count", n as u64).map_err(anyhow::Error::msg)?;
        for m in &mut case.materials {
            m.count = n;
        }
    }
    let configurations = case
        .materials
        .iter()
        .fold(0u64, |t, m| t.saturating_add(m.count as u64));
    let methods = case.methods.len() as u64;
    let mut budget = crate::limits::Budget::new();
    budget.add(
        format!("{configurations} configurations × {methods} methods, every one held"),
        crate::limits::chain_estimate(configurations, methods),
    );
    budget
        .check(&format!("chain of case `{}`", case.name))
        .map_err(anyhow::Error::msg)?;
    Ok(case)
}

/// Measures the chain for every configuration of the case and every method in it.
pub fn measure(case: &Case, gpu: &Gpu, count: Option<usize>, chunk: usize) -> anyhow::Result<ChainRun> {
    let start = Instant::now();
    let case = sized(case, count)?;
    let kernels = methods::kernel_set(&[])?;
    let methods: Vec<Method> = case
        .methods
        .iter()
        .map(|s| methods::resolve(s, &kernels))
        .collect::<anyhow::Result<_>>()?;
    let samples: Vec<Sample> = sampler::sample_case(&case);
    let base: Vec<Config> = samples.iter().map(|s| s.config.clone()).collect();
    let iso: Vec<bool> = base
        .iter()
        .map(|c| matches!(&c.material, Material::Ggx { alpha, .. } if alpha.xy()[0] == alpha.xy()[1]))
        .collect();
    let published_ok = match crate::input::ltc::table::published() {
        Ok(_) => true,
        Err(e) => {
            // Never dropped in silence: the report's table loses a row.
            eprintln!("WARNING: the `published` feed is left out of this chain: {e}");
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
                if published_ok {
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

    let mut rows = Vec::new();
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
            let [truth, fit, table, table16, publ] = refs[i];
            if !(truth > 0.0) {
                continue; // the light is not seen: no relative error to chain
            }
            let (gpu_v, cpu_v, f64_v) = v_ours[i];
            let lookup = table;
            let s = &samples[i];
            rows.push(Row {
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
                links: [
                    rel(fit, truth, truth),
                    rel(table, fit, truth),
                    rel(table16, table, truth),
                    rel(f64_v, lookup, truth),
                    rel(cpu_v, f64_v, truth),
                    rel(gpu_v, cpu_v, truth),
                ],
                total: rel(gpu_v, truth, truth),
                published_total: v_pub[i].map_or(f64::NAN, |v| rel(v.0, truth, truth)),
                published_fit: rel(publ, truth, truth),
                table_fit: rel(table, truth, truth),
                miss: miss_angle(&base[i]),
            });
        }
    }
    Ok(ChainRun {
        rows,
        seconds: start.elapsed().as_secs_f64(),
        configurations: base.len(),
        adapter: gpu.adapter.to_string(),
    })
}

/// The nearest-rank median of the finite values (analyse::stats), None when there are none.
fn median(values: impl Iterator<Item = f64>) -> Option<f64> {
    let v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
    crate::analyse::stats::median(&v)
}

fn quantiles(values: impl Iterator<Item = f64>) -> Option<Quantiles> {
    let mut v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
    Quantiles::of(&mut v)
}

fn sci(x: Option<f64>) -> String {
    x.map_or("–".into(), |v| format!("{v:.2e}"))
}

/// One bin's medians per link and the link that dominates.
#[derive(Clone, Debug, Serialize)]
pub struct Cell {
    pub method: String,
    pub family: String,
    pub alpha: [f64; 2],
    pub view_angle: [f64; 2],
    pub count: usize,
    pub links: [Option<f64>; 6],
    pub total: Option<f64>,
    pub dominant: Option<&'static str>,
}

fn cells(run: &ChainRun, alpha_edges: &[f64], view_edges: &[f64]) -> Vec<Cell> {
    let mut out = Vec::new();
    let mut keys: Vec<(String, String)> = run.rows.iter().map(|r| (r.method.clone(), r.family.clone())).collect();
    keys.dedup();
    keys.sort();
    keys.dedup();
    for (method, family) in keys {
        for a in 0..alpha_edges.len() - 1 {
            for v in 0..view_edges.len() - 1 {
                let rows: Vec<&Row> = run
                    .rows
                    .iter()
                    .filter(|r| r.method == method && r.family == family)
                    .filter(|r| {
                        bin_index(alpha_edges, r.alpha) == Some(a) && bin_index(view_edges, r.view_angle) == Some(v)
                    })
                    .collect();
                let links: [Option<f64>; 6] = std::array::from_fn(|k| median(rows.iter().map(|r| r.links[k])));
                let dominant = LINKS
                    .iter()
                    .zip(links)
                    .filter_map(|(n, l)| l.map(|l| (*n, l)))
                    .max_by(|x, y| x.1.total_cmp(&y.1))
                    .map(|(n, _)| n);
                out.push(Cell {
                    method: method.clone(),
                    family: family.clone(),
                    alpha: [alpha_edges[a], alpha_edges[a + 1]],
                    view_angle: [view_edges[v], view_edges[v + 1]],
                    count: rows.len(),
                    links,
                    total: median(rows.iter().map(|r| r.total)),
                    dominant: if rows.is_empty() { None } else { dominant },
                });
            }
        }
    }
    out
}

/// Writes chain.md, chain.csv and chain.json as the chain report folder `dir` (a set of its
/// own, replaced whole).
pub fn write(dir: &Path, case_path: &str, case: &Case, run: &ChainRun) -> anyhow::Result<Vec<std::path::PathBuf>> {
    let alpha_edges = [0.01, 0.03, 0.1, 0.3, 1.0];
    let view_edges = [0.0, 30.0, 60.0, 75.0, 90.0];
    let cells = cells(run, &alpha_edges, &view_edges);
    let mut md = String::new();
    let _ = writeln!(md, "# The GGX error chain: {}\n", case.title);
    let _ = writeln!(
        md,
        "Generated by `linelight chain {case_path}` from {} configurations on {} in {:.0} s. \
         Every number below comes from that run (chain.csv holds each bin, chain.json each configuration).\n",
        run.configurations, run.adapter, run.seconds
    );
    if let Some(fit) = fit_record() {
        let _ = writeln!(md, "{fit}\n");
    }
    let _ = writeln!(
        md,
        "Links, each |a − b| / T with T the f64 GGX reference: **fit** (exact fit's LTC integral − T), \
         **table** (bilinear f32 look-up of our table − exact fit), **storage** (binary16 texels − f32), \
         **formula** (method in f64 − exact integral of what it was fed), **rounding** (CPU f32 − f64), \
         **driver** (GPU − CPU f32). Anisotropic roughness is fed our anisotropic table (seed 004, \
         quadrilinear, M inverted in f32: docs/ggx.md); its table link is that look-up against the exact fit.\n"
    );
    let _ = writeln!(md, "## Findings\n");
    for f in findings(run, &cells) {
        let _ = writeln!(md, "- {f}");
    }
    let _ = writeln!(md, "\n## Our table beside the published one\n");
    let _ = writeln!(
        md,
        "Isotropic configurations, relative error against the GGX truth: the exact LTC integral of each \
         table's bilinear f32 look-up, and the GPU result of the method fed it. \"Published\" is the published \
         table renormalised per node (each M⁻¹ divided by its own m22, so m22 = 1) before bilinear filtering, \
         as our table is stored (docs/ggx.md): not the published demo's texture, which divides by another \
         entry and so interpolates differently.\n"
    );
    let _ = writeln!(md, "| method | n | ours: LTC exact median | published: LTC exact median | ours: GPU median [p90] | published: GPU median [p90] |");
    let _ = writeln!(md, "|---|---:|---:|---:|---:|---:|");
    for (method, rows) in by_method(run, true) {
        let q = |f: &dyn Fn(&Row) -> f64| quantiles(rows.iter().map(|r| f(r)));
        let show = |x: Option<Quantiles>| x.map_or("–".into(), |q| format!("{:.3e} [{:.3e}]", q.median, q.p90));
        let _ = writeln!(
            md,
            "| `{method}` | {} | {} | {} | {} | {} |",
            rows.len(),
            sci(q(&|r| r.table_fit).map(|q| q.median)),
            sci(q(&|r| r.published_fit).map(|q| q.median)),
            show(q(&|r| r.total)),
            show(q(&|r| r.published_total)),
        );
    }
    let _ = writeln!(
        md,
        "\nThe same, by how close the light comes to the lobe's peak: the angle between the view's mirror \
         direction and the segment's nearest direction (degrees). Medians of |GPU − T|/T.\n"
    );
    let miss_edges = [0.0, 2.0, 5.0, 15.0, 45.0, 180.0];
    let _ = writeln!(md, "| method | miss angle | n | ours | published |");
    let _ = writeln!(md, "|---|---|---:|---:|---:|");
    for (method, rows) in by_method(run, true) {
        for w in miss_edges.windows(2) {
            let rs: Vec<&&Row> = rows.iter().filter(|r| r.miss >= w[0] && r.miss < w[1]).collect();
            if rs.is_empty() {
                continue;
            }
            let _ = writeln!(
                md,
                "| `{method}` | {}–{} | {} | {} | {} |",
                w[0],
                w[1],
                rs.len(),
                sci(median(rs.iter().map(|r| r.total))),
                sci(median(rs.iter().map(|r| r.published_total)))
            );
        }
    }
    let _ = writeln!(md, "\n## Which link dominates\n");
    let _ = writeln!(
        md,
        "Median of each link per bin of roughness α × view angle (degrees); the largest is in bold.\n"
    );
    let mut keys: Vec<(String, String)> = cells.iter().map(|c| (c.method.clone(), c.family.clone())).collect();
    keys.dedup();
    for (method, family) in keys {
        let _ = writeln!(md, "### `{method}` on `{family}`\n");
        let _ = writeln!(
            md,
            "| α | view | n | fit | table | storage | formula | rounding | driver | total |"
        );
        let _ = writeln!(md, "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|");
        for c in cells
            .iter()
            .filter(|c| c.method == method && c.family == family && c.count > 0)
        {
            let links: Vec<String> = LINKS
                .iter()
                .zip(c.links)
                .map(|(n, l)| {
                    let s = sci(l);
                    if Some(*n) == c.dominant {
                        format!("**{s}**")
                    } else {
                        s
                    }
                })
                .collect();
            let _ = writeln!(
                md,
                "| {}–{} | {}–{} | {} | {} | {} |",
                c.alpha[0],
                c.alpha[1],
                c.view_angle[0],
                c.view_angle[1],
                c.count,
                links.join(" | "),
                sci(c.total)
            );
        }
        let _ = writeln!(md);
    }
    aniso_section(&mut md, run);
    let mut csv = String::from("method,family,alpha_lo,alpha_hi,view_lo,view_hi,count,fit,table,storage,formula,rounding,driver,total,dominant\n");
    for c in &cells {
        let f = |x: Option<f64>| x.map_or(String::new(), |v| format!("{v:e}"));
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            c.method,
            c.family,
            c.alpha[0],
            c.alpha[1],
            c.view_angle[0],
            c.view_angle[1],
            c.count,
            f(c.links[0]),
            f(c.links[1]),
            f(c.links[2]),
            f(c.links[3]),
            f(c.links[4]),
            f(c.links[5]),
            f(c.total),
            c.dominant.unwrap_or("")
        );
    }
    let json = serde_json::json!({
        "case": case_path,
        "configurations": run.configurations,
        "adapter": run.adapter,
        "seconds": run.seconds,
        "cells": cells,
        "rows": run.rows.iter().map(|r| {
            let num = crate::measure::eval_rows::number;
            serde_json::json!({
                "config": r.config, "method": r.method, "family": r.family, "alpha": num(r.alpha),
                "view_angle": num(r.view_angle), "anisotropy": num(r.anisotropy), "ratio": num(r.ratio), "truth": num(r.truth),
                "links": r.links.iter().map(|&x| num(x)).collect::<Vec<_>>(), "total": num(r.total),
                "published_total": num(r.published_total), "published_fit": num(r.published_fit),
                "table_fit": num(r.table_fit), "miss_degrees": num(r.miss),
            })
        }).collect::<Vec<_>>(),
    });
    let files = vec![
        ("chain.md".to_string(), md.into_bytes()),
        ("chain.csv".to_string(), csv.into_bytes()),
        ("chain.json".to_string(), serde_json::to_vec(&json)?),
    ];
    // Its own report folder, swapped in whole: never mixed into a sweep's.
    Ok(crate::io::write_set(dir, crate::io::SetKind::Chain, &files)?)
}

/// Bin edges of the anisotropic chain: α_min/α_max as shaded.
const RATIO_EDGES: [f64; 5] = [0.25, 0.4, 0.6, 0.8, 1.0];

/// Median links per bin of two axes, over the given rows: (x bin, y bin, count, links,
/// total, dominant link).
type Bin2 = (
    [f64; 2],
    [f64; 2],
    usize,
    [Option<f64>; 6],
    Option<f64>,
    Option<&'static str>,
);

fn bins2(rows: &[&Row], fx: fn(&Row) -> f64, ex: &[f64], fy: fn(&Row) -> f64, ey: &[f64]) -> Vec<Bin2> {
    let mut out = Vec::new();
    for x in 0..ex.len() - 1 {
        for y in 0..ey.len() - 1 {
            let rs: Vec<&&Row> = rows
                .iter()
                .filter(|r| bin_index(ex, fx(r)) == Some(x) && bin_index(ey, fy(r)) == Some(y))
                .collect();
            if rs.is_empty() {
                continue;
            }
            let links: [Option<f64>; 6] = std::array::from_fn(|k| median(rs.iter().map(|r| r.links[k])));
            let dominant = LINKS
                .iter()
                .zip(links)
                .filter_map(|(n, l)| l.map(|l| (*n, l)))
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .map(|(n, _)| n);
            out.push((
                [ex[x], ex[x + 1]],
                [ey[y], ey[y + 1]],
                rs.len(),
                links,
                median(rs.iter().map(|r| r.total)),
                dominant,
            ));
        }
    }
    out
}

fn bin_table(md: &mut String, xname: &str, yname: &str, bins: &[Bin2]) {
    let _ = writeln!(
        md,
        "| {xname} | {yname} | n | fit | table | storage | formula | rounding | driver | total |"
    );
    let _ = writeln!(md, "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for (x, y, n, links, total, dominant) in bins {
        let cells: Vec<String> = LINKS
            .iter()
            .zip(links)
            .map(|(name, l)| {
                let s = sci(*l);
                if Some(*name) == *dominant {
                    format!("**{s}**")
                } else {
                    s
                }
            })
            .collect();
        let _ = writeln!(
            md,
            "| {}–{} | {}–{} | {n} | {} | {} |",
            x[0],
            x[1],
            y[0],
            y[1],
            cells.join(" | "),
            sci(*total)
        );
    }
    let _ = writeln!(md);
}

/// The anisotropic chain: every anisotropic configuration, binned by α_min/α_max against the
/// view angle and against α, with findings computed from the rows.
fn aniso_section(md: &mut String, run: &ChainRun) {
    let aniso: Vec<&Row> = run.rows.iter().filter(|r| r.ratio < 1.0).collect();
    if aniso.is_empty() {
        return;
    }
    let _ = writeln!(
        md,
        "## The anisotropic chain
"
    );
    if let Some(rec) = aniso_fit_record() {
        let _ = writeln!(
            md,
            "{rec}
"
        );
    }
    let _ = writeln!(
        md,
        "Anisotropic configurations: the methods are fed our 4D table (quadrilinear f32 look-up of M, \
         inverted in f32, in the frame where the view lies in the xz-plane); **fit** is the exact \
         per-configuration fit against T, **table** the look-up's exact LTC integral against the exact \
         fit's, **storage** binary16 texels against f32. Bins of r = α_min/α_max as shaded (each α \
         clamped to 1) against the view angle (degrees) and against the geometric-mean α; medians, \
         the largest link in bold.\n"
    );
    let _ = writeln!(md, "### Findings\n");
    for f in aniso_findings(&aniso) {
        let _ = writeln!(md, "- {f}");
    }
    let _ = writeln!(md);
    let mut methods: Vec<&str> = aniso.iter().map(|r| r.method.as_str()).collect();
    methods.sort();
    methods.dedup();
    let view_edges = [0.0, 30.0, 60.0, 75.0, 90.0];
    let alpha_edges = [0.01, 0.03, 0.1, 0.3, 1.0];
    for m in methods {
        let rows: Vec<&Row> = aniso.iter().copied().filter(|r| r.method == m).collect();
        let _ = writeln!(md, "### `{m}`, anisotropic: r × view angle\n");
        bin_table(
            md,
            "r",
            "view",
            &bins2(&rows, |r| r.ratio, &RATIO_EDGES, |r| r.view_angle, &view_edges),
        );
        let _ = writeln!(md, "### `{m}`, anisotropic: r × α\n");
        bin_table(
            md,
            "r",
            "α",
            &bins2(&rows, |r| r.ratio, &RATIO_EDGES, |r| r.alpha, &alpha_edges),
        );
    }
}

/// Sentences about the anisotropic rows, computed from them.
fn aniso_findings(rows: &[&Row]) -> Vec<String> {
    let mut out = Vec::new();
    let mut methods: Vec<&str> = rows.iter().map(|r| r.method.as_str()).collect();
    methods.sort();
    methods.dedup();
    for m in methods {
        let rs: Vec<&Row> = rows.iter().copied().filter(|r| r.method == m).collect();
        let med = |k: usize| median(rs.iter().map(|r| r.links[k]));
        let bins = bins2(
            &rs,
            |r| r.ratio,
            &RATIO_EDGES,
            |r| r.view_angle,
            &[0.0, 30.0, 60.0, 75.0, 90.0],
        );
        let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
        for b in &bins {
            if let Some(d) = b.5 {
                *counts.entry(d).or_default() += 1;
            }
        }
        let counts: Vec<String> = counts.iter().map(|(k, v)| format!("{k} in {v}")).collect();
        let (fit, table) = (med(0), med(1));
        let compare = match (fit, table) {
            (Some(f), Some(t)) if t > f => {
                format!("the look-up adds more than the fit itself (median table link {t:.2e} against fit {f:.2e})")
            }
            (Some(f), Some(t)) => {
                format!("the look-up adds less than the fit itself (median table link {t:.2e} against fit {f:.2e})")
            }
            _ => "no table or fit link".into(),
        };
        let worst = bins
            .iter()
            .filter(|b| b.3[1].is_some())
            .max_by(|a, b| a.3[1].unwrap_or(0.0).total_cmp(&b.3[1].unwrap_or(0.0)));
        let worst = worst.map_or(String::new(), |b| {
            format!(
                " The table link is largest at r {}–{}, view {}–{}° (median {}, {} configurations).",
                b.0[0],
                b.0[1],
                b.1[0],
                b.1[1],
                sci(b.3[1]),
                b.2
            )
        });
        out.push(format!(
            "`{m}` ({} anisotropic configurations): {compare}; storage in binary16 {}, formula {}, rounding {}, \
             driver {}; total {} (median |GPU − T|/T). Dominant link per r × view bin: {} of {} bins.{worst}",
            rs.len(),
            sci(med(2)),
            sci(med(3)),
            sci(med(4)),
            sci(med(5)),
            sci(median(rs.iter().map(|r| r.total))),
            counts.join(", "),
            bins.len()
        ));
    }
    out
}

/// The anisotropic fit's run record (data/ltc_ggx_aniso.run.json), as a sentence.
fn aniso_fit_record() -> Option<String> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/ltc_ggx_aniso.run.json");
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(path).ok()?).ok()?;
    let size: Vec<String> = v["size"].as_array()?.iter().map(|x| x.to_string()).collect();
    Some(format!(
        "Our anisotropic table (`data/ltc_ggx_aniso.csv`, θ × φ × α_max × r = {}; {} entries fitted, the rest \
         by symmetry) was fitted by `linelight fit --aniso` in {:.0} s on {} thread(s) of this 2-core machine, \
         shared with other jobs (`data/ltc_ggx_aniso.run.json`); relative L1 lobe error of an entry: median \
         {:.2e}, largest {:.2e}.",
        size.join(" × "),
        v["fitted"].as_u64()?,
        v["seconds"].as_f64()?,
        v["threads"].as_u64()?,
        v["fit_l1_median"].as_f64()?,
        v["fit_l1_max"].as_f64()?
    ))
}

fn by_method(run: &ChainRun, iso_only: bool) -> Vec<(String, Vec<&Row>)> {
    let mut out: BTreeMap<String, Vec<&Row>> = BTreeMap::new();
    for r in &run.rows {
        if !iso_only || r.published_total.is_finite() {
            out.entry(r.method.clone()).or_default().push(r);
        }
    }
    out.into_iter().collect()
}

/// The fit's run record (data/ltc_ggx_iso.run.json), as a sentence.
fn fit_record() -> Option<String> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/ltc_ggx_iso.run.json");
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(path).ok()?).ok()?;
    Some(format!(
        "Our isotropic table (`data/ltc_ggx_iso.csv`, {0}×{0}) was fitted by `linelight fit` in {1:.0} s on {2} \
         thread(s) of this 2-core machine, shared with other jobs (`data/ltc_ggx_iso.run.json`); largest relative \
         L1 lobe error of an entry {3:.2e}.",
        v["size"].as_u64()?,
        v["seconds"].as_f64()?,
        v["threads"].as_u64()?,
        v["fit_l1_max"].as_f64()?
    ))
}

/// Sentences computed from the data.
fn findings(run: &ChainRun, cells: &[Cell]) -> Vec<String> {
    let mut out = Vec::new();
    for (method, rows) in by_method(run, false) {
        let fams: Vec<String> = {
            let mut f: Vec<String> = rows.iter().map(|r| r.family.clone()).collect();
            f.sort();
            f.dedup();
            f
        };
        for fam in fams {
            let rs: Vec<&&Row> = rows.iter().filter(|r| r.family == fam).collect();
            let meds: Vec<(&str, Option<f64>)> = LINKS
                .iter()
                .enumerate()
                .map(|(k, n)| (*n, median(rs.iter().map(|r| r.links[k]))))
                .collect();
            let dominant: Vec<&Cell> = cells
                .iter()
                .filter(|c| c.method == method && c.family == fam && c.count > 0)
                .collect();
            let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
            for c in &dominant {
                if let Some(d) = c.dominant {
                    *counts.entry(d).or_default() += 1;
                }
            }
            let counts: Vec<String> = counts.iter().map(|(k, v)| format!("{k} in {v}")).collect();
            let medians: Vec<String> = meds
                .iter()
                .filter_map(|(n, m)| m.map(|m| format!("{n} {m:.2e}")))
                .collect();
            out.push(format!(
                "`{method}` on `{fam}` ({} configurations): the dominant link per bin is {} of {} bins. \
                 Medians over all: {}; total {}.",
                rs.len(),
                counts.join(", "),
                dominant.len(),
                medians.join(", "),
                sci(median(rs.iter().map(|r| r.total)))
            ));
        }
    }
    for (method, rows) in by_method(run, true) {
        let ours = median(rows.iter().map(|r| r.total));
        let theirs = median(rows.iter().map(|r| r.published_total));
        if let (Some(o), Some(t)) = (ours, theirs) {
            let verdict = if o <= t {
                "at least as close to the GGX truth as"
            } else {
                "farther from the GGX truth than"
            };
            let near: Vec<&&Row> = rows.iter().filter(|r| r.miss < 5.0).collect();
            let (no, nt) = (
                median(near.iter().map(|r| r.total)),
                median(near.iter().map(|r| r.published_total)),
            );
            let near_text = match (no, nt) {
                (Some(a), Some(b)) => format!(
                    " On the {} lights that pass within 5° of the mirror direction: {a:.3e} against {b:.3e}.",
                    near.len()
                ),
                _ => String::new(),
            };
            out.push(format!(
                "Fed to `{method}` (bilinear f32 look-up, {} isotropic configurations), our table is {verdict} the \
                 published one: median relative error {o:.3e} against {t:.3e} (ratio {:.3}).{near_text}",
                rows.len(),
                o / t
            ));
        }
    }
    out
}
