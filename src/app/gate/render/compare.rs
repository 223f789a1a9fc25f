//! A render against its render baseline: per method the `flip`, `image` and `nan` rules
//! (src/analyse/render_gate.rs) on the floor pixels, a note per reference image, and the
//! floor pixels that regressed.

use super::{Loaded, RenderRun};
use crate::analyse::gate::{Change, GateReport, RuleResult};
use crate::analyse::render_gate::{MethodMaps, RenderGateOptions};
use crate::report::image::{Rgb, NONFINITE};

/// The floor pixels of a full-image map.
fn on_floor<T: Copy>(map: &[T], width: u32, floor: &[(u32, u32)]) -> Vec<T> {
    floor.iter().map(|&(x, y)| map[(y * width + x) as usize]).collect()
}

fn nonfinite(img: &Rgb, floor: &[(u32, u32)]) -> Vec<bool> {
    floor.iter().map(|&(x, y)| img.get(x, y) == NONFINITE).collect()
}

/// The comparison of a render with its baseline: every rule (src/analyse/render_gate.rs)
/// per method, a note per reference image, and the floor pixels (indices) that regressed.
pub fn compare(loaded: &Loaded, run: &RenderRun, options: RenderGateOptions) -> (GateReport, Vec<usize>) {
    let started = std::time::Instant::now();
    let base = &loaded.baseline;
    let w = run.scene.width;
    let mut rules = Vec::new();
    // The references first: a reference that moved makes every FLIP-against-it rule compare
    // against a different reference, which the report says.
    for (target, img) in &run.references {
        let Some(old) = loaded.references.get(target) else {
            continue;
        };
        let differ = run
            .floor
            .iter()
            .filter(|&&(x, y)| old.get(x, y) != img.get(x, y))
            .count();
        let exposure = if base.exposure == run.exposure {
            String::new()
        } else {
            format!(
                "; the exposure moved from {} to {} (the images are compared at the baseline's)",
                base.exposure, run.exposure
            )
        };
        rules.push(RuleResult {
            method: format!("reference {target}"),
            material: "floor".into(),
            rule: "reference",
            change: if differ == 0 {
                Change::Unchanged
            } else {
                Change::Skipped
            },
            message: if differ == 0 {
                format!("the reference image is the baseline's on every floor pixel{exposure}")
            } else {
                format!(
                    "the reference image differs from the baseline's on {differ} of {} floor pixels (the \
                     references changed, not a method: not gated){exposure}",
                    run.floor.len()
                )
            },
        });
    }
    let mut regressed = std::collections::BTreeSet::new();
    for (entry, old_image) in base.methods.iter().zip(&loaded.images) {
        let Some(now) = run.methods.iter().find(|m| m.label == entry.label) else {
            rules.push(RuleResult {
                method: entry.label.clone(),
                material: "(all)".into(),
                rule: "present",
                change: Change::Regressed,
                message: format!("`{}` is in the baseline but not in this render", entry.label),
            });
            continue;
        };
        let old_reference = &loaded.references[&entry.judged_against];
        if now.judged_against != entry.judged_against {
            rules.push(RuleResult {
                method: entry.label.clone(),
                material: "(all)".into(),
                rule: "target",
                change: Change::Skipped,
                message: format!(
                    "judged against `{}` now and `{}` in the baseline: not compared",
                    now.judged_against, entry.judged_against
                ),
            });
            continue;
        }
        // The baseline's FLIP against its reference, recomputed from its lossless images.
        let base_flip = crate::report::image::flip(old_reference, old_image);
        let retoned = (base.exposure != run.exposure)
            .then(|| (run.retone)(now.label, base.exposure))
            .flatten();
        let new_image = retoned.as_ref().unwrap_or(now.image);
        let change = crate::report::image::flip(old_image, new_image);
        let maps = (
            on_floor(&base_flip, w, run.floor),
            on_floor(now.flip, w, run.floor),
            on_floor(&change, w, run.floor),
        );
        let (base_nf, now_nf) = (nonfinite(old_image, run.floor), nonfinite(now.image, run.floor));
        let outcome = crate::analyse::render_gate::rules(
            &MethodMaps {
                label: now.label,
                base: &maps.0,
                now: &maps.1,
                change: &maps.2,
                base_nonfinite: &base_nf,
                now_nonfinite: &now_nf,
            },
            &options,
        );
        let kernel = if now.kernel_sha256 == entry.kernel_sha256 {
            "kernel unchanged since the baseline"
        } else {
            "kernel changed since the baseline"
        };
        for mut r in outcome.rules {
            if r.rule == "flip" {
                r.message = format!("{kernel}; {}", r.message);
            }
            rules.push(r);
        }
        regressed.extend(outcome.regressed_pixels);
    }
    let new_methods = run
        .methods
        .iter()
        .filter(|m| !base.methods.iter().any(|b| b.label == m.label))
        .map(|m| m.label.to_string())
        .collect();
    let change = Change::overall(&rules);
    (
        GateReport {
            baseline_adapter: base.adapter.clone(),
            adapter: run.adapter.clone(),
            rules,
            timings: Vec::new(),
            new_methods,
            change,
            share_options: Default::default(),
            shares: Vec::new(),
            seconds: started.elapsed().as_secs_f64(),
            replay: Vec::new(),
        },
        regressed.into_iter().collect(),
    )
}
