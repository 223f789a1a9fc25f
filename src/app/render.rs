//! `linelight render SCENE.toml --out DIR` (docs/render.md): a floor under the light, one
//! configuration per floor pixel, run through eval's path (GPU f32 per method, f64
//! references, the CPU evaluator's f64 and cpu_f32 columns: measure::render), written as
//! images (report::render), FLIP statistics (analyse::render, the typed summary render.json)
//! and the eval files, swapped in whole as one report set; with a render baseline, the gate.

use super::gate::render::{self as gate, SceneEntry};
use super::{open_gpu, GpuOptions, Status};
use crate::analyse::render;
use crate::input::render_scene::{FloorPixel, RenderScene, GRAZING_DEG};
use crate::input::target::Target;
use crate::kernel::methods::Method;
use crate::report::format::{Bytes, Format, Json, Jsonl, Layout, Markdown, Svg};
use crate::report::html::{Gallery, Part};
use crate::report::image::{self, Rgb};
use crate::report::render::method_samples;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::Instant;

pub use crate::analyse::render::{received, FLIP_THRESHOLDS, VISIBLE_FLIP, VISIBLE_SHARE, WORST};

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

/// How the images are tone-mapped (render.json's `tone_map`).
const TONE_MAP: &str = "radiance of a unit-intensity light × exposure, then Reinhard v/(1+v), then the sRGB curve, 8 bits, grey; negative values black; NaN/inf green (0,255,0); background (32,40,64)";

/// What the OpenEXR files hold (render.json's `hdr`).
const HDR: &str = "OpenEXR (lossless ZIP), channel Y the radiance of a unit-intensity light before exposure and tone map, as f32 (a method's GPU values exactly, the reference rounded once; NaN/inf kept), channel A 1 on the floor and 0 on the background: reference.exr (reference_<target>.exr when the methods judge different targets) and each method's `hdr`";

pub fn render(options: RenderOptions, includes: &crate::kernel::Includes) -> anyhow::Result<Status> {
    let gpu = &options.gpu;
    let total = Instant::now();
    let command_line = shell_words::join(std::env::args());
    let scene = RenderScene::load(&options.scene)?;
    let at = options.scene.display().to_string();
    let kernels = crate::kernel::methods::kernel_set(&gpu.kernels, includes)?;
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
    let time_pixels = crate::measure::render::secs(started);
    let configs: Vec<_> = pixels.iter().map(|p| p.config.clone()).collect();
    let configurations = configs
        .iter()
        .map(serde_json::to_value)
        .collect::<Result<Vec<_>, _>>()?;
    let configurations_jsonl = crate::io::to_jsonl(&configurations);
    // What the render is: its configurations (a comment in the scene file changes nothing).
    let scene_entry = SceneEntry {
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
        .map(|b| gate::load(b, &scene_entry))
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
    let measured = crate::measure::render::measure(&device, &methods, &configs, gpu.chunk, &options.scene)?;
    let started = Instant::now();
    let (w, h) = (scene.width, scene.height);
    let images = crate::report::render::images(&scene, &pixels, &methods, &measured.f32s, &measured.references);
    let mut per_method = BTreeMap::new();
    for (k, m) in methods.iter().enumerate() {
        let t = received(m.target());
        let references: Vec<f64> = measured.references.iter().map(|r| r[&t].value).collect();
        let values: Vec<f64> = measured.f32s[k].iter().map(|&v| f64::from(v)).collect();
        let (list, hdr) = images.names[&m.label].clone();
        let run = render::MethodPixels {
            values: &values,
            references: &references,
            flip: &images.flips[&m.label],
            width: w,
        };
        let summary = render::method_summary((m.describe(), m.target(), list, hdr), &pixels, run, &measured.rows);
        per_method.insert(m.label.clone(), summary);
    }
    let claims = claims(&scene, &pixels, &per_method, &images.method_images);
    let time_images = crate::measure::render::secs(started);
    let timing = render::Timing {
        pixels_to_configurations_s: time_pixels,
        gpu_s: measured.gpu_s,
        references_s: measured.references_s,
        cpu_columns_s: measured.cpu_columns_s,
        images_and_flip_s: time_images,
        total_s: crate::measure::render::secs(total),
        adapter: device.adapter.to_string(),
    };
    // The gate: this render against its baseline, pixel by pixel (src/app/gate/render/).
    let gate_options = crate::analyse::render_gate::RenderGateOptions {
        flip_noise: options.flip_noise,
        visible_flip: VISIBLE_FLIP,
        visible_share: VISIBLE_SHARE,
    };
    let floor: Vec<(u32, u32)> = pixels.iter().map(|p| (p.x, p.y)).collect();
    let references = &measured.references;
    let retone = |label: &str, exposure: f64| -> Option<Rgb> {
        let k = methods.iter().position(|m| m.label == label)?;
        let samples = method_samples(&pixels, &measured.f32s[k], references, received(methods[k].target()));
        Some(image::radiance_image(w, h, &samples, exposure, false))
    };
    let run = gate::RenderRun {
        scene: scene_entry,
        adapter: device.adapter.to_string(),
        exposure: images.exposure_value,
        floor: &floor,
        references: images.ref_images.iter().map(|(t, img)| (t.to_string(), img)).collect(),
        methods: methods
            .iter()
            .map(|m| {
                let r = &per_method[&m.label];
                gate::MethodRun {
                    label: &m.label,
                    kernel: &m.kernel.path,
                    kernel_sha256: crate::app::shard::source_sha256(m),
                    judged_against: received(m.target()).to_string(),
                    image: &images.method_images[&m.label],
                    flip: &images.flips[&m.label],
                    flip_mean: r.flip_floor.mean.unwrap_or(0.0),
                    flip_p99: r.flip_floor.p99.unwrap_or(0.0),
                    flip_visible_pixels: r.flip_floor.visible_pixels(),
                    nonfinite: r.nan + r.inf,
                }
            })
            .collect(),
        retone: &retone,
    };
    let gate = baseline.as_ref().map(|b| gate::compare(b, &run, gate_options));
    let mut summary = render::RenderSummary {
        scene: scene.name.clone(),
        scene_file: at,
        description: scene.description.clone(),
        command_line,
        width: w,
        height: h,
        camera: scene.camera.clone(),
        floor_pixels: pixels.len(),
        grazing_pixels: pixels.iter().filter(|p| p.elevation_deg < GRAZING_DEG).count(),
        grazing_deg: GRAZING_DEG,
        exposure: images.exposure.clone(),
        tone_map: TONE_MAP,
        flip: render::FlipSettings {
            implementation: "nv-flip (NVIDIA LDR-FLIP) on the tone-mapped sRGB images, against the reference image of the method's received target",
            pixels_per_degree: image::PIXELS_PER_DEGREE,
            thresholds: FLIP_THRESHOLDS,
            visible: render::Visible { flip_above: VISIBLE_FLIP, share_at_least: VISIBLE_SHARE },
        },
        hdr: HDR,
        relative_error_legend: render::Legend {
            scale: "log10, magma",
            left: 10f64.powf(image::REL_LOG_MIN),
            right: "≥ 1",
            ticks: "one per decade",
            nonfinite: "green",
            false_light: "cyan (reference 0, value not 0)",
        },
        methods: per_method,
        failure: scene.failure.clone(),
        claims,
        timing,
        baseline: None,
    };
    let stale = summary.stale();
    let mut regressed_rows = Vec::new();
    if let (Some((report, regressed)), Some(b)) = (&gate, &baseline) {
        summary.baseline = Some(render::BaselineSummary {
            folder: b.dir.display().to_string(),
            format: gate::FORMAT,
            change: report.change,
            summary: report.summary(),
            options: gate_options,
            baseline_adapter: report.baseline_adapter.clone(),
            rules: report.rules.clone(),
            new_methods: report.new_methods.clone(),
            regressed_pixels: regressed.len(),
        });
        regressed_rows = regressed.iter().map(|&i| configurations[i].clone()).collect();
    }
    let md = crate::report::render::markdown(&summary, &images.image_names);
    let mut outputs: Vec<Box<dyn Format>> = vec![
        // Through a JSON value: its keys in sorted order, as render.json has always had them.
        Box::new(Json::new(
            "render.json",
            serde_json::to_value(&summary)?,
            Layout::Pretty,
        )),
        Box::new(Jsonl::new("configurations.jsonl", configurations)),
        Box::new(Jsonl::new("pixels.jsonl", measured.rows)),
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
    for (name, bytes) in images.files {
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
                rows: images.image_names.clone(),
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
    for line in crate::report::render::verdict_lines(&summary) {
        eprintln!("{line}");
    }
    if let Some(dir) = &options.save_baseline {
        for path in gate::save(dir, &run)? {
            eprintln!("wrote {}", path.display());
        }
    }
    let mut regressed = false;
    if let Some((report, pixels)) = &gate {
        eprint!("{}", report.details());
        if let Some(path) = &options.junit {
            let xml = gate::junit(&scene.name, report);
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

/// The scene's failure claims: each failing method against each fixed one.
fn claims(
    scene: &RenderScene,
    pixels: &[FloorPixel],
    per_method: &BTreeMap<String, render::MethodSummary>,
    method_images: &BTreeMap<String, Rgb>,
) -> Vec<render::Claim> {
    let mut claims = Vec::new();
    let mean = |label: &str| per_method[label].flip_floor.mean.unwrap_or(0.0);
    if let Some(f) = &scene.failure {
        for bad in &f.methods {
            for good in &f.fixed {
                // What a viewer sees of the failure alone: FLIP of the failing method's image
                // against the fixed one's (the error both share, e.g. the LTC fit's, cancels).
                let pair = image::flip(&method_images[good], &method_images[bad]);
                let floor = render::floor_flip(&pair, scene.width, pixels);
                claims.push(render::claim(bad, good, [mean(bad), mean(good)], f.claim, floor));
            }
        }
    }
    claims
}
