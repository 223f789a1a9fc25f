//! Render baselines (docs/render.md, "In the gate"): what `render --save-baseline DIR` writes,
//! and how `render --baseline DIR` compares a render with it. A render's pixels are its
//! configurations, so the comparison is paired pixel by pixel: the baseline keeps each
//! method's tone-mapped image and the reference images (PNG, lossless, so every FLIP map of the
//! baseline is recomputed exactly), the FLIP statistics, the exposure, and content hashes of
//! the scene's configurations and of each method's kernel. The rules are
//! src/analyse/render_gate.rs's; the verdict and JUnit are the sweep gate's.
//!
//! Format 1 (`render-baseline.json`, the index; `images/*.png`):
//! `{"format": 1, "scene": {name, file_sha256, configurations_sha256, width, height,
//! floor_pixels}, "adapter", "exposure", "pixels_per_degree", "references": [{target, image}],
//! "methods": [{label, kernel, kernel_sha256, judged_against, image, flip_mean, flip_p99,
//! flip_visible_pixels, nonfinite}]}`.

use super::{file_name, GateReport};
use crate::limits::MAX_IMAGE_BYTES;
use crate::report::format::{Bytes, Format, Json, Layout};
use crate::report::image::Rgb;
use anyhow::Context;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The render against its baseline, pixel by pixel.
mod compare;
pub use compare::compare;

/// Version of the render baseline's format; another is bad input.
pub const FORMAT: u32 = 1;
/// The index file of a render baseline.
pub const INDEX: &str = "render-baseline.json";

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SceneEntry {
    pub name: String,
    /// SHA-256 of the scene file's bytes: a note (a comment edit changes it, not the render).
    pub file_sha256: String,
    /// SHA-256 of the floor pixels' configurations (configurations.jsonl's bytes): the
    /// render's content. A baseline whose configurations differ is refused.
    pub configurations_sha256: String,
    pub width: u32,
    pub height: u32,
    pub floor_pixels: usize,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ReferenceEntry {
    pub target: String,
    pub image: String,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MethodEntry {
    pub label: String,
    pub kernel: String,
    /// SHA-256 of what the method's values come from (its kernel's text and its inner
    /// method's): the comparison says whether the kernel changed since the baseline.
    pub kernel_sha256: String,
    pub judged_against: String,
    pub image: String,
    pub flip_mean: f64,
    pub flip_p99: f64,
    /// Floor pixels whose FLIP against the reference is above the visible threshold.
    pub flip_visible_pixels: usize,
    /// Floor pixels NaN or ±inf.
    pub nonfinite: usize,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RenderBaseline {
    pub format: u32,
    pub scene: SceneEntry,
    pub adapter: String,
    /// The exposure every image was tone-mapped with.
    pub exposure: f64,
    pub pixels_per_degree: f64,
    pub references: Vec<ReferenceEntry>,
    pub methods: Vec<MethodEntry>,
}

/// One method of this run, as the baseline saves and compares it.
pub struct MethodRun<'a> {
    pub label: &'a str,
    pub kernel: &'a str,
    pub kernel_sha256: String,
    pub judged_against: String,
    /// Its tone-mapped image, and the same values tone-mapped with another exposure when the
    /// baseline's differs (`retone`).
    pub image: &'a Rgb,
    /// FLIP against its reference image, per image pixel.
    pub flip: &'a [f32],
    pub flip_mean: f64,
    pub flip_p99: f64,
    pub flip_visible_pixels: usize,
    pub nonfinite: usize,
}

/// A render as the baseline sees it.
pub struct RenderRun<'a> {
    pub scene: SceneEntry,
    pub adapter: String,
    pub exposure: f64,
    /// (x, y) of each floor pixel, in configuration order.
    pub floor: &'a [(u32, u32)],
    /// Reference image per target name.
    pub references: BTreeMap<String, &'a Rgb>,
    pub methods: Vec<MethodRun<'a>>,
    /// A method's image tone-mapped with another exposure (label, exposure).
    pub retone: &'a dyn Fn(&str, f64) -> Option<Rgb>,
}

fn image_name(stem: &str) -> String {
    format!("images/{}.png", file_name(stem))
}

/// Writes DIR/render-baseline.json and DIR/images/*.png as one set, swapped in whole.
pub fn save(dir: &Path, run: &RenderRun) -> anyhow::Result<Vec<PathBuf>> {
    let mut files: Vec<Box<dyn Format>> = Vec::new();
    let mut references = Vec::new();
    for (target, img) in &run.references {
        let image = image_name(&format!("reference_{target}"));
        files.push(Box::new(Bytes {
            name: image.clone(),
            bytes: img.png(),
        }));
        references.push(ReferenceEntry {
            target: target.clone(),
            image,
        });
    }
    let mut methods = Vec::new();
    for m in &run.methods {
        let image = image_name(m.label);
        files.push(Box::new(Bytes {
            name: image.clone(),
            bytes: m.image.png(),
        }));
        methods.push(MethodEntry {
            label: m.label.to_string(),
            kernel: m.kernel.to_string(),
            kernel_sha256: m.kernel_sha256.clone(),
            judged_against: m.judged_against.clone(),
            image,
            flip_mean: m.flip_mean,
            flip_p99: m.flip_p99,
            flip_visible_pixels: m.flip_visible_pixels,
            nonfinite: m.nonfinite,
        });
    }
    let index = RenderBaseline {
        format: FORMAT,
        scene: run.scene.clone(),
        adapter: run.adapter.clone(),
        exposure: run.exposure,
        pixels_per_degree: f64::from(crate::report::image::PIXELS_PER_DEGREE),
        references,
        methods,
    };
    files.push(Box::new(Json::new(INDEX, index, Layout::PrettyLine)));
    crate::report::format::write_set(dir, crate::io::SetKind::RenderBaseline, &files)
}

/// A loaded render baseline: its index and its images, decoded.
pub struct Loaded {
    pub dir: PathBuf,
    pub baseline: RenderBaseline,
    pub references: BTreeMap<String, Rgb>,
    pub images: Vec<Rgb>,
}

/// Reads a render baseline and checks it was saved from this scene (its configurations and
/// size); any mismatch, a missing or malformed image, or another format is bad input (exit
/// 2), found before the render.
pub fn load(dir: &Path, scene: &SceneEntry) -> anyhow::Result<Loaded> {
    use crate::io::read_regular;
    let path = dir.join(INDEX);
    let here = |what: String| anyhow::anyhow!("render baseline {}: {what}", path.display());
    if crate::io::set_kind(dir) == Some(crate::io::SetKind::Baseline) {
        return Err(here(
            "this is a sweep baseline (`sweep --save-baseline`), not a render baseline: save one with \
             `linelight render SCENE --save-baseline DIR`"
                .into(),
        ));
    }
    let text = read_regular(&path, "render baseline index", crate::limits::MAX_RECORD_BYTES)?;
    // The format first, so a baseline of another version says so rather than failing on a key.
    let value: serde_json::Value =
        serde_json::from_slice(&text).with_context(|| format!("{}: not JSON", path.display()))?;
    match value.get("format").and_then(serde_json::Value::as_u64) {
        Some(f) if f == u64::from(FORMAT) => {}
        Some(f) => {
            return Err(here(format!(
                "render baseline format {f} (this linelight reads format {FORMAT}): save it again with \
                 `linelight render SCENE --save-baseline {}` and commit the new folder",
                dir.display()
            )))
        }
        None => return Err(here("no `format` number: not a linelight render baseline".into())),
    }
    let baseline: RenderBaseline = serde_json::from_value(value)
        .with_context(|| format!("{}: not a linelight render baseline", path.display()))?;
    let saved = &baseline.scene;
    if saved.name != scene.name {
        return Err(here(format!(
            "saved from scene `{}`; this scene is `{}`",
            crate::input::names::clip(&saved.name),
            scene.name
        )));
    }
    if (saved.width, saved.height) != (scene.width, scene.height) {
        return Err(here(format!(
            "size mismatch: saved at {} × {} pixels; this scene renders {} × {}: the comparison is \
             pixel by pixel, save the baseline again",
            saved.width, saved.height, scene.width, scene.height
        )));
    }
    if saved.configurations_sha256 != scene.configurations_sha256 || saved.floor_pixels != scene.floor_pixels {
        return Err(here(format!(
            "scene changed: its floor pixels' configurations (camera, light, material, max_distance) \
             differ from the baseline's ({} floor pixels, configurations SHA-256 {}…; the baseline has \
             {}, {}…): the comparison is pixel by pixel, save the baseline again",
            scene.floor_pixels,
            &scene.configurations_sha256[..12.min(scene.configurations_sha256.len())],
            saved.floor_pixels,
            crate::input::names::clip(&saved.configurations_sha256[..12.min(saved.configurations_sha256.len())])
        )));
    }
    let inside = crate::io::resolved(dir);
    let read_image = |what: &str, rel: &str| -> anyhow::Result<Rgb> {
        // The image is the baseline's own: a path that leaves the folder is refused, never read.
        let file = dir.join(rel);
        let plain = !rel.is_empty()
            && Path::new(rel)
                .components()
                .all(|c| matches!(c, std::path::Component::Normal(_)));
        if !plain || !crate::io::resolved(&file).starts_with(&inside) {
            return Err(here(format!(
                "{what}: image `{}` is not inside the baseline folder",
                crate::input::names::clip(rel)
            )));
        }
        let bytes = read_regular(&file, "render baseline image", MAX_IMAGE_BYTES)
            .map_err(|e| here(format!("{what}: missing or unreadable image: {e}")))?;
        // The size is checked from the PNG's header, before it is decoded.
        let img = Rgb::from_png(&bytes, Some((scene.width, scene.height)))
            .map_err(|e| here(format!("{what}: {}: {e}", file.display())))?;
        if (img.width, img.height) != (scene.width, scene.height) {
            return Err(here(format!(
                "{what}: size mismatch: {} is {} × {} pixels, the scene {} × {}",
                file.display(),
                img.width,
                img.height,
                scene.width,
                scene.height
            )));
        }
        Ok(img)
    };
    let mut references = BTreeMap::new();
    for r in &baseline.references {
        references.insert(
            r.target.clone(),
            read_image(
                &format!("reference `{}`", crate::input::names::clip(&r.target)),
                &r.image,
            )?,
        );
    }
    let mut images = Vec::new();
    for m in &baseline.methods {
        let what = format!("method `{}`", crate::input::names::clip(&m.label));
        if !references.contains_key(&m.judged_against) {
            return Err(here(format!(
                "{what} is judged against `{}`, which has no reference image in the baseline",
                crate::input::names::clip(&m.judged_against)
            )));
        }
        images.push(read_image(&what, &m.image)?);
    }
    Ok(Loaded {
        dir: dir.to_path_buf(),
        baseline,
        references,
        images,
    })
}

/// The JUnit document of a render's gate (the sweep gate's writer: one suite
/// `<scene>.baseline`, one testcase per rule).
pub fn junit(scene: &str, report: &GateReport) -> String {
    crate::report::junit::junit(scene, &[], Some(report), report.seconds)
}
