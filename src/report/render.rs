//! A render's report (docs/render.md): the images (tone-mapped radiance, relative error and
//! FLIP per method, the reference of each received target, as PNG and OpenEXR), and render.md
//! from the typed summary (analyse::render), in the four parts report.html shows too.

use crate::analyse::render::{received, BaselineSummary, Exposure, RenderSummary, VISIBLE_FLIP, VISIBLE_SHARE};
use crate::input::render_scene::{FloorPixel, RenderScene, GRAZING_DEG};
use crate::input::target::Target;
use crate::kernel::methods::Method;
use crate::report::image::{self, Rgb, Sample};
use crate::report::markup::{Align, Table};
use serde::Serialize;
use std::collections::BTreeMap;

/// A value as render.json writes it (serde_json's numbers), for the text that quotes it.
fn json<T: Serialize>(v: T) -> String {
    serde_json::to_value(v).map_or_else(|_| String::new(), |v| v.to_string())
}

/// A value's name as render.json writes it (a unit enum variant's string).
fn name<T: Serialize>(v: T) -> String {
    serde_json::to_value(v)
        .ok()
        .and_then(|v| v.as_str().map(String::from))
        .unwrap_or_default()
}

fn fmt(v: Option<f64>) -> String {
    match v {
        Some(0.0) => "0".into(),
        Some(x) if x.abs() >= 0.01 => format!("{x:.3}"),
        Some(x) => format!("{x:.1e}"),
        None => "—".into(),
    }
}

/// The images of a render: every file, and what the summary and the gate are made from.
pub struct Images {
    pub exposure: Exposure,
    pub exposure_value: f64,
    pub ref_images: BTreeMap<Target, Rgb>,
    pub method_images: BTreeMap<String, Rgb>,
    /// Per method: FLIP against its reference image, per image pixel.
    pub flips: BTreeMap<String, Vec<f32>>,
    /// Per method: its image files and its HDR file.
    pub names: BTreeMap<String, (Vec<String>, String)>,
    pub files: Vec<(String, Vec<u8>)>,
    /// (method label or "reference…", file names) in display order.
    pub image_names: Vec<(String, Vec<String>)>,
}

/// A method's values on the floor pixels beside the reference of its received target `t`.
pub fn method_samples(
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

/// Every image of the render, one exposure for all (from the first method's received
/// reference).
pub fn images(
    scene: &RenderScene,
    pixels: &[FloorPixel],
    methods: &[Method],
    f32s: &[Vec<f32>],
    references: &[BTreeMap<Target, crate::reference::Estimate>],
) -> Images {
    let (w, h) = (scene.width, scene.height);
    let mut targets: Vec<Target> = Vec::new();
    for m in methods {
        if !targets.contains(&received(m.target())) {
            targets.push(received(m.target()));
        }
    }
    let first: Vec<f64> = references.iter().map(|r| r[&targets[0]].value).collect();
    let (exposure_value, exposure) = match image::exposure(&first) {
        Some(k) => (
            k,
            Exposure {
                value: k,
                from: format!(
                    "Reinhard key {} over the log-average of the {} reference's lit floor pixels (reference > 0)",
                    image::KEY,
                    targets[0]
                ),
                fallback: false,
            },
        ),
        None => (
            1.0,
            Exposure {
                value: 1.0,
                from: format!(
                    "the {} reference is 0 on every floor pixel (a lamp wholly below the floor): fallback exposure 1",
                    targets[0]
                ),
                fallback: true,
            },
        ),
    };
    let mut files = Vec::new();
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
        let img = image::radiance_image(w, h, &samples, exposure_value, true);
        let stem = if targets.len() == 1 {
            "reference".to_string()
        } else {
            format!("reference_{t}")
        };
        let name = format!("{stem}.png");
        files.push((name.clone(), img.png()));
        let exr = image::radiance_exr(w, h, &samples, true, &format!("reference {t}"));
        files.push((format!("{stem}.exr"), exr.clone()));
        if targets.len() > 1 && *t == targets[0] {
            // `reference.exr` is always there too, as `reference.png` is.
            files.push(("reference.exr".into(), exr));
        }
        image_names.push((format!("reference ({t})"), vec![name]));
        ref_images.insert(*t, img);
    }
    if targets.len() > 1 {
        // `reference.png` is always there: the first method's received target.
        files.push(("reference.png".into(), ref_images[&targets[0]].png()));
    }
    let (mut method_images, mut flips, mut names) = (BTreeMap::new(), BTreeMap::new(), BTreeMap::new());
    for (k, m) in methods.iter().enumerate() {
        let t = received(m.target());
        let samples = method_samples(pixels, &f32s[k], references, t);
        let img: Rgb = image::radiance_image(w, h, &samples, exposure_value, false);
        let flip = image::flip(&ref_images[&t], &img);
        let stem = crate::input::names::clip(&m.label).replace(['/', '[', ']', '~', '@'], "_");
        let list = vec![
            format!("{stem}.png"),
            format!("{stem}.relative_error.png"),
            format!("{stem}.flip.png"),
        ];
        files.push((list[0].clone(), img.png()));
        let hdr = format!("{stem}.exr");
        files.push((hdr.clone(), image::radiance_exr(w, h, &samples, false, &m.label)));
        method_images.insert(m.label.clone(), img);
        files.push((list[1].clone(), image::relative_error_image(w, h, &samples).png()));
        files.push((list[2].clone(), image::flip_image(w, h, &flip, &samples).png()));
        image_names.push((m.label.clone(), list.clone()));
        names.insert(m.label.clone(), (list, hdr));
        flips.insert(m.label.clone(), flip);
    }
    Images {
        exposure,
        exposure_value,
        ref_images,
        method_images,
        flips,
        names,
        files,
        image_names,
    }
}

/// The scene's verdict on the failure it was built for, from its numbers.
pub fn verdict_lines(s: &RenderSummary) -> Vec<String> {
    let mut out = Vec::new();
    let n = s.floor_pixels;
    if let Some(f) = &s.failure {
        out.push(format!("Failure this scene is built to show: {}", f.what));
        out.push(
            "Against the reference: all of each method's error, including what the failing and the \
             fixed methods share (an LTC's fit and its missed light, say):"
                .to_string(),
        );
        let mut shared_visible = false;
        for (role, list) in [("failing", &f.methods), ("fixed", &f.fixed)] {
            for m in list {
                let Some(r) = s.methods.get(m) else {
                    out.push(format!(
                        "- `{m}` ({role}): not visible — FLIP > {VISIBLE_FLIP} on 0 of {n} floor pixels (0.00 %; visible means ≥ {} %), mean FLIP —, NaN/inf 0; \
                         missed light (reference lit, value exactly 0) on 0 pixels, 0 of the 0 above {VISIBLE_FLIP}",
                        100.0 * VISIBLE_SHARE
                    ));
                    continue;
                };
                let k = r.flip_floor.visible_pixels();
                shared_visible |= r.visible && role == "fixed";
                let k_missed = r.flip_missed_light.visible_pixels();
                out.push(format!(
                    "- `{m}` ({role}): {} — FLIP > {VISIBLE_FLIP} on {k} of {n} floor pixels ({:.2} %; visible means ≥ {} %), mean FLIP {}, NaN/inf {}; \
                     missed light (reference lit, value exactly 0) on {} pixels, {k_missed} of the {k} above {VISIBLE_FLIP}",
                    if r.visible { "VISIBLE" } else { "not visible" },
                    100.0 * k as f64 / n.max(1) as f64,
                    100.0 * VISIBLE_SHARE,
                    fmt(r.flip_floor.mean),
                    r.nan + r.inf,
                    r.missed_light,
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
    for c in &s.claims {
        out.push(format!(
            "- {} ({} against {}): {}",
            c.claim,
            fmt(Some(c.values[0])),
            fmt(Some(c.values[1])),
            match (c.is_claim, c.holds) {
                (true, true) => "claim holds",
                (true, false) => "STALE: the claim does not hold",
                (false, true) => "holds (reported, not a claim)",
                (false, false) => "does not hold (reported, not a claim)",
            }
        ));
        let a = &c.flip_against_fixed;
        out.push(format!(
            "  - against the fixed method's image (the error they share cancels): {} — FLIP > {VISIBLE_FLIP} on {} of {n} floor pixels, mean FLIP {}, max {}",
            if c.visible_against_fixed { "VISIBLE" } else { "not visible" },
            a.visible_pixels(),
            fmt(a.mean),
            fmt(a.max),
        ));
    }
    out
}

/// "Against the baseline": the render gate's verdict and every rule.
fn gate_markdown(b: &BaselineSummary) -> String {
    let o = &b.options;
    let mut md = format!(
        "## Against the baseline\n\n`{}` (render baseline format {}, saved on {}). Per method: `flip`, the \
         mean FLIP against the reference now against the baseline's (a rise beyond ±{} fails); `image`, \
         FLIP between the baseline's image and this run's (a change is visible above {} on at least {} % \
         of the floor pixels, and fails when at least that many of the changed pixels moved away from \
         the reference); `nan`, floor pixels NaN/inf new since the baseline. The pixels that regressed \
         are in `regressed.jsonl` ({}).\n\n**{}**\n\n",
        b.folder,
        b.format,
        b.baseline_adapter,
        json(o.flip_noise),
        json(o.visible_flip),
        o.visible_share * 100.0,
        b.regressed_pixels,
        b.summary,
    );
    let mut table = Table::new(&[
        ("method", Align::Left),
        ("rule", Align::Left),
        ("outcome", Align::Left),
        ("numbers", Align::Left),
    ]);
    for r in &b.rules {
        table.row(vec![
            format!("`{}`", r.method),
            r.rule.to_string(),
            name(r.change),
            r.message.replace('|', "\\|"),
        ]);
    }
    md += &table.markdown();
    for m in &b.new_methods {
        md += &format!("\nNew since the baseline (not gated): `{m}`\n");
    }
    md + "\n"
}

/// render.md, in four parts that concatenate to it: the numbers; the images' heading; the
/// images; the timing. report.html shows the same parts, the images as a grid.
pub fn markdown(s: &RenderSummary, images: &[(String, Vec<String>)]) -> [String; 4] {
    let mut md = format!(
        "# Render `{}`\n\n{}\n\n`{}`\n\n{} × {} pixels, {} on the floor ({} in the grazing band, view below {}°). Adapter: {}.\n\n",
        s.scene,
        s.description.as_deref().unwrap_or(""),
        s.command_line,
        s.width,
        s.height,
        s.floor_pixels,
        s.grazing_pixels,
        GRAZING_DEG,
        s.timing.adapter
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
        json(s.flip.pixels_per_degree)
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
    for (label, r) in &s.methods {
        let share = |t: &str| fmt(r.flip_floor.above.get(t).map(|a| a.share));
        table.row(vec![
            format!("`{label}`"),
            fmt(r.flip_floor.mean),
            fmt(r.flip_floor.p99),
            fmt(r.flip_floor.max),
            fmt(r.flip_lit.mean),
            fmt(r.flip_grazing.mean),
            share("0.05"),
            share("0.1"),
            share("0.2"),
            r.nan.to_string(),
            r.inf.to_string(),
            r.false_light.to_string(),
            fmt(r.relative_error_lit.p50),
            fmt(r.relative_error_lit.p99),
        ]);
    }
    md += &table.markdown();
    md += &format!(
        "\nShares are of the floor pixels. Exposure {} ({}). Tone map: {}.\n\n",
        fmt(Some(s.exposure.value)),
        s.exposure.from,
        s.tone_map
    );
    if let Some(b) = &s.baseline {
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
    let t = &s.timing;
    let timing = format!(
        "## Timing\n\nTotal {} s: pixels {} s, GPU {} s, references {} s, CPU columns {} s, images and FLIP {} s.\n",
        json(t.total_s),
        json(t.pixels_to_configurations_s),
        json(t.gpu_s),
        json(t.references_s),
        json(t.cpu_columns_s),
        json(t.images_and_flip_s)
    );
    [md, heading, list, timing]
}
