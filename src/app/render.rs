//! `linelight render SCENE.toml --out DIR` (docs/render.md): a floor under the light, one
//! configuration per floor pixel, run through eval's path (GPU f32 per method, f64
//! references, the CPU evaluator's f64 and cpu_f32 columns), written as images, FLIP
//! statistics and the eval files, swapped in whole as one report set.

use super::{open_gpu, GpuOptions, Status};
use crate::input::render_scene::{FloorPixel, RenderScene, GRAZING_DEG};
use crate::input::target::Target;
use crate::kernel::methods::Method;
use crate::measure::eval_rows;
use crate::report::format::{Bytes, Format, Json, Jsonl, Layout, Markdown, Svg};
use crate::report::html::{Gallery, Part};
use crate::report::image::{self, Rgb, Sample};
use crate::report::markup::{Align, Table};
use rayon::prelude::*;
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::Instant;

/// Options of `linelight render`.
#[derive(clap::Args)]
pub struct RenderOptions {
    /// Scene file (TOML with a [render] table), e.g. cases/render/floor_tube.toml.
    pub scene: PathBuf,
    /// The render goes to OUT/<scene name>/.
    #[arg(long, default_value = "reports/render")]
    pub out: PathBuf,
    /// Save this render as a render baseline in DIR (render-baseline.json + images/), for a
    /// later --baseline.
    #[arg(long, value_name = "DIR")]
    pub save_baseline: Option<PathBuf>,
    /// Compare with the render baseline in DIR, pixel by pixel: any regression exits 1.
    #[arg(long, value_name = "DIR")]
    pub baseline: Option<PathBuf>,
    /// Write the render gate's rules as JUnit XML (with --baseline).
    #[arg(long, value_name = "FILE")]
    pub junit: Option<PathBuf>,
    /// A change of a method's mean FLIP against the reference within ±X is no change (0 to 1).
    #[arg(long, value_name = "X", default_value_t = FLIP_NOISE, value_parser = super::options::fraction)]
    pub flip_noise: f64,
    #[command(flatten)]
    pub gpu: GpuOptions,
}

/// The default of `--flip-noise`.
pub const FLIP_NOISE: f64 = 0.001;

/// FLIP thresholds whose share of pixels above is reported.
pub const FLIP_THRESHOLDS: [f64; 4] = [0.05, 0.1, 0.2, 0.5];
/// A failure is visible when at least [`VISIBLE_SHARE`] of the floor pixels have a FLIP
/// above this (and at least one pixel does).
pub const VISIBLE_FLIP: f64 = 0.1;
pub const VISIBLE_SHARE: f64 = 0.001;
/// Worst pixels listed per method.
pub const WORST: usize = 8;

/// What the floor receives of a method's target: the `*_upper` form where there is one.
pub fn received(t: Target) -> Target {
    match t {
        Target::Line => Target::LineUpper,
        other => other,
    }
}

fn secs(t: Instant) -> f64 {
    (t.elapsed().as_secs_f64() * 1000.0).round() / 1000.0
}

/// Nearest-rank quantile of sorted values.
/// The nearest-rank quantile (analyse::stats), None when empty.
fn quantile(sorted: &[f64], q: f64) -> Option<f64> {
    (!sorted.is_empty()).then(|| crate::analyse::stats::nearest_rank(sorted, q))
}

/// Mean, percentiles and shares above the thresholds of a set of FLIP values.
fn flip_stats(values: &mut [f64]) -> Value {
    values.sort_by(f64::total_cmp);
    let n = values.len();
    let mean = if n == 0 {
        None
    } else {
        Some(values.iter().sum::<f64>() / n as f64)
    };
    let above: serde_json::Map<String, Value> = FLIP_THRESHOLDS
        .iter()
        .map(|&t| {
            let k = values.iter().filter(|&&v| v > t).count();
            (
                format!("{t}"),
                json!({"pixels": k, "share": if n == 0 { 0.0 } else { k as f64 / n as f64 }}),
            )
        })
        .collect();
    json!({
        "pixels": n,
        "mean": mean,
        "p50": quantile(values, 0.5),
        "p90": quantile(values, 0.9),
        "p99": quantile(values, 0.99),
        "max": values.last(),
        "above": above,
    })
}

pub fn render(options: RenderOptions) -> anyhow::Result<Status> {
    let gpu = &options.gpu;
    let total = Instant::now();
    let command_line = shell_words::join(std::env::args());
    let scene = RenderScene::load(&options.scene)?;
    let at = options.scene.display().to_string();
    let kernels = crate::kernel::methods::kernel_set(&gpu.kernels)?;
    crate::kernel::methods::check_unique(&scene.methods, &format!("{at}: methods"))?;
    let methods = scene
        .methods
        .iter()
        .map(|s| crate::kernel::methods::resolve(s, &kernels).map_err(|e| anyhow::anyhow!("{at}: methods: {e:#}")))
        .collect::<anyhow::Result<Vec<Method>>>()?;
    let dir = options.out.join(&scene.name);
    // Checked before any work, as every command's outputs are (src/io.rs): the folder is
    // absent, empty or a render folder, and holds no input.
    let mut plan = crate::io::OutputPlan::new();
    plan.input("SCENE", &options.scene);
    for k in &gpu.kernels {
        plan.input("--kernel", k);
    }
    if let Some(b) = &options.baseline {
        plan.input("--baseline", b);
    }
    plan.set("--out", &dir, crate::io::SetKind::Render);
    if let Some(save) = &options.save_baseline {
        plan.set("--save-baseline", save, crate::io::SetKind::RenderBaseline);
    }
    if let Some(junit) = &options.junit {
        plan.file("--junit", junit);
    }
    plan.check()?;
    crate::app::options::check_float("--flip-noise", options.flip_noise, crate::app::options::FRACTION)
        .map_err(anyhow::Error::msg)?;
    if options.junit.is_some() && options.baseline.is_none() {
        anyhow::bail!("--junit writes the render gate's rules: it needs --baseline DIR");
    }
    let started = Instant::now();
    let pixels = scene.floor_pixels().map_err(|e| anyhow::anyhow!("{at}: {e}"))?;
    if pixels.is_empty() {
        anyhow::bail!("{at}: no pixel of the image sees the floor (z = 0): aim the camera at it");
    }
    for m in &methods {
        if let Some(p) = pixels.iter().find(|p| !m.applies(&p.config)) {
            anyhow::bail!(
                "{at}: method `{}` approximates `{}`, which needs {} in render.light (pixel {})",
                m.label,
                m.target(),
                if m.target() == Target::Rectangle {
                    "`rect`"
                } else {
                    "`radius`"
                },
                p.config.id
            );
        }
    }
    let time_pixels = secs(started);
    let configs: Vec<_> = pixels.iter().map(|p| p.config.clone()).collect();
    let configurations = configs
        .iter()
        .map(serde_json::to_value)
        .collect::<Result<Vec<_>, _>>()?;
    let configurations_jsonl = crate::io::to_jsonl(&configurations);
    // What the render is: its configurations (a comment in the scene file changes nothing).
    let scene_entry = crate::app::gate::render::SceneEntry {
        name: scene.name.clone(),
        file_sha256: crate::io::read_regular(&options.scene, "scene file", crate::limits::MAX_RECORD_BYTES)
            .map_or_else(
                |_| "unknown (not a regular file)".into(),
                |b| crate::app::shard::sha256(&b),
            ),
        configurations_sha256: crate::app::shard::sha256(&configurations_jsonl),
        width: scene.width,
        height: scene.height,
        floor_pixels: pixels.len(),
    };
    // A baseline that does not fit this scene is bad input, found before the render.
    let baseline = options
        .baseline
        .as_deref()
        .map(|b| crate::app::gate::render::load(b, &scene_entry))
        .transpose()?;
    crate::limits::check(
        &format!("render of {at} ({} floor pixels)", pixels.len()),
        crate::limits::Bytes(
            crate::limits::eval_estimate(pixels.len() as u64, methods.len() as u64)
                .0
                .saturating_mul(2),
        ),
        crate::limits::max_memory(),
    )
    .map_err(anyhow::Error::msg)?;

    let device = open_gpu(gpu.adapter.as_deref())?;
    let started = Instant::now();
    let scenes: Vec<_> = configs.iter().map(crate::input::scene::GpuScene::from).collect();
    let mut f32s = Vec::new();
    for m in &methods {
        let p = device.pipeline(m)?;
        f32s.push(device.run(&p, &scenes, gpu.chunk, &mut |_| {})?.values);
    }
    drop(scenes);
    let time_gpu = secs(started);
    let started = Instant::now();
    let references: Vec<BTreeMap<Target, crate::reference::Estimate>> = configs
        .par_iter()
        .map(|c| crate::reference::references(c, &eval_rows::targets_of(c, &methods)))
        .collect();
    eval_rows::check_references(&options.scene, &configs, &references)?;
    let time_references = secs(started);
    let started = Instant::now();
    let mut rows = Vec::with_capacity(configs.len());
    for (block, part) in configs.chunks(eval_rows::ROW_BLOCK).enumerate() {
        let at = block * eval_rows::ROW_BLOCK..block * eval_rows::ROW_BLOCK + part.len();
        let values: Vec<&[f32]> = f32s.iter().map(|v| &v[at.clone()]).collect();
        rows.extend(eval_rows::rows(
            part,
            &methods,
            &values,
            &references[at],
            None,
            false,
            false,
        )?);
    }
    let time_cpu = secs(started);

    let started = Instant::now();
    let outcome = images_and_stats(&scene, &pixels, &methods, &f32s, &references, &rows);
    let time_images = secs(started);

    let (w, h) = (scene.width, scene.height);
    let timing = json!({
        "pixels_to_configurations_s": time_pixels,
        "gpu_s": time_gpu,
        "references_s": time_references,
        "cpu_columns_s": time_cpu,
        "images_and_flip_s": time_images,
        "total_s": secs(total),
        "adapter": device.adapter.to_string(),
    });
    // The gate: this render against its baseline, pixel by pixel (src/app/gate/render.rs).
    let gate_options = crate::analyse::render_gate::RenderGateOptions {
        flip_noise: options.flip_noise,
        visible_flip: VISIBLE_FLIP,
        visible_share: VISIBLE_SHARE,
    };
    let floor: Vec<(u32, u32)> = pixels.iter().map(|p| (p.x, p.y)).collect();
    let retone = |label: &str, exposure: f64| -> Option<Rgb> {
        let k = methods.iter().position(|m| m.label == label)?;
        let samples = method_samples(&pixels, &f32s[k], &references, received(methods[k].target()));
        Some(image::radiance_image(
            scene.width,
            scene.height,
            &samples,
            exposure,
            false,
        ))
    };
    let run = crate::app::gate::render::RenderRun {
        scene: scene_entry,
        adapter: device.adapter.to_string(),
        exposure: outcome.exposure_value,
        floor: &floor,
        references: outcome.ref_images.iter().map(|(t, img)| (t.to_string(), img)).collect(),
        methods: methods
            .iter()
            .map(|m| {
                let r = &outcome.per_method[&m.label];
                let f = &r["flip_floor"];
                crate::app::gate::render::MethodRun {
                    label: &m.label,
                    kernel: &m.kernel.path,
                    kernel_sha256: crate::app::shard::source_sha256(m),
                    judged_against: received(m.target()).to_string(),
                    image: &outcome.method_images[&m.label],
                    flip: &outcome.flips[&m.label],
                    flip_mean: f["mean"].as_f64().unwrap_or(0.0),
                    flip_p99: f["p99"].as_f64().unwrap_or(0.0),
                    flip_visible_pixels: f["above"][format!("{VISIBLE_FLIP}")]["pixels"].as_u64().unwrap_or(0) as usize,
                    nonfinite: (r["nan"].as_u64().unwrap_or(0) + r["inf"].as_u64().unwrap_or(0)) as usize,
                }
            })
            .collect(),
        retone: &retone,
    };
    let gate = baseline
        .as_ref()
        .map(|b| crate::app::gate::render::compare(b, &run, gate_options));
    let stale = outcome
        .claims
        .iter()
        .any(|c| c["is_claim"] == json!(true) && c["holds"] == json!(false));
    let summary = json!({
        "scene": scene.name,
        "scene_file": at,
        "description": scene.description,
        "command_line": command_line,
        "width": w,
        "height": h,
        "camera": scene.camera,
        "floor_pixels": pixels.len(),
        "grazing_pixels": pixels.iter().filter(|p| p.elevation_deg < GRAZING_DEG).count(),
        "grazing_deg": GRAZING_DEG,
        "exposure": outcome.exposure,
        "tone_map": "radiance of a unit-intensity light × exposure, then Reinhard v/(1+v), then the sRGB curve, 8 bits, grey; negative values black; NaN/inf green (0,255,0); background (32,40,64)",
        "flip": {
            "implementation": "nv-flip (NVIDIA LDR-FLIP) on the tone-mapped sRGB images, against the reference image of the method's received target",
            "pixels_per_degree": image::PIXELS_PER_DEGREE,
            "thresholds": FLIP_THRESHOLDS,
            "visible": {"flip_above": VISIBLE_FLIP, "share_at_least": VISIBLE_SHARE},
        },
        "hdr": "OpenEXR (lossless ZIP), channel Y the radiance of a unit-intensity light before exposure and tone map, as f32 (a method's GPU values exactly, the reference rounded once; NaN/inf kept), channel A 1 on the floor and 0 on the background: reference.exr (reference_<target>.exr when the methods judge different targets) and each method's `hdr`",
        "relative_error_legend": {"scale": "log10, magma", "left": 10f64.powf(image::REL_LOG_MIN), "right": "≥ 1", "ticks": "one per decade", "nonfinite": "green", "false_light": "cyan (reference 0, value not 0)"},
        "methods": outcome.per_method,
        "failure": scene.failure,
        "claims": outcome.claims,
        "timing": timing,
    });
    let mut summary = summary;
    let mut regressed_rows = Vec::new();
    if let (Some((report, regressed)), Some(b)) = (&gate, &baseline) {
        summary["baseline"] = json!({
            "folder": b.dir.display().to_string(),
            "format": crate::app::gate::render::FORMAT,
            "change": report.change,
            "summary": report.summary(),
            "options": gate_options,
            "baseline_adapter": report.baseline_adapter,
            "rules": report.rules,
            "new_methods": report.new_methods,
            "regressed_pixels": regressed.len(),
        });
        regressed_rows = regressed.iter().map(|&i| configurations[i].clone()).collect();
    }
    let md = markdown(&summary, &outcome.image_names);
    let mut outputs: Vec<Box<dyn Format>> = vec![
        Box::new(Json::new("render.json", &summary, Layout::Pretty)),
        Box::new(Jsonl::new("configurations.jsonl", configurations)),
        Box::new(Jsonl::new("pixels.jsonl", rows)),
        Box::new(Svg::new(
            "relative_error_legend.svg",
            image::relative_error_legend_svg(),
        )),
        Box::new(Markdown::new("render.md", md.concat())),
    ];
    if gate.is_some() {
        // The pixels that regressed against the baseline, replayable with `linelight eval`.
        outputs.push(Box::new(Jsonl::new("regressed.jsonl", regressed_rows)));
    }
    for (name, bytes) in outcome.images {
        outputs.push(Box::new(Bytes { name, bytes }));
    }
    // The same text as render.md, the images side by side, all inline.
    let mut files = crate::report::format::encode_all(&outputs)?;
    let html = crate::report::html::page(
        &format!("Render {}", scene.name),
        &[
            Part::Markdown(&md[0]),
            Part::Markdown(&md[1]),
            Part::Gallery(Gallery {
                columns: vec!["radiance".into(), "relative error".into(), "FLIP".into()],
                rows: outcome.image_names.clone(),
                legend: Some("relative_error_legend.svg".into()),
            }),
            Part::Markdown(&md[3]),
        ],
        &files,
    );
    files.push(("report.html".into(), html));
    let written = crate::io::write_set(&dir, crate::io::SetKind::Render, &files)?;
    eprintln!(
        "wrote {} files to {} ({} floor pixels, {:.1} s)",
        written.len(),
        dir.display(),
        pixels.len(),
        total.elapsed().as_secs_f64()
    );
    for line in verdict_lines(&summary) {
        eprintln!("{line}");
    }
    if let Some(dir) = &options.save_baseline {
        for path in crate::app::gate::render::save(dir, &run)? {
            eprintln!("wrote {}", path.display());
        }
    }
    let mut regressed = false;
    if let Some((report, pixels)) = &gate {
        eprint!("{}", report.details());
        if let Some(path) = &options.junit {
            let xml = crate::app::gate::render::junit(&scene.name, report);
            crate::report::format::write_file(path, &crate::report::format::Junit::new("JUnit report", xml))?;
            eprintln!("wrote {}", path.display());
        }
        if !pixels.is_empty() {
            eprintln!(
                "{} floor pixels regressed against the baseline: {} (replay with linelight eval)",
                pixels.len(),
                dir.join("regressed.jsonl").display()
            );
        }
        println!("{}", report.summary());
        regressed = report.regressed();
    }
    Ok(if stale {
        Status::StaleClaim
    } else if regressed {
        Status::ToleranceFail
    } else {
        Status::Ok
    })
}

struct Outcome {
    exposure: Value,
    exposure_value: f64,
    ref_images: BTreeMap<Target, Rgb>,
    method_images: BTreeMap<String, Rgb>,
    /// Per method: FLIP against its reference image, per image pixel.
    flips: BTreeMap<String, Vec<f32>>,
    per_method: serde_json::Map<String, Value>,
    claims: Vec<Value>,
    images: Vec<(String, Vec<u8>)>,
    /// (method label or "reference…", file names) in display order.
    image_names: Vec<(String, Vec<String>)>,
}

/// A method's values on the floor pixels beside the reference of its received target `t`.
fn method_samples(
    pixels: &[FloorPixel],
    values: &[f32],
    references: &[BTreeMap<Target, crate::reference::Estimate>],
    t: Target,
) -> Vec<Sample> {
    pixels
        .iter()
        .zip(references)
        .zip(values)
        .map(|((p, r), v)| Sample {
            x: p.x,
            y: p.y,
            value: f64::from(*v),
            reference: r[&t].value,
        })
        .collect()
}

fn images_and_stats(
    scene: &RenderScene,
    pixels: &[FloorPixel],
    methods: &[Method],
    f32s: &[Vec<f32>],
    references: &[BTreeMap<Target, crate::reference::Estimate>],
    rows: &[Value],
) -> Outcome {
    let (w, h) = (scene.width, scene.height);
    let targets: Vec<Target> = {
        let mut t: Vec<Target> = methods.iter().map(|m| received(m.target())).collect();
        t.dedup();
        let mut seen = Vec::new();
        t.retain(|x| {
            let new = !seen.contains(x);
            seen.push(*x);
            new
        });
        t
    };
    // One exposure for every image, from the first method's received reference.
    let first: Vec<f64> = references.iter().map(|r| r[&targets[0]].value).collect();
    let (exposure, exposure_json) = match image::exposure(&first) {
        Some(k) => (
            k,
            json!({"value": k, "from": format!("Reinhard key {} over the log-average of the {} reference's lit floor pixels (reference > 0)", image::KEY, targets[0]), "fallback": false}),
        ),
        None => (
            1.0,
            json!({"value": 1.0, "from": format!("the {} reference is 0 on every floor pixel (a lamp wholly below the floor): fallback exposure 1", targets[0]), "fallback": true}),
        ),
    };
    let mut images = Vec::new();
    let mut image_names = Vec::new();
    let mut ref_images = BTreeMap::new();
    for t in &targets {
        let samples: Vec<Sample> = pixels
            .iter()
            .zip(references)
            .map(|(p, r)| Sample {
                x: p.x,
                y: p.y,
                value: r[t].value,
                reference: r[t].value,
            })
            .collect();
        let img = image::radiance_image(w, h, &samples, exposure, true);
        let stem = if targets.len() == 1 {
            "reference".to_string()
        } else {
            format!("reference_{t}")
        };
        let name = format!("{stem}.png");
        images.push((name.clone(), img.png()));
        images.push((
            format!("{stem}.exr"),
            image::radiance_exr(w, h, &samples, true, &format!("reference {t}")),
        ));
        if targets.len() > 1 && *t == targets[0] {
            // `reference.exr` is always there too, as `reference.png` is.
            images.push((
                "reference.exr".into(),
                image::radiance_exr(w, h, &samples, true, &format!("reference {t}")),
            ));
        }
        image_names.push((format!("reference ({t})"), vec![name]));
        ref_images.insert(*t, img);
    }
    if targets.len() > 1 {
        // `reference.png` is always there: the first method's received target.
        images.push(("reference.png".into(), ref_images[&targets[0]].png()));
    }
    let mut per_method = serde_json::Map::new();
    let mut means = BTreeMap::new();
    let mut method_images = BTreeMap::new();
    let mut flips = BTreeMap::new();
    for (k, m) in methods.iter().enumerate() {
        let t = received(m.target());
        let samples = method_samples(pixels, &f32s[k], references, t);
        let img: Rgb = image::radiance_image(w, h, &samples, exposure, false);
        let flip = image::flip(&ref_images[&t], &img);
        let stem = crate::input::names::clip(&m.label).replace(['/', '[', ']', '~', '@'], "_");
        let names = vec![
            format!("{stem}.png"),
            format!("{stem}.relative_error.png"),
            format!("{stem}.flip.png"),
        ];
        images.push((names[0].clone(), img.png()));
        let hdr = format!("{stem}.exr");
        images.push((hdr.clone(), image::radiance_exr(w, h, &samples, false, &m.label)));
        method_images.insert(m.label.clone(), img.clone());
        images.push((names[1].clone(), image::relative_error_image(w, h, &samples).png()));
        images.push((names[2].clone(), image::flip_image(w, h, &flip, &samples).png()));
        image_names.push((m.label.clone(), names.clone()));
        let pixel_flip: Vec<f64> = pixels
            .iter()
            .map(|p| f64::from(flip[(p.y * w + p.x) as usize]))
            .collect();
        let mut floor = pixel_flip.clone();
        let mut lit: Vec<f64> = pixel_flip
            .iter()
            .zip(&samples)
            .filter(|(_, s)| s.reference > 0.0)
            .map(|(f, _)| *f)
            .collect();
        let mut grazing: Vec<f64> = pixel_flip
            .iter()
            .zip(pixels)
            .filter(|(_, p)| p.elevation_deg < GRAZING_DEG)
            .map(|(f, _)| *f)
            .collect();
        let nan = samples.iter().filter(|s| s.value.is_nan()).count();
        let inf = samples.iter().filter(|s| s.value.is_infinite()).count();
        let false_light = samples
            .iter()
            .filter(|s| s.reference == 0.0 && s.value != 0.0 && s.value.is_finite())
            .count();
        let negative = samples.iter().filter(|s| s.value < 0.0).count();
        // Missed light: the reference is lit and the method returns exactly 0 (for an LTC,
        // the lobe's tail beyond its transformed horizon). Its pixels' FLIP apart from the
        // other lit pixels', so a report can say which of the two is what a viewer sees.
        let missed = |s: &Sample| s.reference > 0.0 && s.value == 0.0;
        let missed_light = samples.iter().filter(|s| missed(s)).count();
        let lit_split = |want: bool| -> Vec<f64> {
            pixel_flip
                .iter()
                .zip(&samples)
                .filter(|(_, s)| s.reference > 0.0 && missed(s) == want)
                .map(|(f, _)| *f)
                .collect()
        };
        let (mut flip_missed, mut flip_other_lit) = (lit_split(true), lit_split(false));
        let mut rel: Vec<f64> = samples
            .iter()
            .filter(|s| s.reference != 0.0 && s.value.is_finite())
            .map(|s| (s.value - s.reference).abs() / s.reference.abs())
            .collect();
        rel.sort_by(f64::total_cmp);
        // Worst: NaN/inf first, then by FLIP.
        let mut order: Vec<usize> = (0..pixels.len()).collect();
        order.sort_by(|&a, &b| {
            let key = |i: usize| (samples[i].value.is_finite(), -pixel_flip[i]);
            key(a).partial_cmp(&key(b)).unwrap_or(std::cmp::Ordering::Equal)
        });
        let worst: Vec<Value> = order
            .iter()
            .take(WORST)
            .map(|&i| {
                json!({
                    "id": pixels[i].config.id,
                    "flip": pixel_flip[i],
                    "value": eval_rows::number(samples[i].value),
                    "reference": samples[i].reference,
                    "view_elevation_deg": pixels[i].elevation_deg,
                    "configuration": pixels[i].config,
                    "result": rows[i],
                })
            })
            .collect();
        let floor_stats = flip_stats(&mut floor);
        let mean = floor_stats["mean"].as_f64().unwrap_or(0.0);
        means.insert(m.label.clone(), mean);
        let visible_pixels = floor_stats["above"][format!("{VISIBLE_FLIP}")]["pixels"]
            .as_u64()
            .unwrap_or(0);
        let visible = visible_pixels > 0 && visible_pixels as f64 >= VISIBLE_SHARE * pixels.len() as f64;
        flips.insert(m.label.clone(), flip);
        per_method.insert(
            m.label.clone(),
            json!({
                "method": m.describe(),
                "target": m.target(),
                "judged_against": t,
                "images": names,
                "hdr": hdr,
                "flip_floor": floor_stats,
                "flip_lit": flip_stats(&mut lit),
                "flip_grazing": flip_stats(&mut grazing),
                "visible": visible,
                "nan": nan,
                "inf": inf,
                "negative": negative,
                "false_light": false_light,
                "missed_light": missed_light,
                "flip_missed_light": flip_stats(&mut flip_missed),
                "flip_lit_not_missed": flip_stats(&mut flip_other_lit),
                "relative_error_lit": {
                    "pixels": rel.len(),
                    "p50": quantile(&rel, 0.5),
                    "p99": quantile(&rel, 0.99),
                    "max": rel.last(),
                },
                "worst": worst,
            }),
        );
    }
    let mut claims = Vec::new();
    if let Some(f) = &scene.failure {
        for bad in &f.methods {
            for good in &f.fixed {
                let (b, g) = (means[bad], means[good]);
                // What a viewer sees of the failure alone: FLIP of the failing method's image
                // against the fixed one's (the error both share, e.g. the LTC fit's, cancels).
                let pair = image::flip(&method_images[good], &method_images[bad]);
                let mut floor: Vec<f64> = pixels
                    .iter()
                    .map(|p| f64::from(pair[(p.y * w + p.x) as usize]))
                    .collect();
                let stats = flip_stats(&mut floor);
                let k = stats["above"][format!("{VISIBLE_FLIP}")]["pixels"]
                    .as_u64()
                    .unwrap_or(0);
                claims.push(json!({
                    "claim": format!("mean FLIP over the floor: {bad} > {good}"),
                    "values": [b, g],
                    "holds": b > g,
                    "is_claim": f.claim,
                    "flip_against_fixed": stats,
                    "visible_against_fixed": k > 0 && k as f64 >= VISIBLE_SHARE * pixels.len() as f64,
                }));
            }
        }
    }
    Outcome {
        exposure: exposure_json,
        exposure_value: exposure,
        ref_images,
        method_images,
        flips,
        per_method,
        claims,
        images,
        image_names,
    }
}

fn fmt(v: &Value) -> String {
    match v.as_f64() {
        Some(0.0) => "0".into(),
        Some(x) if x.abs() >= 0.01 => format!("{x:.3}"),
        Some(x) => format!("{x:.1e}"),
        None => "—".into(),
    }
}

/// The scene's verdict on the failure it was built for, from its numbers.
fn verdict_lines(s: &Value) -> Vec<String> {
    let mut out = Vec::new();
    let n = s["floor_pixels"].as_u64().unwrap_or(0);
    let methods = &s["methods"];
    if let Some(f) = s["failure"].as_object() {
        out.push(format!(
            "Failure this scene is built to show: {}",
            f["what"].as_str().unwrap_or("")
        ));
        out.push(
            "Against the reference: all of each method's error, including what the failing and the \
             fixed methods share (an LTC's fit and its missed light, say):"
                .to_string(),
        );
        let mut shared_visible = false;
        for (role, key) in [("failing", "methods"), ("fixed", "fixed")] {
            for m in f[key].as_array().into_iter().flatten() {
                let m = m.as_str().unwrap_or("");
                let r = &methods[m];
                let k = r["flip_floor"]["above"][format!("{VISIBLE_FLIP}")]["pixels"]
                    .as_u64()
                    .unwrap_or(0);
                let visible = r["visible"] == json!(true);
                shared_visible |= visible && key == "fixed";
                let missed = r["missed_light"].as_u64().unwrap_or(0);
                let k_missed = r["flip_missed_light"]["above"][format!("{VISIBLE_FLIP}")]["pixels"]
                    .as_u64()
                    .unwrap_or(0);
                out.push(format!(
                    "- `{m}` ({role}): {} — FLIP > {VISIBLE_FLIP} on {k} of {n} floor pixels ({:.2} %; visible means ≥ {} %), mean FLIP {}, NaN/inf {}; \
                     missed light (reference lit, value exactly 0) on {missed} pixels, {k_missed} of the {k} above {VISIBLE_FLIP}",
                    if visible { "VISIBLE" } else { "not visible" },
                    100.0 * k as f64 / n.max(1) as f64,
                    100.0 * VISIBLE_SHARE,
                    fmt(&r["flip_floor"]["mean"]),
                    r["nan"].as_u64().unwrap_or(0) + r["inf"].as_u64().unwrap_or(0),
                ));
            }
        }
        if shared_visible {
            out.push(
                "- The fixed method is visibly off the reference too: that error is shared, not the failure \
                 this scene is built to show. Whether the failure itself shows is the comparison with the \
                 fixed method's image below."
                    .to_string(),
            );
        }
        out.push("\nThe failure alone: each failing method's image against the fixed method's:".to_string());
    }
    for c in s["claims"].as_array().into_iter().flatten() {
        out.push(format!(
            "- {} ({} against {}): {}",
            c["claim"].as_str().unwrap_or(""),
            fmt(&c["values"][0]),
            fmt(&c["values"][1]),
            match (c["is_claim"] == json!(true), c["holds"] == json!(true)) {
                (true, true) => "claim holds",
                (true, false) => "STALE: the claim does not hold",
                (false, true) => "holds (reported, not a claim)",
                (false, false) => "does not hold (reported, not a claim)",
            }
        ));
        let a = &c["flip_against_fixed"];
        out.push(format!(
            "  - against the fixed method's image (the error they share cancels): {} — FLIP > {VISIBLE_FLIP} on {} of {n} floor pixels, mean FLIP {}, max {}",
            if c["visible_against_fixed"] == json!(true) { "VISIBLE" } else { "not visible" },
            a["above"][format!("{VISIBLE_FLIP}")]["pixels"],
            fmt(&a["mean"]),
            fmt(&a["max"]),
        ));
    }
    out
}

/// "Against the baseline": the render gate's verdict and every rule.
fn gate_markdown(b: &serde_json::Map<String, Value>) -> String {
    let o = &b["options"];
    let mut md = format!(
        "## Against the baseline\n\n`{}` (render baseline format {}, saved on {}). Per method: `flip`, the \
         mean FLIP against the reference now against the baseline's (a rise beyond ±{} fails); `image`, \
         FLIP between the baseline's image and this run's (a change is visible above {} on at least {} % \
         of the floor pixels, and fails when at least that many of the changed pixels moved away from \
         the reference); `nan`, floor pixels NaN/inf new since the baseline. The pixels that regressed \
         are in `regressed.jsonl` ({}).\n\n**{}**\n\n",
        b["folder"].as_str().unwrap_or(""),
        b["format"],
        b["baseline_adapter"].as_str().unwrap_or(""),
        o["flip_noise"],
        o["visible_flip"],
        o["visible_share"].as_f64().unwrap_or(0.0) * 100.0,
        b["regressed_pixels"],
        b["summary"].as_str().unwrap_or(""),
    );
    let mut table = Table::new(&[
        ("method", Align::Left),
        ("rule", Align::Left),
        ("outcome", Align::Left),
        ("numbers", Align::Left),
    ]);
    for r in b["rules"].as_array().into_iter().flatten() {
        table.row(vec![
            format!("`{}`", r["method"].as_str().unwrap_or("")),
            r["rule"].as_str().unwrap_or("").to_string(),
            r["change"].as_str().unwrap_or("").to_string(),
            r["message"].as_str().unwrap_or("").replace('|', "\\|"),
        ]);
    }
    md += &table.markdown();
    for m in b["new_methods"].as_array().into_iter().flatten() {
        md += &format!("\nNew since the baseline (not gated): `{}`\n", m.as_str().unwrap_or(""));
    }
    md + "\n"
}

/// render.md, in four parts that concatenate to it: the numbers; the images' heading; the
/// images; the timing. report.html shows the same parts, the images as a grid.
fn markdown(s: &Value, images: &[(String, Vec<String>)]) -> [String; 4] {
    let mut md = format!(
        "# Render `{}`\n\n{}\n\n`{}`\n\n{} × {} pixels, {} on the floor ({} in the grazing band, view below {}°). Adapter: {}.\n\n",
        s["scene"].as_str().unwrap_or(""),
        s["description"].as_str().unwrap_or(""),
        s["command_line"].as_str().unwrap_or(""),
        s["width"],
        s["height"],
        s["floor_pixels"],
        s["grazing_pixels"],
        GRAZING_DEG,
        s["timing"]["adapter"].as_str().unwrap_or("")
    );
    let lines = verdict_lines(s);
    if !lines.is_empty() {
        md += "## Is the failure visible?\n\n";
        md += &lines.join("\n");
        md += "\n\n";
    }
    md += &format!(
        "## FLIP per method\n\nFLIP (nv-flip, LDR) on the tone-mapped images against the reference, {} pixels per degree. \
         Floor: every floor pixel; lit: reference > 0; grazing: view below {GRAZING_DEG}°.\n\n",
        s["flip"]["pixels_per_degree"]
    );
    let mut table = Table::new(
        &[
            "method",
            "mean floor",
            "p99 floor",
            "max",
            "mean lit",
            "mean grazing",
            "> 0.05",
            "> 0.1",
            "> 0.2",
            "NaN",
            "inf",
            "false light",
            "rel. err. p50 (lit)",
            "rel. err. p99 (lit)",
        ]
        .map(|c| (c, Align::Left)),
    );
    for (label, r) in s["methods"].as_object().into_iter().flatten() {
        let share = |t: &str| fmt(&r["flip_floor"]["above"][t]["share"]);
        table.row(vec![
            format!("`{label}`"),
            fmt(&r["flip_floor"]["mean"]),
            fmt(&r["flip_floor"]["p99"]),
            fmt(&r["flip_floor"]["max"]),
            fmt(&r["flip_lit"]["mean"]),
            fmt(&r["flip_grazing"]["mean"]),
            share("0.05"),
            share("0.1"),
            share("0.2"),
            r["nan"].to_string(),
            r["inf"].to_string(),
            r["false_light"].to_string(),
            fmt(&r["relative_error_lit"]["p50"]),
            fmt(&r["relative_error_lit"]["p99"]),
        ]);
    }
    md += &table.markdown();
    md += &format!(
        "\nShares are of the floor pixels. Exposure {} ({}). Tone map: {}.\n\n",
        fmt(&s["exposure"]["value"]),
        s["exposure"]["from"].as_str().unwrap_or(""),
        s["tone_map"].as_str().unwrap_or("")
    );
    if let Some(b) = s["baseline"].as_object() {
        md += &gate_markdown(b);
    }
    let heading = "## Images\n\nPer method: radiance, relative error (legend: `relative_error_legend.svg`), FLIP (magma, 0 black to 1 light yellow).\n\n".to_string();
    let mut list = String::new();
    for (label, files) in images {
        list += &format!("**{label}**\n\n");
        for f in files {
            list += &format!("![{f}]({f}) ");
        }
        list += "\n\n";
    }
    let t = &s["timing"];
    let timing = format!(
        "## Timing\n\nTotal {} s: pixels {} s, GPU {} s, references {} s, CPU columns {} s, images and FLIP {} s.\n",
        t["total_s"],
        t["pixels_to_configurations_s"],
        t["gpu_s"],
        t["references_s"],
        t["cpu_columns_s"],
        t["images_and_flip_s"]
    );
    [md, heading, list, timing]
}
