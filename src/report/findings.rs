//! Measured findings, written as sentences from the statistics: where two methods
//! differ, by how much, and whether f64 says it is the formula or the rounding.

use super::markup::sci;
use crate::analyse::analysis::{Analysis, Comparison, MethodStats, PairMaterial};

/// Below this, two formulas evaluated in f64 are taken to be the same function.
const SAME_FUNCTION_F64: f64 = 1e-9;
/// A bin needs this many configurations before a finding quotes it.
const MIN_BIN: usize = 30;

fn bin_p99(m: &MethodStats, material: &str, axis: &str, k: usize) -> (Option<f64>, Option<f64>) {
    let s = m
        .materials
        .iter()
        .find(|x| x.material == material)
        .and_then(|x| x.axes.iter().find(|a| a.axis == axis))
        .map(|a| &a.bins[k].stats);
    (
        s.and_then(|s| s.rel.map(|q| q.p99)),
        s.and_then(|s| s.rel_f64.map(|q| q.p99)),
    )
}

fn method<'a>(a: &'a Analysis, label: &str) -> Option<&'a MethodStats> {
    a.methods.iter().find(|m| m.label == label)
}

/// One paragraph per material for a compared pair.
pub fn comparison(analysis: &Analysis, c: &Comparison, mat: &PairMaterial) -> String {
    let (a, b) = (&c.a, &c.b);
    let Some(d32) = mat.all.diff_f32 else {
        return format!(
            "- **{a} vs {b}, `{}`**: no configuration both methods support.",
            mat.material
        );
    };
    let d64 = mat.all.diff_f64.map(|q| q.max);
    let mut s = format!(
        "- **{a} vs {b}, `{}`** ({} configurations): in f32 they differ by median {}, p99 {}, max {} \
         (relative to the reference); ",
        mat.material,
        mat.all.count,
        sci(Some(d32.median)),
        sci(Some(d32.p99)),
        sci(Some(d32.max)),
    );
    match d64 {
        Some(m) if m <= SAME_FUNCTION_F64 => {
            s += &format!(
                "in f64 by at most {}: **the two formulas compute the same function; the f32 difference is rounding**.",
                sci(Some(m))
            )
        }
        Some(m) => s += &format!("in f64 by up to {}: **the formulas themselves differ**.", sci(Some(m))),
        None => s += "(no f64 evaluation for one of them).",
    }
    // Where the difference concentrates: for each axis, the bin with the largest p99.
    for axis in &mat.axes {
        let populated: Vec<_> = axis
            .bins
            .iter()
            .enumerate()
            .filter(|(_, b)| b.stats.count >= MIN_BIN)
            .collect();
        let p99 = |b: &crate::analyse::analysis::PairBin| b.stats.diff_f32.map_or(0.0, |q| q.p99);
        let (Some(worst), Some(best)) = (
            populated.iter().max_by(|x, y| p99(x.1).total_cmp(&p99(y.1))),
            populated.iter().min_by(|x, y| p99(x.1).total_cmp(&p99(y.1))),
        ) else {
            continue;
        };
        if p99(worst.1) <= 4.0 * p99(best.1).max(f64::MIN_POSITIVE) {
            continue; // flat along this axis: nothing to locate
        }
        let (ea, fa) = method(analysis, a).map_or((None, None), |m| bin_p99(m, &mat.material, &axis.axis, worst.0));
        let (eb, fb) = method(analysis, b).map_or((None, None), |m| bin_p99(m, &mat.material, &axis.axis, worst.0));
        s += &format!(
            "\n  - along `{}`: p99 difference {} for {} ∈ [{}, {}) ({} configs) against {} for [{}, {}); \
             in that worst bin p99 error against the reference is {} for {a} (f64 {}) and {} for {b} (f64 {}).",
            axis.axis,
            sci(Some(p99(worst.1))),
            axis.axis,
            worst.1.lo,
            worst.1.hi,
            worst.1.stats.count,
            sci(Some(p99(best.1))),
            best.1.lo,
            best.1.hi,
            sci(ea),
            sci(fa),
            sci(eb),
            sci(fb),
        );
    }
    s
}
