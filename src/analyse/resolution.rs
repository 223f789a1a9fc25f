//! The resolution study's statistics (`linelight resolution`; docs in src/app/resolution.rs):
//! per family and region (the natural sample overall, and each bin of the case's `highlight`
//! axis with its top-ups), the error against GGX truth of each table, its table link (against
//! the exact fit) and the fit link, as nearest-rank medians and p90s with their counts; paired
//! ratios between resolutions with bootstrap intervals. The findings are written from these
//! by `report::resolution`.

use crate::analyse::gate::paired;
use crate::analyse::stats::nearest_rank;
use crate::input::case::Case;
use crate::measure::resolution::{Point, ResolutionRun};
use serde::Serialize;

/// Nearest-rank median and p90 of a set of relative errors, with its count.
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    pub n: usize,
    pub median: f64,
    pub p90: f64,
}

fn summary(mut v: Vec<f64>) -> Summary {
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        return Summary {
            n: 0,
            median: f64::NAN,
            p90: f64::NAN,
        };
    }
    Summary {
        n: v.len(),
        median: nearest_rank(&v, 0.5),
        p90: nearest_rank(&v, 0.9),
    }
}

/// One table in one region.
#[derive(Clone, Debug, Serialize)]
pub struct TableRow {
    pub table: String,
    /// |E_table − T|/T: what users see.
    pub error: Summary,
    /// |E_table − E_fit|/T: the discretisation (the table's interpolation of the fits).
    pub table_link: Summary,
}

/// The geometric mean over configurations of error(coarse)/error(fine), with its 95 %
/// bootstrap interval (`analyse::gate::paired`, errors floored at 2⁻²⁴).
#[derive(Clone, Debug, Serialize)]
pub struct Ratio {
    pub coarse: String,
    pub fine: String,
    /// Of the error against truth, and of the table link.
    pub error: [f64; 3],
    pub table_link: [f64; 3],
    pub pairs: usize,
}

#[derive(Clone, Debug, Serialize)]
pub struct Region {
    pub family: String,
    /// "all (natural sample)" or "highlight [lo, hi)°".
    pub region: String,
    /// Configurations in the region, and those left out because the truth is 0 (no light:
    /// a relative error is undefined there) with how many of them a table lights anyway.
    pub configurations: usize,
    pub dark: usize,
    pub dark_lit_by_a_table: usize,
    /// |E_fit − T|/T.
    pub fit_link: Summary,
    pub tables: Vec<TableRow>,
    pub ratios: Vec<Ratio>,
}

#[derive(Clone, Debug, Serialize)]
pub struct Resolution {
    pub regions: Vec<Region>,
    pub labels: Vec<String>,
    pub configurations: usize,
    pub seconds: f64,
}

/// Bootstrap resamples of every ratio's interval.
pub const RESAMPLES: usize = 2000;
/// "At most x % worse than the finest": a coarser table whose error ratio's 95 % interval lies
/// below 1 + this (one-sided: a table far better than the finest passes too).
pub const WITHIN: f64 = 0.1;

fn region(family: &str, name: String, points: &[&Point], labels: &[String]) -> Region {
    let lit: Vec<&&Point> = points.iter().filter(|p| p.truth > 0.0).collect();
    let dark: Vec<&&Point> = points.iter().filter(|p| !(p.truth > 0.0)).collect();
    let rel = |a: f64, b: f64, t: f64| (a - b).abs() / t;
    let fit_link = summary(lit.iter().map(|p| rel(p.fit, p.truth, p.truth)).collect());
    let applies = |p: &Point, k: usize| p.tables[k].is_finite();
    let tables: Vec<TableRow> = labels
        .iter()
        .enumerate()
        .map(|(k, label)| TableRow {
            table: label.clone(),
            error: summary(
                lit.iter()
                    .filter(|p| applies(p, k))
                    .map(|p| rel(p.tables[k], p.truth, p.truth))
                    .collect(),
            ),
            table_link: summary(
                lit.iter()
                    .filter(|p| applies(p, k))
                    .map(|p| rel(p.tables[k], p.fit, p.truth))
                    .collect(),
            ),
        })
        .collect();
    // Every pair (coarse, fine), in the order given (coarsest first), on the configurations
    // both apply to.
    let mut ratios = Vec::new();
    for (i, coarse) in labels.iter().enumerate() {
        for (j, fine) in labels.iter().enumerate().skip(i + 1) {
            let both: Vec<&&Point> = lit.iter().filter(|p| applies(p, i) && applies(p, j)).copied().collect();
            if both.is_empty() {
                continue;
            }
            let pairs = |f: &dyn Fn(&Point, usize) -> f64| -> Vec<(f64, f64)> {
                both.iter().map(|p| (f(p, j), f(p, i))).collect()
            };
            let err = pairs(&|p, k| rel(p.tables[k], p.truth, p.truth));
            let link = pairs(&|p, k| rel(p.tables[k], p.fit, p.truth));
            ratios.push(Ratio {
                coarse: coarse.clone(),
                fine: fine.clone(),
                error: paired(&err, RESAMPLES, 0.0).geomean,
                table_link: paired(&link, RESAMPLES, 0.0).geomean,
                pairs: both.len(),
            });
        }
    }
    Region {
        family: family.to_string(),
        region: name,
        configurations: points.len(),
        dark: dark.len(),
        dark_lit_by_a_table: dark
            .iter()
            .filter(|p| p.tables.iter().any(|&v| v.is_finite() && v != 0.0))
            .count(),
        fit_link,
        tables,
        ratios,
    }
}

/// The regions of every family.
pub fn analyse(case: &Case, run: &ResolutionRun) -> Resolution {
    let axis = case.bins.iter().find(|b| b.axis == "highlight");
    let mut regions = Vec::new();
    for family in &case.materials {
        let members: Vec<&Point> = run.points.iter().filter(|p| p.family == family.name).collect();
        let natural: Vec<&Point> = members.iter().filter(|p| p.natural).copied().collect();
        regions.push(region(
            &family.name,
            "all (natural sample)".to_string(),
            &natural,
            &run.labels,
        ));
        if let Some(axis) = axis {
            for k in 0..axis.edges.len() - 1 {
                let inside: Vec<&Point> = members
                    .iter()
                    .filter(|p| {
                        if p.natural {
                            axis.index(p.highlight) == Some(k)
                        } else {
                            p.strata.contains(&k)
                        }
                    })
                    .copied()
                    .collect();
                let name = format!("highlight [{}, {})°", axis.edges[k], axis.edges[k + 1]);
                regions.push(region(&family.name, name, &inside, &run.labels));
            }
        }
    }
    Resolution {
        regions,
        labels: run.labels.clone(),
        configurations: run.points.len(),
        seconds: run.seconds,
    }
}
