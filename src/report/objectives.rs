//! The objective comparison's files (`linelight objectives` → reports/ggx-objectives/):
//! objectives.md (findings first, then the tables), lines.csv (every line), entries.csv (every
//! entry's lobe errors), objectives.json (the tables for tools).

use super::format::{Csv, Format, Json, Layout, Markdown};
use super::markup::{sci, sci2, Align::*, Doc as _, Table};
use crate::analyse::objectives::{Group, Objectives, VARIANTS};

/// The run's inputs, as the report states them.
pub struct Inputs {
    pub command: String,
    pub sw_record: Option<serde_json::Value>,
    /// The SW subset's path, as given.
    pub subset: String,
    /// Where `sw_record` was read from (the subset's `.run.json`).
    pub sw_record_path: String,
    pub l1_record: Option<serde_json::Value>,
}

fn group_table(groups: &[Group]) -> String {
    let mut t = Table::new(&[
        ("lines", Left),
        ("n", Right),
        ("L1 median", Right),
        ("L1 p90", Right),
        ("SW median", Right),
        ("SW p90", Right),
        ("SW nearer", Right),
        ("L1 nearer", Right),
        ("T = 0 (false light L1 / SW)", Right),
        ("not finite", Right),
    ]);
    for g in groups {
        t.row(vec![
            g.label.clone(),
            g.n.to_string(),
            sci(g.median[0]),
            sci(g.p90[0]),
            sci(g.median[1]),
            sci(g.p90[1]),
            g.sw_nearer.to_string(),
            g.l1_nearer.to_string(),
            format!("{} ({} / {})", g.zero_truth, g.false_light[0], g.false_light[1]),
            g.not_finite.to_string(),
        ]);
    }
    t.markdown()
}

fn record_line(r: &Option<serde_json::Value>, keys: &[&str]) -> String {
    match r {
        None => "no run record found".into(),
        Some(v) => keys
            .iter()
            .filter_map(|k| v.get(*k).map(|x| format!("{k} {x}")))
            .collect::<Vec<_>>()
            .join(", "),
    }
}

pub fn outputs(o: &Objectives, inputs: &Inputs) -> Vec<Box<dyn Format>> {
    let mut md = String::new();
    md.para(format_args!(
        "# Seed 004's objective beside ours: sliced Wasserstein (SGD) against L1 (Nelder–Mead)\n\n\
         `{}` (docs/ggx.md). {} entries of the {}×{}×{}×{} anisotropic table, each fitted twice: \
         by our L1 lobe error (Nelder–Mead, `data/ltc_ggx_aniso.csv`) and by seed 004's sliced-Wasserstein loss \
         (SGD, `{}`, src/input/ltc/sw.rs), both aligned and post-processed alike. \
         Each entry is judged at its own node (its lobe exactly, no look-up): {} lines per region drawn from the \
         entry's own seeded stream, the GGX truth T of the `line` target against the magnitude times the exact \
         LTC line integral of each M, over the whole segment (the `line` target: the part of the lobe below the \
         horizon included, which is why a fit can light a line whose T is 0). Error |value − T|/T over the lines \
         with T > 0, no floor; lines with T = 0 counted apart. Medians and p90 are nearest-rank (for an even \
         count the median is the lower middle value). SW distances are estimates from 4096 samples × 256 \
         directions, whose own sampling floor is of the order of the sharpest lobes' values (α_max = 0.02). \
         Measured in {:.1} s of wall time.",
        inputs.command,
        o.entries,
        o.size[0],
        o.size[1],
        o.size[2],
        o.size[3],
        inputs.subset,
        o.lines_per_region,
        o.seconds
    ));
    md.heading(2, "Findings");
    let findings = findings(o);
    for f in &findings {
        md.line(format_args!("- {f}"));
    }
    md.para(format_args!(
        "\n## The fits\n\n- SW (`{}`): {}.\n- L1 (`data/ltc_ggx_aniso.run.json`, the whole table): {}.",
        inputs.sw_record_path,
        record_line(
            &inputs.sw_record,
            &[
                "entries",
                "steps",
                "directions",
                "samples_per_step",
                "learning_rate",
                "learning_rate_schedule",
                "start",
                "threads",
                "seconds"
            ]
        ),
        record_line(
            &inputs.l1_record,
            &["objective", "objective_grid", "fitted", "threads", "seconds"]
        )
    ));
    for (name, groups) in &o.regions {
        md.para(format_args!("## Line-light error, {}\n\nRows: all lines, then per (φ, r) slice, per α_max, and for the natural sample per \
             highlight-angle bin. \"SW nearer\" / \"L1 nearer\": lines where that fit's value is nearer T (paired).", if name == "highlight" {
                "near the highlight (nearest point within 5° of the mirror direction)"
            } else {
                "natural sample (cases/ggx.toml's geometry), also binned by the highlight angle"
            }));
        md.push_str(&group_table(groups));
        md.push('\n');
    }
    md.para("## Lobe errors\n\nPer entry: the relative L1 lobe error ∫|mag·D_ltc − D|/∫D on a 128² MIS grid (the L1 fit \
         minimised it on 32²), and the SW distance (Eq. 10) on 4096 samples × 256 directions, the same samples and \
         directions for both matrices. The SW distance is a finite-sample estimate with a floor (two sample sets of one \
         distribution are not at distance 0), the same for both.");
    let mut t = Table::new(&[
        ("entries", Left),
        ("n", Right),
        ("L1 lobe error: L1 fit", Right),
        ("SW fit", Right),
        ("SW lower", Right),
        ("SW distance: L1 fit", Right),
        ("SW fit", Right),
        ("SW lower", Right),
    ]);
    for l in &o.lobes {
        t.row(vec![
            l.label.clone(),
            l.n.to_string(),
            sci(l.l1_error_median[0]),
            sci(l.l1_error_median[1]),
            l.sw_lower_l1.to_string(),
            sci(l.sw_distance_median[0]),
            sci(l.sw_distance_median[1]),
            l.sw_lower_sw.to_string(),
        ]);
    }
    md.push_str("Medians.\n\n");
    md.table(&t);

    let mut lines = String::from(
        "i_theta,i_phi,i_alpha,i_ratio,region,highlight_deg,p1x,p1y,p1z,p2x,p2y,p2z,truth,truth_error,l1_fit,sw_fit\n",
    );
    for r in &o.rows {
        lines.line(format_args!(
            "{},{},{},{},{},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e}",
            r.entry[0],
            r.entry[1],
            r.entry[2],
            r.entry[3],
            r.region,
            r.highlight,
            r.p1[0],
            r.p1[1],
            r.p1[2],
            r.p2[0],
            r.p2[1],
            r.p2[2],
            r.truth,
            r.truth_error,
            r.l1,
            r.sw
        ));
    }
    let mut entries = String::from("i_theta,i_phi,i_alpha,i_ratio,theta,phi,alpha_max,ratio,l1_error_l1_fit,l1_error_sw_fit,sw_distance_l1_fit,sw_distance_sw_fit\n");
    for e in &o.entry_rows {
        entries.line(format_args!(
            "{},{},{},{},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e}",
            e.entry[0],
            e.entry[1],
            e.entry[2],
            e.entry[3],
            e.point[0],
            e.point[1],
            e.point[2],
            e.point[3],
            e.l1_error[0],
            e.l1_error[1],
            e.sw_distance[0],
            e.sw_distance[1]
        ));
    }
    let json = serde_json::json!({
        "variants": VARIANTS,
        "size": o.size,
        "entries": o.entries,
        "lines_per_region": o.lines_per_region,
        "seconds": o.seconds,
        "regions": o.regions,
        "lobes": o.lobes,
        "entries_sw_better": o.entries_sw_better,
        "findings": findings,
    });
    vec![
        Box::new(Markdown::new("objectives.md", md)),
        Box::new(Csv::new("lines.csv", lines)),
        Box::new(Csv::new("entries.csv", entries)),
        Box::new(Json::new("objectives.json", json, Layout::PrettyLine)),
    ]
}

/// The findings, as sentences computed from the analysed numbers: per region the medians of
/// both fits and where the SW fit wins, per entry, and the lobe errors.
fn findings(o: &Objectives) -> Vec<String> {
    let mut findings = Vec::new();
    for (name, groups) in &o.regions {
        let g = &groups[0];
        let what = if name == "highlight" {
            format!(
                "Near the highlight (segment's nearest point within {}° of the mirror direction)",
                o.highlight_cap
            )
        } else {
            "Over the natural sample (cases/ggx.toml's geometry)".to_string()
        };
        let verdict = match (g.median[0], g.median[1]) {
            (Some(a), Some(b)) if b < a => "the SW fit's median line-light error is lower",
            (Some(a), Some(b)) if b > a => "the L1 fit's median line-light error is lower",
            _ => "the two medians are equal",
        };
        findings.push(format!(
            "{what}, {verdict}: L1 {} (p90 {}), SW {} (p90 {}) over {} lines; SW is nearer the GGX truth on {} of them, L1 on {}.",
            sci2(g.median[0]),
            sci2(g.p90[0]),
            sci2(g.median[1]),
            sci2(g.p90[1]),
            g.n,
            g.sw_nearer,
            g.l1_nearer
        ));
        // Where the SW fit wins and where it loses, by slice and by α_max.
        let wins: Vec<String> = groups[1..]
            .iter()
            .filter(|g| {
                !g.label.starts_with("highlight") && matches!((g.median[0], g.median[1]), (Some(a), Some(b)) if b < a)
            })
            .map(|g| g.label.clone())
            .collect();
        let losses: Vec<String> = groups[1..]
            .iter()
            .filter(|g| {
                !g.label.starts_with("highlight") && matches!((g.median[0], g.median[1]), (Some(a), Some(b)) if b > a)
            })
            .map(|g| g.label.clone())
            .collect();
        findings.push(format!(
            "{}: the SW fit's median is lower in {} ({}) and higher in {} ({}) of the 3 slices and the 8 α_max values (two groupings of the same lines).",
            if name == "highlight" {
                "Near the highlight, by slice and α_max"
            } else {
                "Over the natural sample, by slice and α_max"
            },
            wins.len(),
            if wins.is_empty() {
                "none".to_string()
            } else {
                wins.join("; ")
            },
            losses.len(),
            if losses.is_empty() {
                "none".to_string()
            } else {
                losses.join("; ")
            },
        ));
    }
    for (name, c) in &o.entries_sw_better {
        findings.push(format!(
            "Per entry ({name} lines): the SW fit's median line-light error is lower at {} of {} entries, higher at {}, tied or not comparable at {}.",
            c[0],
            o.entries,
            c[1],
            o.entries.saturating_sub(c[0] + c[1])
        ));
    }
    let l = &o.lobes[0];
    findings.push(format!(
        "Lobe errors over the {} entries: relative L1 lobe error median L1 fit {}, SW fit {} (SW lower at {} entries); SW distance median L1 fit {}, SW fit {} (SW lower at {} entries). Each fit wins on its own objective {}.",
        l.n,
        sci2(l.l1_error_median[0]),
        sci2(l.l1_error_median[1]),
        l.sw_lower_l1,
        sci2(l.sw_distance_median[0]),
        sci2(l.sw_distance_median[1]),
        l.sw_lower_sw,
        if l.sw_lower_l1 * 2 < l.n && l.sw_lower_sw * 2 > l.n {
            "at most entries"
        } else {
            "not at most entries (see the table)"
        }
    ));
    // Where the SW fit loses on its own objective, the descent (not the objective) is judged.
    let unconverged: Vec<String> = o.lobes[1..]
        .iter()
        .filter(|g| g.label.starts_with("α_max") && g.sw_lower_sw * 2 < g.n)
        .map(|g| format!("{} ({} of {})", g.label, g.n - g.sw_lower_sw, g.n))
        .collect();
    findings.push(if unconverged.is_empty() {
        "The SW fit has the lower SW distance at most entries of every α_max: its descent reached below the L1 fit on its own objective everywhere.".to_string()
    } else {
        format!(
            "The SW fit's own SW distance is higher than the L1 fit's at most entries of {}: there its descent stopped above the L1 matrix's SW distance (one estimate each, whose sampling floor is of the order of these values, so the count is approximate), and the comparison judges the hyperparameters more than the objective.",
            unconverged.join(", ")
        )
    });
    findings
}
