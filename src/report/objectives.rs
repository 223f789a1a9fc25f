//! The objective comparison's files (`linelight objectives` → reports/ggx-objectives/):
//! objectives.md (findings first, then the tables), lines.csv (every line), entries.csv (every
//! entry's lobe errors), objectives.json (the tables for tools).

use super::format::{Csv, Format, Json, Layout, Markdown};
use super::markup::{Align::*, Table};
use super::sci;
use crate::analyse::objectives::{Group, Objectives, VARIANTS};
use std::fmt::Write;

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
    let _ = writeln!(
        md,
        "# Seed 004's objective beside ours: sliced Wasserstein (SGD) against L1 (Nelder–Mead)\n\n\
         `{}` (issue 24; docs/ggx.md). {} entries of the {}×{}×{}×{} anisotropic table, each fitted twice: \
         by our L1 lobe error (Nelder–Mead, `data/ltc_ggx_aniso.csv`) and by seed 004's sliced-Wasserstein loss \
         (SGD, `{}`, src/input/ltc/sw.rs), both aligned and post-processed alike. \
         Each entry is judged at its own node (its lobe exactly, no look-up): {} lines per region drawn from the \
         entry's own seeded stream, the GGX truth T of the `line` target against the magnitude times the exact \
         LTC line integral of each M, over the whole segment (the `line` target: the part of the lobe below the \
         horizon included, which is why a fit can light a line whose T is 0). Error |value − T|/T over the lines \
         with T > 0, no floor; lines with T = 0 counted apart. Medians and p90 are nearest-rank (for an even \
         count the median is the lower middle value). SW distances are estimates from 4096 samples × 256 \
         directions, whose own sampling floor is of the order of the sharpest lobes' values (α_max = 0.02). \
         Measured in {:.1} s of wall time.\n",
        inputs.command,
        o.entries,
        o.size[0],
        o.size[1],
        o.size[2],
        o.size[3],
        inputs.subset,
        o.lines_per_region,
        o.seconds
    );
    let _ = writeln!(md, "## Findings\n");
    for f in &o.findings {
        let _ = writeln!(md, "- {f}");
    }
    let _ = writeln!(
        md,
        "\n## The fits\n\n- SW (`{}`): {}.\n- L1 (`data/ltc_ggx_aniso.run.json`, the whole table): {}.\n",
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
    );
    for (name, groups) in &o.regions {
        let _ = writeln!(
            md,
            "## Line-light error, {}\n\nRows: all lines, then per (φ, r) slice, per α_max, and for the natural sample per \
             highlight-angle bin. \"SW nearer\" / \"L1 nearer\": lines where that fit's value is nearer T (paired).\n",
            if name == "highlight" {
                "near the highlight (nearest point within 5° of the mirror direction)"
            } else {
                "natural sample (cases/ggx.toml's geometry), also binned by the highlight angle"
            }
        );
        md.push_str(&group_table(groups));
        md.push('\n');
    }
    let _ = writeln!(
        md,
        "## Lobe errors\n\nPer entry: the relative L1 lobe error ∫|mag·D_ltc − D|/∫D on a 128² MIS grid (the L1 fit \
         minimised it on 32²), and the SW distance (Eq. 10) on 4096 samples × 256 directions, the same samples and \
         directions for both matrices. The SW distance is a finite-sample estimate with a floor (two sample sets of one \
         distribution are not at distance 0), the same for both.\n"
    );
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
    md.push_str(&t.markdown());

    let mut lines = String::from(
        "i_theta,i_phi,i_alpha,i_ratio,region,highlight_deg,p1x,p1y,p1z,p2x,p2y,p2z,truth,truth_error,l1_fit,sw_fit\n",
    );
    for r in &o.rows {
        let _ = writeln!(
            lines,
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
        );
    }
    let mut entries = String::from("i_theta,i_phi,i_alpha,i_ratio,theta,phi,alpha_max,ratio,l1_error_l1_fit,l1_error_sw_fit,sw_distance_l1_fit,sw_distance_sw_fit\n");
    for e in &o.entry_rows {
        let _ = writeln!(
            entries,
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
        );
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
        "findings": o.findings,
    });
    vec![
        Box::new(Markdown::new("objectives.md", md)),
        Box::new(Csv::new("lines.csv", lines)),
        Box::new(Csv::new("entries.csv", entries)),
        Box::new(Json::new("objectives.json", json, Layout::PrettyLine)),
    ]
}
