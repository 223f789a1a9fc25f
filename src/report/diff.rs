//! `linelight diff`'s output: the paired comparison per material and where A and B disagree
//! most (printed), the verdict line, and the disagreement configurations as eval input
//! (`--output`).

use crate::analyse::diff::{DiffSummary, MaterialDiff, Outcome};
use crate::analyse::gate::Change;
use crate::report::format::Jsonl;

/// The lines before the verdict: the header, one line per material, the disagreements.
pub fn body(s: &DiffSummary) -> String {
    let mut out = format!("diff on case {}: A = {}, B = {} (ratios are B / A)\n", s.case, s.a, s.b);
    for m in &s.materials {
        match m {
            MaterialDiff::NotCompared {
                material,
                unsupported_by,
            } => out.push_str(&format!(
                "  {material}: not compared (unsupported by {unsupported_by})\n"
            )),
            MaterialDiff::TooFew { material, pairs } => out.push_str(&format!(
                "  {material}: no verdict: {pairs} paired configurations, fewer than the {} a paired comparison \
                 needs (raise --count)\n",
                crate::limits::MIN_JUDGED
            )),
            MaterialDiff::Compared {
                material,
                change,
                paired: p,
                non_finite,
                false_light,
            } => {
                let verdict = match change {
                    Change::Regressed => "B is less accurate",
                    Change::Improved => "B is more accurate",
                    _ => "no difference beyond the noise",
                };
                let [gl, gm, gh] = p.geomean;
                let [pl, pm, ph] = p.p99_ratio;
                out.push_str(&format!(
                    "  {material}: {verdict}: over {} paired configurations, error ratio geometric mean ×{gm:.4} [{gl:.4}–{gh:.4}], \
                     p99 ×{pm:.4} [{pl:.4}–{ph:.4}] (95 % bootstrap, noise ±{} %); B worse on {}, better on {}; \
                     NaN/inf A {} B {}; false light A {} B {}\n",
                    p.pairs,
                    s.noise * 100.0,
                    p.worse,
                    p.better,
                    non_finite[0],
                    non_finite[1],
                    false_light[0],
                    false_light[1],
                ));
            }
        }
    }
    out.push_str("  where they disagree most (disagreement search, both ways):\n");
    for d in &s.disagreements {
        let who = d.worse;
        let at: Vec<String> = d.at.iter().map(|(k, v)| format!("{k} {v:.4}")).collect();
        out.push_str(&format!(
            "    {who} worse on {}: err {who} {:.3e} against {:.3e} (×{:.3e}; the sample's largest ×{:.3e}) at {}\n",
            d.family,
            d.err_worse,
            d.err_other,
            d.ratio,
            d.sample_ratio,
            at.join(", ")
        ));
    }
    out
}

/// The verdict line.
pub fn verdict(outcome: Outcome) -> String {
    let verdict = match outcome {
        Outcome::Mixed => "mixed (B is more accurate on some materials and less on others)",
        Outcome::Regressed => "B is less accurate than A",
        Outcome::Improved => "B is more accurate than A",
        Outcome::Unchanged => "no difference beyond the noise",
        Outcome::NoVerdict => {
            return format!(
                "verdict: none (no material has the {} paired configurations a verdict needs: raise --count)",
                crate::limits::MIN_JUDGED
            )
        }
    };
    format!("verdict: {verdict}")
}

/// The disagreement configurations, in eval input format (replayable with `linelight eval`).
pub fn replay(s: &DiffSummary) -> anyhow::Result<Jsonl> {
    let rows: Vec<_> = s
        .disagreements
        .iter()
        .map(|d| serde_json::to_value(&d.config))
        .collect::<Result<_, _>>()?;
    Ok(Jsonl::new("disagreements", rows))
}
