//! The anisotropic table's resolution study, measured (`linelight resolution`, seed 004
//! Fig. 12; docs in src/app/resolution.rs): per configuration of a case of anisotropic
//! `ggx` families, the GGX truth T of the line light, the exact LTC integral of the exact
//! per-configuration fit, and the exact LTC integral of each table's f32 look-up (each table
//! fed as `ltc = "aniso"` feeds ours: `ltc::feed_aniso`). Errors and statistics are the
//! analyse stage's (`analyse::resolution`).

use crate::input::case::Case;
use crate::input::ltc::aniso::AnisoTable;
use crate::input::ltc::table::Storage;
use crate::input::ltc::{feed, feed_aniso, Fed, Feed};
use crate::input::sampler::{self, Sample};
use crate::input::scene::{Config, Material};
use crate::input::target::Target;
use crate::reference::reference;
use rayon::prelude::*;
use std::time::Instant;

/// A table of the study: its label (its size, or "slice 32×32") and the table.
pub struct StudyTable {
    pub label: String,
    pub table: AnisoTable,
}

/// One configuration's values.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Point {
    pub id: String,
    pub family: String,
    /// False for a configuration drawn to top up a highlight bin (counted in that bin only).
    pub natural: bool,
    /// The highlight bins (bin index of the case's `highlight` axis) a top-up counts in.
    pub strata: Vec<usize>,
    pub alpha: f64,
    pub view_angle: f64,
    /// Degrees between the view's mirror direction and the segment's nearest direction.
    pub highlight: f64,
    /// The f64 reference of the `ggx` lobe (the line light), and its error estimate.
    pub truth: f64,
    pub truth_error: f64,
    /// The exact integral of the exact per-configuration fit, times its magnitude.
    pub fit: f64,
    /// The exact integral of each table's look-up, times its magnitude (the study's tables in
    /// order; NaN where a slice table does not apply: configurations off its (φ, r)).
    pub tables: Vec<f64>,
}

/// A measured study.
pub struct ResolutionRun {
    pub points: Vec<Point>,
    pub labels: Vec<String>,
    pub seconds: f64,
}

/// The study's target: the line light (the chain's `line`).
pub const TARGET: Target = Target::Line;

/// A configuration's roughness and view in the table's reduced coordinates would be (φ, r);
/// true when they are the slice's to 1e-9 (its look-up answers there only).
fn on_slice(alpha: [f64; 2], view: [f64; 3], slice: [f64; 2]) -> bool {
    let (mut ax, mut ay) = (alpha[0], alpha[1]);
    let (mut vx, mut vy) = (view[0].abs(), view[1].abs());
    if ay > ax {
        (ax, ay) = (ay, ax);
        (vx, vy) = (vy, vx);
    }
    let phi = vy.atan2(vx);
    (phi - slice[0]).abs() < 1e-9 && (ay / ax - slice[1]).abs() < 1e-9
}

/// The exact LTC integral (times the magnitude) of `c` fed `fed`.
fn exact_of(c: &Config, fed: Fed) -> f64 {
    let Material::Ggx { alpha, view, f0, .. } = &c.material else {
        return f64::NAN;
    };
    let fed_config = Config {
        material: Material::Ggx {
            alpha: *alpha,
            view: *view,
            f0: *f0,
            ltc: Some(Feed::Aniso.name().to_string()),
            fed,
        },
        ..c.clone()
    };
    let (ltc, magnitude) = fed_config.fed();
    reference(&ltc, TARGET).map_or(f64::NAN, |e| e.value * magnitude)
}

/// Measures every configuration of `case` (its natural sample and its top-ups) against every
/// table. Refuses a case with a family that is not anisotropic `ggx` without `f0`.
pub fn measure(case: &Case, tables: &[StudyTable]) -> anyhow::Result<ResolutionRun> {
    let start = Instant::now();
    let natural = sampler::sample_case(case);
    let (topped, _) = sampler::top_up(case, &natural);
    let highlight_axis = case.bins.iter().position(|b| b.axis == "highlight");
    let samples: Vec<Sample> = natural.into_iter().chain(topped).collect();
    for s in &samples {
        match &s.config.material {
            Material::Ggx { alpha, f0, .. } if alpha.xy()[0] != alpha.xy()[1] && f0.is_none() => {}
            _ => anyhow::bail!(
                "case `{}`, family `{}`: the resolution study takes anisotropic ggx families without f0 only",
                case.name,
                case.materials[s.material].name
            ),
        }
    }
    let pb = crate::measure::progress::bar(samples.len() as u64, "fits and look-ups");
    let points: Vec<Point> = samples
        .par_iter()
        .map(|s| {
            let c = &s.config;
            let Material::Ggx { alpha, view, .. } = &c.material else {
                unreachable!("checked above")
            };
            let a = alpha.xy();
            let truth = reference(c, TARGET);
            let fit = feed(a, *view, Feed::Fit).map_or(f64::NAN, |f| exact_of(c, f));
            let values = tables
                .iter()
                .map(|t| match t.table.slice {
                    Some(slice) if !on_slice(a, *view, slice) => f64::NAN,
                    _ => exact_of(c, feed_aniso(&t.table, a, *view, Storage::F32)),
                })
                .collect();
            pb.inc(1);
            Point {
                id: c.id.clone(),
                family: case.materials[s.material].name.clone(),
                natural: s.natural(),
                strata: s
                    .strata
                    .iter()
                    .filter(|(axis, _)| Some(*axis) == highlight_axis)
                    .map(|&(_, k)| k)
                    .collect(),
                alpha: s.axes.alpha,
                view_angle: s.axes.view_angle,
                highlight: s.axes.highlight,
                truth: truth.map_or(f64::NAN, |e| e.value),
                truth_error: truth.map_or(f64::NAN, |e| e.error),
                fit,
                tables: values,
            }
        })
        .collect();
    pb.finish_and_clear();
    Ok(ResolutionRun {
        points,
        labels: tables.iter().map(|t| t.label.clone()).collect(),
        seconds: start.elapsed().as_secs_f64(),
    })
}
