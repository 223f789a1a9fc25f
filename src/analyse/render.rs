//! A render's numbers (docs/render.md): per method the FLIP statistics of its image against
//! the reference image of its received target (over the floor, its lit pixels, the grazing
//! band, missed light apart), its NaN, inf, negative and false-light pixels, its relative
//! errors and worst pixels; the scene's failure claims; and the typed summary written as
//! render.json and read back by its report.

use crate::analyse::gate::{Change, RuleResult};
use crate::analyse::render_gate::RenderGateOptions;
use crate::input::render_scene::{Camera, Failure, FloorPixel, GRAZING_DEG};
use crate::input::scene::Config;
use crate::input::target::Target;
use serde::Serialize;
use std::collections::BTreeMap;

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

/// The nearest-rank quantile (analyse::stats), None when empty.
fn quantile(sorted: &[f64], q: f64) -> Option<f64> {
    (!sorted.is_empty()).then(|| crate::analyse::stats::nearest_rank(sorted, q))
}

/// Pixels above a FLIP threshold, and their share.
#[derive(Clone, Debug, Serialize)]
pub struct Above {
    pub pixels: usize,
    pub share: f64,
}

/// Mean, percentiles and shares above the thresholds of a set of FLIP values.
#[derive(Clone, Debug, Serialize)]
pub struct FlipStats {
    pub pixels: usize,
    pub mean: Option<f64>,
    pub p50: Option<f64>,
    pub p90: Option<f64>,
    pub p99: Option<f64>,
    pub max: Option<f64>,
    /// Keyed by the threshold as written (`0.05`, `0.1`, …).
    pub above: BTreeMap<String, Above>,
}

impl FlipStats {
    pub fn of(values: &mut [f64]) -> FlipStats {
        values.sort_by(f64::total_cmp);
        let n = values.len();
        let mean = (n > 0).then(|| values.iter().sum::<f64>() / n as f64);
        let above = FLIP_THRESHOLDS
            .iter()
            .map(|&t| {
                let k = values.iter().filter(|&&v| v > t).count();
                let share = if n == 0 { 0.0 } else { k as f64 / n as f64 };
                (format!("{t}"), Above { pixels: k, share })
            })
            .collect();
        FlipStats {
            pixels: n,
            mean,
            p50: quantile(values, 0.5),
            p90: quantile(values, 0.9),
            p99: quantile(values, 0.99),
            max: values.last().copied(),
            above,
        }
    }

    /// Pixels above `threshold` (one of [`FLIP_THRESHOLDS`]).
    pub fn above(&self, threshold: f64) -> usize {
        self.above.get(&format!("{threshold}")).map_or(0, |a| a.pixels)
    }

    /// Pixels above [`VISIBLE_FLIP`].
    pub fn visible_pixels(&self) -> usize {
        self.above(VISIBLE_FLIP)
    }

    /// At least one pixel and [`VISIBLE_SHARE`] of the `of` floor pixels above [`VISIBLE_FLIP`].
    pub fn visible(&self, of: usize) -> bool {
        let k = self.visible_pixels();
        k > 0 && k as f64 >= VISIBLE_SHARE * of as f64
    }
}

/// The relative errors of a method's finite values where the reference is not 0.
#[derive(Clone, Debug, Serialize)]
pub struct RelativeErrors {
    pub pixels: usize,
    pub p50: Option<f64>,
    pub p99: Option<f64>,
    pub max: Option<f64>,
}

/// One of a method's worst pixels.
#[derive(Clone, Debug, Serialize)]
pub struct Worst {
    pub id: String,
    pub flip: f64,
    /// As docs/eval-format.md writes a number: NaN and infinities as strings.
    pub value: serde_json::Value,
    pub reference: f64,
    pub view_elevation_deg: f64,
    pub configuration: Config,
    /// The pixel's row of pixels.jsonl.
    pub result: serde_json::Value,
}

/// A method's numbers on the floor.
#[derive(Clone, Debug, Serialize)]
pub struct MethodSummary {
    pub method: String,
    pub target: Target,
    pub judged_against: Target,
    pub images: Vec<String>,
    pub hdr: String,
    pub flip_floor: FlipStats,
    pub flip_lit: FlipStats,
    pub flip_grazing: FlipStats,
    pub visible: bool,
    pub nan: usize,
    pub inf: usize,
    pub negative: usize,
    pub false_light: usize,
    pub missed_light: usize,
    pub flip_missed_light: FlipStats,
    pub flip_lit_not_missed: FlipStats,
    pub relative_error_lit: RelativeErrors,
    pub worst: Vec<Worst>,
}

/// A method's values on the floor pixels (in pixel order) beside its received reference, and
/// its FLIP map against the reference image.
pub struct MethodPixels<'a> {
    pub values: &'a [f64],
    pub references: &'a [f64],
    /// FLIP per image pixel (row-major, `width` wide).
    pub flip: &'a [f32],
    pub width: u32,
}

/// The FLIP values of the floor pixels from a full-image map.
pub fn floor_flip(flip: &[f32], width: u32, pixels: &[FloorPixel]) -> Vec<f64> {
    pixels
        .iter()
        .map(|p| f64::from(flip[(p.y * width + p.x) as usize]))
        .collect()
}

/// A method's numbers (without its names: `method`, `target`, `images` and `hdr` are given).
pub fn method_summary(
    names: (String, Target, Vec<String>, String),
    pixels: &[FloorPixel],
    run: MethodPixels,
    rows: &[serde_json::Value],
) -> MethodSummary {
    let (method, target, images, hdr) = names;
    let (values, refs) = (run.values, run.references);
    let pixel_flip = floor_flip(run.flip, run.width, pixels);
    let mut floor = pixel_flip.clone();
    let pick = |keep: &dyn Fn(usize) -> bool| -> Vec<f64> {
        (0..pixels.len()).filter(|&i| keep(i)).map(|i| pixel_flip[i]).collect()
    };
    let mut lit = pick(&|i| refs[i] > 0.0);
    let mut grazing = pick(&|i| pixels[i].elevation_deg < GRAZING_DEG);
    let count = |keep: &dyn Fn(usize) -> bool| (0..pixels.len()).filter(|&i| keep(i)).count();
    let nan = count(&|i| values[i].is_nan());
    let inf = count(&|i| values[i].is_infinite());
    let false_light = count(&|i| refs[i] == 0.0 && values[i] != 0.0 && values[i].is_finite());
    let negative = count(&|i| values[i] < 0.0);
    // Missed light: the reference is lit and the method returns exactly 0 (for an LTC, the
    // lobe's tail beyond its transformed horizon). Its pixels' FLIP apart from the other lit
    // pixels', so a report can say which of the two is what a viewer sees.
    let missed = |i: usize| refs[i] > 0.0 && values[i] == 0.0;
    let missed_light = count(&missed);
    let mut flip_missed = pick(&|i| refs[i] > 0.0 && missed(i));
    let mut flip_other_lit = pick(&|i| refs[i] > 0.0 && !missed(i));
    let mut rel: Vec<f64> = (0..pixels.len())
        .filter(|&i| refs[i] != 0.0 && values[i].is_finite())
        .map(|i| (values[i] - refs[i]).abs() / refs[i].abs())
        .collect();
    rel.sort_by(f64::total_cmp);
    // Worst: NaN/inf first, then by FLIP.
    let mut order: Vec<usize> = (0..pixels.len()).collect();
    order.sort_by(|&a, &b| {
        let key = |i: usize| (values[i].is_finite(), -pixel_flip[i]);
        key(a).partial_cmp(&key(b)).unwrap_or(std::cmp::Ordering::Equal)
    });
    let worst = order
        .iter()
        .take(WORST)
        .map(|&i| Worst {
            id: pixels[i].config.id.clone(),
            flip: pixel_flip[i],
            value: crate::io::json_number(values[i]),
            reference: refs[i],
            view_elevation_deg: pixels[i].elevation_deg,
            configuration: pixels[i].config.clone(),
            result: rows[i].clone(),
        })
        .collect();
    let flip_floor = FlipStats::of(&mut floor);
    MethodSummary {
        method,
        target,
        judged_against: received(target),
        images,
        hdr,
        visible: flip_floor.visible(pixels.len()),
        flip_floor,
        flip_lit: FlipStats::of(&mut lit),
        flip_grazing: FlipStats::of(&mut grazing),
        nan,
        inf,
        negative,
        false_light,
        missed_light,
        flip_missed_light: FlipStats::of(&mut flip_missed),
        flip_lit_not_missed: FlipStats::of(&mut flip_other_lit),
        relative_error_lit: RelativeErrors {
            pixels: rel.len(),
            p50: quantile(&rel, 0.5),
            p99: quantile(&rel, 0.99),
            max: rel.last().copied(),
        },
        worst,
    }
}

/// A failing method against a fixed one: mean FLIP over the floor against the reference, and
/// what a viewer sees of the failure alone, FLIP of the failing image against the fixed one's.
#[derive(Clone, Debug, Serialize)]
pub struct Claim {
    pub claim: String,
    /// Mean FLIP of the failing and the fixed method.
    pub values: [f64; 2],
    pub holds: bool,
    pub is_claim: bool,
    pub flip_against_fixed: FlipStats,
    pub visible_against_fixed: bool,
}

/// The claim of `bad` (failing) over `good` (fixed), from their mean FLIP and the floor's FLIP
/// of one image against the other.
pub fn claim(bad: &str, good: &str, means: [f64; 2], is_claim: bool, mut floor: Vec<f64>) -> Claim {
    let stats = FlipStats::of(&mut floor);
    let [b, g] = means;
    Claim {
        claim: format!("mean FLIP over the floor: {bad} > {good}"),
        values: [b, g],
        holds: b > g,
        is_claim,
        visible_against_fixed: stats.visible(floor.len()),
        flip_against_fixed: stats,
    }
}

/// The exposure every image is tone-mapped with, and where it comes from.
#[derive(Clone, Debug, Serialize)]
pub struct Exposure {
    pub value: f64,
    pub from: String,
    pub fallback: bool,
}

/// The FLIP implementation and thresholds.
#[derive(Clone, Debug, Serialize)]
pub struct FlipSettings {
    pub implementation: &'static str,
    pub pixels_per_degree: f32,
    pub thresholds: [f64; 4],
    pub visible: Visible,
}

#[derive(Clone, Debug, Serialize)]
pub struct Visible {
    pub flip_above: f64,
    pub share_at_least: f64,
}

/// The relative-error images' colour scale.
#[derive(Clone, Debug, Serialize)]
pub struct Legend {
    pub scale: &'static str,
    pub left: f64,
    pub right: &'static str,
    pub ticks: &'static str,
    pub nonfinite: &'static str,
    pub false_light: &'static str,
}

/// Wall-clock seconds of each stage of the render (rounded to the millisecond).
#[derive(Clone, Debug, Serialize)]
pub struct Timing {
    pub pixels_to_configurations_s: f64,
    pub gpu_s: f64,
    pub references_s: f64,
    pub cpu_columns_s: f64,
    pub images_and_flip_s: f64,
    pub total_s: f64,
    pub adapter: String,
}

/// The render against its render baseline.
#[derive(Clone, Debug, Serialize)]
pub struct BaselineSummary {
    pub folder: String,
    pub format: u32,
    pub change: Change,
    pub summary: String,
    pub options: RenderGateOptions,
    pub baseline_adapter: String,
    pub rules: Vec<RuleResult>,
    pub new_methods: Vec<String>,
    pub regressed_pixels: usize,
}

/// render.json: the whole render's numbers (written with its keys in sorted order).
#[derive(Clone, Debug, Serialize)]
pub struct RenderSummary {
    pub scene: String,
    pub scene_file: String,
    pub description: Option<String>,
    pub command_line: String,
    pub width: u32,
    pub height: u32,
    pub camera: Camera,
    pub floor_pixels: usize,
    pub grazing_pixels: usize,
    pub grazing_deg: f64,
    pub exposure: Exposure,
    pub tone_map: &'static str,
    pub flip: FlipSettings,
    pub hdr: &'static str,
    pub relative_error_legend: Legend,
    /// Per method label, in label order.
    pub methods: BTreeMap<String, MethodSummary>,
    pub failure: Option<Failure>,
    pub claims: Vec<Claim>,
    pub timing: Timing,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub baseline: Option<BaselineSummary>,
}

impl RenderSummary {
    /// A claim of the scene that does not hold (exit 3).
    pub fn stale(&self) -> bool {
        self.claims.iter().any(|c| c.is_claim && !c.holds)
    }
}
