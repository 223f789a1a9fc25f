//! The comparison of fitting objectives (L1 against sliced Wasserstein), analysed: per region
//! (near the highlight, the natural sample) and per slice or α_max, the line-light error
//! |value − T|/T of the L1-fitted and the SW-fitted matrices (nearest-rank quantiles, over the
//! lines whose truth is above 0, no floor), paired counts of which is nearer T, the lines whose
//! truth is 0 apart (false light), the lobe errors of both; `report::objectives` writes the
//! findings from these numbers.

use crate::analyse::stats::Quantiles;
use crate::measure::objectives::{Line, Region, Run};

/// The two fits, in column order.
pub const VARIANTS: [&str; 2] = ["L1 (Nelder–Mead)", "SW (SGD)"];

/// Line-light errors of one group of lines.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Group {
    pub label: String,
    /// Lines with T > 0 and both values finite.
    pub n: usize,
    /// Quantiles of |value − T|/T for [L1, SW].
    #[serde(skip)]
    pub error: [Option<Quantiles>; 2],
    pub median: [Option<f64>; 2],
    pub p90: [Option<f64>; 2],
    /// Lines where SW is nearer T than L1, where L1 is nearer, and equal.
    pub sw_nearer: usize,
    pub l1_nearer: usize,
    pub equal: usize,
    /// Lines with T = 0, and of those, where each variant gives light (> 0).
    pub zero_truth: usize,
    pub false_light: [usize; 2],
    /// Lines where a value or T is not finite (never folded into the quantiles).
    pub not_finite: usize,
}

/// The lobe errors of a group of entries.
#[derive(Clone, Debug, serde::Serialize)]
pub struct LobeGroup {
    pub label: String,
    pub n: usize,
    /// Medians of the relative L1 lobe error and of the SW distance, for [L1, SW].
    pub l1_error_median: [Option<f64>; 2],
    pub sw_distance_median: [Option<f64>; 2],
    /// Entries where the SW fit has the lower L1 lobe error, the lower SW distance.
    pub sw_lower_l1: usize,
    pub sw_lower_sw: usize,
}

#[derive(Clone, Debug, serde::Serialize)]
pub struct Objectives {
    pub size: [usize; 4],
    pub entries: usize,
    pub lines_per_region: usize,
    pub seconds: f64,
    /// Per region: all lines, then per slice (φ, r), per α_max, and (natural only) per
    /// highlight-angle bin.
    pub regions: Vec<(String, Vec<Group>)>,
    pub lobes: Vec<LobeGroup>,
    /// Per region: entries where the SW fit's median line error is below the L1 fit's, above,
    /// and equal (the entry's lines with T > 0).
    pub entries_sw_better: Vec<(String, [usize; 3])>,
    /// The highlight region's largest angle (degrees) between the segment's nearest point and
    /// the mirror direction.
    pub highlight_cap: f64,
    /// Every line, for the CSV.
    pub rows: Vec<Row>,
    /// Every entry's lobe errors.
    pub entry_rows: Vec<EntryRow>,
}

/// One line as the CSV has it.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Row {
    pub entry: [usize; 4],
    pub region: String,
    pub highlight: f64,
    pub p1: [f64; 3],
    pub p2: [f64; 3],
    pub truth: f64,
    pub truth_error: f64,
    pub l1: f64,
    pub sw: f64,
}

/// One entry's lobe errors as the CSV has them.
#[derive(Clone, Debug, serde::Serialize)]
pub struct EntryRow {
    pub entry: [usize; 4],
    pub point: [f64; 4],
    pub l1_error: [f64; 2],
    pub sw_distance: [f64; 2],
}

/// Highlight-angle bins (degrees) of the natural sample, as cases/ggx.toml's.
pub const HIGHLIGHT_EDGES: [f64; 6] = [0.0, 5.0, 15.0, 45.0, 90.0, 180.0];

fn group(label: String, lines: &[&Line]) -> Group {
    let (mut e1, mut e2) = (Vec::new(), Vec::new());
    let (mut sw_nearer, mut l1_nearer, mut equal) = (0, 0, 0);
    let (mut zero_truth, mut false_light, mut not_finite) = (0, [0usize; 2], 0);
    for l in lines {
        if !(l.truth.is_finite() && l.l1.is_finite() && l.sw.is_finite()) {
            not_finite += 1;
            continue;
        }
        if l.truth == 0.0 {
            zero_truth += 1;
            false_light[0] += usize::from(l.l1 > 0.0);
            false_light[1] += usize::from(l.sw > 0.0);
            continue;
        }
        let a = (l.l1 - l.truth).abs() / l.truth.abs();
        let b = (l.sw - l.truth).abs() / l.truth.abs();
        e1.push(a);
        e2.push(b);
        match b.total_cmp(&a) {
            std::cmp::Ordering::Less => sw_nearer += 1,
            std::cmp::Ordering::Greater => l1_nearer += 1,
            std::cmp::Ordering::Equal => equal += 1,
        }
    }
    let n = e1.len();
    let error = [Quantiles::of(&mut e1), Quantiles::of(&mut e2)];
    Group {
        label,
        n,
        median: [0, 1].map(|k| error[k].as_ref().map(|q| q.median)),
        p90: [0, 1].map(|k| error[k].as_ref().map(|q| q.p90)),
        error,
        sw_nearer,
        l1_nearer,
        equal,
        zero_truth,
        false_light,
        not_finite,
    }
}

fn slice_label(run: &Run, i: [usize; 4]) -> String {
    let p = crate::input::ltc::aniso::entry_point(run.size, i);
    format!("φ {:.1}°, r {:.3}", p[1].to_degrees(), p[3])
}

pub fn analyse(run: &Run) -> Objectives {
    let mut slices: Vec<[usize; 2]> = run.lobes.iter().map(|l| [l.entry[1], l.entry[3]]).collect();
    slices.sort();
    slices.dedup();
    let mut alphas: Vec<usize> = run.lobes.iter().map(|l| l.entry[2]).collect();
    alphas.sort();
    alphas.dedup();
    let mut regions = Vec::new();
    for region in Region::ALL {
        let lines: Vec<&Line> = run.lines.iter().filter(|l| l.region == region).collect();
        let mut groups = vec![group("all".into(), &lines)];
        for sl in &slices {
            let sub: Vec<&Line> = lines
                .iter()
                .copied()
                .filter(|l| [l.entry[1], l.entry[3]] == *sl)
                .collect();
            let label = slice_label(run, [0, sl[0], 0, sl[1]]);
            groups.push(group(label, &sub));
        }
        for &a in &alphas {
            let sub: Vec<&Line> = lines.iter().copied().filter(|l| l.entry[2] == a).collect();
            let p = crate::input::ltc::aniso::entry_point(run.size, [0, 0, a, 0]);
            groups.push(group(format!("α_max {:.2}", p[2]), &sub));
        }
        if region == Region::Natural {
            for w in HIGHLIGHT_EDGES.windows(2) {
                let last = w[1] == 180.0;
                let sub: Vec<&Line> = lines
                    .iter()
                    .copied()
                    .filter(|l| l.highlight >= w[0] && (l.highlight < w[1] || (last && l.highlight <= w[1])))
                    .collect();
                groups.push(group(format!("highlight {}–{}°", w[0], w[1]), &sub));
            }
        }
        regions.push((region.name().to_string(), groups));
    }

    let lobe_group = |label: String, pick: &dyn Fn(&crate::measure::objectives::Lobe) -> bool| {
        let ls: Vec<_> = run.lobes.iter().filter(|l| pick(l)).collect();
        let col = |f: &dyn Fn(&crate::measure::objectives::Lobe) -> f64| {
            crate::analyse::stats::median(&ls.iter().map(|l| f(l)).collect::<Vec<_>>())
        };
        LobeGroup {
            label,
            n: ls.len(),
            l1_error_median: [col(&|l| l.l1_error[0]), col(&|l| l.l1_error[1])],
            sw_distance_median: [col(&|l| l.sw_distance[0]), col(&|l| l.sw_distance[1])],
            sw_lower_l1: ls.iter().filter(|l| l.l1_error[1] < l.l1_error[0]).count(),
            sw_lower_sw: ls.iter().filter(|l| l.sw_distance[1] < l.sw_distance[0]).count(),
        }
    };
    let mut lobes = vec![lobe_group("all".into(), &|_| true)];
    for sl in &slices {
        let sl = *sl;
        lobes.push(lobe_group(slice_label(run, [0, sl[0], 0, sl[1]]), &|l| {
            [l.entry[1], l.entry[3]] == sl
        }));
    }
    for &a in &alphas {
        let p = crate::input::ltc::aniso::entry_point(run.size, [0, 0, a, 0]);
        lobes.push(lobe_group(format!("α_max {:.2}", p[2]), &|l| l.entry[2] == a));
    }

    let mut entries_sw_better = Vec::new();
    for region in Region::ALL {
        let mut c = [0usize; 3];
        for lobe in &run.lobes {
            let ls: Vec<&Line> = run
                .lines
                .iter()
                .filter(|l| l.region == region && l.entry == lobe.entry)
                .collect();
            let g = group(String::new(), &ls);
            match (g.median[0], g.median[1]) {
                (Some(a), Some(b)) if b < a => c[0] += 1,
                (Some(a), Some(b)) if b > a => c[1] += 1,
                (Some(_), Some(_)) => c[2] += 1,
                _ => {}
            }
        }
        entries_sw_better.push((region.name().to_string(), c));
    }

    Objectives {
        size: run.size,
        entries: run.lobes.len(),
        lines_per_region: run.lines_per_region,
        seconds: run.seconds,
        regions,
        lobes,
        entries_sw_better,
        highlight_cap: crate::measure::objectives::HIGHLIGHT_CAP,
        rows: run
            .lines
            .iter()
            .map(|l| Row {
                entry: l.entry,
                region: l.region.name().to_string(),
                highlight: l.highlight,
                p1: l.p1,
                p2: l.p2,
                truth: l.truth,
                truth_error: l.truth_error,
                l1: l.l1,
                sw: l.sw,
            })
            .collect(),
        entry_rows: run
            .lobes
            .iter()
            .map(|l| EntryRow {
                entry: l.entry,
                point: l.point,
                l1_error: l.l1_error,
                sw_distance: l.sw_distance,
            })
            .collect(),
    }
}
