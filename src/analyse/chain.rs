//! The GGX error chain, analysed: each measured point's links (|a − b| / T, so they add up to
//! the total), the medians per bin of roughness × view angle and the link that dominates, our
//! table beside the published one, the anisotropic bins, and the facts the findings state
//! (`report::chain` writes them as sentences).

use crate::analyse::stats::{bin_index, Quantiles};
use crate::measure::chain::{ChainRun, Point};
use serde::Serialize;
use std::collections::BTreeMap;

/// The links, in chain order.
pub const LINKS: [&str; 6] = ["fit", "table", "storage", "formula", "rounding", "driver"];

/// Bins of roughness α and view angle (degrees) of the dominant-link tables.
pub const ALPHA_EDGES: [f64; 5] = [0.01, 0.03, 0.1, 0.3, 1.0];
pub const VIEW_EDGES: [f64; 5] = [0.0, 30.0, 60.0, 75.0, 90.0];
/// Bins of the miss angle (degrees) of the table beside the published one.
pub const MISS_EDGES: [f64; 6] = [0.0, 2.0, 5.0, 15.0, 45.0, 180.0];

/// One configuration's chain for one method.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    pub config: usize,
    pub method: String,
    pub family: String,
    pub alpha: f64,
    pub view_angle: f64,
    pub anisotropy: f64,
    /// α_min/α_max as shaded (after each α is clamped to 1); 1 for isotropic roughness.
    pub ratio: f64,
    pub truth: f64,
    /// Relative size of each link (NaN where it does not apply).
    pub links: [f64; 6],
    /// |GPU − T|/T with our feed (the isotropic table, or the anisotropic one).
    pub total: f64,
    /// Isotropic only: the same method fed the published table (f32 bilinear): |GPU − T|/T,
    /// and that look-up's exact LTC integral against T.
    pub published_total: f64,
    pub published_fit: f64,
    /// Our table's look-up (isotropic or anisotropic), exact LTC integral against T.
    pub table_fit: f64,
    /// Schlick's F0 (1 without one).
    pub f0: f64,
    /// The Fresnel link: |f0·magnitude + (1 − f0)·fresnel − ∫D·F| / ∫D·F, our feed's
    /// Fresnel-weighted magnitude (what an LTC method is multiplied by) against the exact
    /// integral of the lobe with F. Not one of [`LINKS`]: it is part of the table link (the
    /// look-up's magnitude), shown apart because it is the only place F enters an LTC method.
    pub fresnel: f64,
    /// The exact ∫D·F's own relative error estimate: a Fresnel link not far above it is the
    /// quadrature's, not the feed's.
    pub fresnel_reference: f64,
    /// Angle (degrees) between the mirror direction of the view and the segment's nearest
    /// direction: how close the light comes to the lobe's peak.
    pub miss: f64,
}

fn rel(a: f64, b: f64, truth: f64) -> f64 {
    (a - b).abs() / truth.abs()
}

impl Row {
    /// The links of a measured point, or None where the light is not seen (T not above 0: no
    /// relative error to chain).
    fn of(p: &Point) -> Option<Row> {
        let truth = p.truth;
        if !(truth > 0.0) {
            return None;
        }
        let lookup = p.table;
        Some(Row {
            config: p.config,
            method: p.method.clone(),
            family: p.family.clone(),
            alpha: p.alpha,
            view_angle: p.view_angle,
            anisotropy: p.anisotropy,
            ratio: p.ratio,
            truth,
            links: [
                rel(p.fit, truth, truth),
                rel(p.table, p.fit, truth),
                rel(p.table16, p.table, truth),
                rel(p.f64, lookup, truth),
                rel(p.cpu_f32, p.f64, truth),
                rel(p.gpu, p.cpu_f32, truth),
            ],
            total: rel(p.gpu, truth, truth),
            published_total: p.published_gpu.map_or(f64::NAN, |v| rel(v, truth, truth)),
            published_fit: rel(p.published_exact, truth, truth),
            table_fit: rel(p.table, truth, truth),
            f0: p.f0,
            fresnel: rel(p.fed_norm, p.exact_norm, p.exact_norm),
            fresnel_reference: p.exact_norm_error / p.exact_norm.abs(),
            miss: p.miss,
        })
    }
}

/// Our table beside the published one, for one method (isotropic configurations).
#[derive(Clone, Debug)]
pub struct Published {
    pub method: String,
    pub n: usize,
    /// Medians of each look-up's exact LTC integral against T.
    pub ours_exact: Option<f64>,
    pub published_exact: Option<f64>,
    /// |GPU − T|/T fed each table.
    pub ours_gpu: Option<Quantiles>,
    pub published_gpu: Option<Quantiles>,
}

/// The same, in one bin of the miss angle: medians of |GPU − T|/T.
#[derive(Clone, Debug)]
pub struct ByMiss {
    pub method: String,
    pub miss: [f64; 2],
    pub n: usize,
    pub ours: Option<f64>,
    pub published: Option<f64>,
}

/// The anisotropic chain: per method what its findings say, and its its bins of r × view angle and r × α.
#[derive(Clone, Debug)]
pub struct Aniso {
    pub findings: Vec<AnisoFinding>,
    pub methods: Vec<(String, Vec<Bin2>, Vec<Bin2>)>,
}

/// The Fresnel link over one family's configurations (each counted once, whatever the methods).
#[derive(Clone, Debug, Serialize)]
pub struct FresnelLink {
    pub family: String,
    /// The smallest and largest F0 of the family.
    pub f0: [f64; 2],
    pub n: usize,
    pub link: Option<Quantiles>,
    /// The exact ∫D·F's relative error estimate over the same configurations.
    pub reference: Option<Quantiles>,
}

/// Everything the chain report shows.
pub struct Chain {
    pub rows: Vec<Row>,
    pub fresnel: Vec<FresnelLink>,
    pub cells: Vec<Cell>,
    /// What the findings say, per method and family, and per method against the published table.
    pub links: Vec<LinkFinding>,
    pub versus: Vec<VersusPublished>,
    pub published: Vec<Published>,
    pub by_miss: Vec<ByMiss>,
    /// None without anisotropic configurations.
    pub aniso: Option<Aniso>,
    pub configurations: usize,
    pub adapter: String,
    pub seconds: f64,
}

/// The chain analysed.
pub fn analyse(run: &ChainRun) -> Chain {
    let rows: Vec<Row> = run.points.iter().filter_map(Row::of).collect();
    let cells = cells(&rows, &ALPHA_EDGES, &VIEW_EDGES);
    let links = link_findings(&rows, &cells);
    let versus = versus_published(&rows);
    let mut published = Vec::new();
    let mut by_miss = Vec::new();
    for (method, rs) in by_method(&rows, true) {
        let q = |f: &dyn Fn(&Row) -> f64| quantiles(rs.iter().map(|r| f(r)));
        published.push(Published {
            method: method.clone(),
            n: rs.len(),
            ours_exact: q(&|r| r.table_fit).map(|q| q.median),
            published_exact: q(&|r| r.published_fit).map(|q| q.median),
            ours_gpu: q(&|r| r.total),
            published_gpu: q(&|r| r.published_total),
        });
    }
    for (method, rs) in by_method(&rows, true) {
        for w in MISS_EDGES.windows(2) {
            let near: Vec<&&Row> = rs.iter().filter(|r| r.miss >= w[0] && r.miss < w[1]).collect();
            if near.is_empty() {
                continue;
            }
            by_miss.push(ByMiss {
                method: method.clone(),
                miss: [w[0], w[1]],
                n: near.len(),
                ours: median(near.iter().map(|r| r.total)),
                published: median(near.iter().map(|r| r.published_total)),
            });
        }
    }
    let aniso = aniso(&rows);
    let fresnel = fresnel_links(&rows);
    Chain {
        fresnel,
        rows,
        cells,
        links,
        versus,
        published,
        by_miss,
        aniso,
        configurations: run.configurations,
        adapter: run.adapter.clone(),
        seconds: run.seconds,
    }
}

/// The Fresnel link per family, each configuration once (the link does not depend on the method).
fn fresnel_links(rows: &[Row]) -> Vec<FresnelLink> {
    let mut by_family: BTreeMap<&str, BTreeMap<usize, &Row>> = BTreeMap::new();
    for r in rows {
        by_family.entry(&r.family).or_default().entry(r.config).or_insert(r);
    }
    by_family
        .into_iter()
        .map(|(family, configs)| {
            let f0 = configs.values().fold([f64::INFINITY, f64::NEG_INFINITY], |a, r| {
                [a[0].min(r.f0), a[1].max(r.f0)]
            });
            FresnelLink {
                family: family.to_string(),
                f0,
                n: configs.len(),
                link: quantiles(configs.values().map(|r| r.fresnel)),
                reference: quantiles(configs.values().map(|r| r.fresnel_reference)),
            }
        })
        .collect()
}

/// The anisotropic rows (r < 1) binned by r against the view angle and against α, per method.
fn aniso(rows: &[Row]) -> Option<Aniso> {
    let aniso: Vec<&Row> = rows.iter().filter(|r| r.ratio < 1.0).collect();
    if aniso.is_empty() {
        return None;
    }
    let mut methods: Vec<&str> = aniso.iter().map(|r| r.method.as_str()).collect();
    methods.sort();
    methods.dedup();
    let methods = methods
        .into_iter()
        .map(|m| {
            let rs: Vec<&Row> = aniso.iter().copied().filter(|r| r.method == m).collect();
            (
                m.to_string(),
                bins2(&rs, |r| r.ratio, &RATIO_EDGES, |r| r.view_angle, &VIEW_EDGES),
                bins2(&rs, |r| r.ratio, &RATIO_EDGES, |r| r.alpha, &ALPHA_EDGES),
            )
        })
        .collect();
    Some(Aniso {
        findings: aniso_findings(&aniso),
        methods,
    })
}

/// The nearest-rank median of the finite values (analyse::stats), None when there are none.
fn median(values: impl Iterator<Item = f64>) -> Option<f64> {
    let v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
    crate::analyse::stats::median(&v)
}

fn quantiles(values: impl Iterator<Item = f64>) -> Option<Quantiles> {
    let mut v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
    Quantiles::of(&mut v)
}

/// One bin's medians per link and the link that dominates.
#[derive(Clone, Debug, Serialize)]
pub struct Cell {
    pub method: String,
    pub family: String,
    pub alpha: [f64; 2],
    pub view_angle: [f64; 2],
    pub count: usize,
    pub links: [Option<f64>; 6],
    pub total: Option<f64>,
    pub dominant: Option<&'static str>,
}

fn cells(rows: &[Row], alpha_edges: &[f64], view_edges: &[f64]) -> Vec<Cell> {
    let mut out = Vec::new();
    let mut keys: Vec<(String, String)> = rows.iter().map(|r| (r.method.clone(), r.family.clone())).collect();
    keys.dedup();
    keys.sort();
    keys.dedup();
    for (method, family) in keys {
        for a in 0..alpha_edges.len() - 1 {
            for v in 0..view_edges.len() - 1 {
                let rows: Vec<&Row> = rows
                    .iter()
                    .filter(|r| r.method == method && r.family == family)
                    .filter(|r| {
                        bin_index(alpha_edges, r.alpha) == Some(a) && bin_index(view_edges, r.view_angle) == Some(v)
                    })
                    .collect();
                let links: [Option<f64>; 6] = std::array::from_fn(|k| median(rows.iter().map(|r| r.links[k])));
                let dominant = LINKS
                    .iter()
                    .zip(links)
                    .filter_map(|(n, l)| l.map(|l| (*n, l)))
                    .max_by(|x, y| x.1.total_cmp(&y.1))
                    .map(|(n, _)| n);
                out.push(Cell {
                    method: method.clone(),
                    family: family.clone(),
                    alpha: [alpha_edges[a], alpha_edges[a + 1]],
                    view_angle: [view_edges[v], view_edges[v + 1]],
                    count: rows.len(),
                    links,
                    total: median(rows.iter().map(|r| r.total)),
                    dominant: if rows.is_empty() { None } else { dominant },
                });
            }
        }
    }
    out
}

/// Bin edges of the anisotropic chain: α_min/α_max as shaded.
const RATIO_EDGES: [f64; 5] = [0.25, 0.4, 0.6, 0.8, 1.0];

/// Median links per bin of two axes, over the given rows: (x bin, y bin, count, links,
/// total, dominant link).
pub type Bin2 = (
    [f64; 2],
    [f64; 2],
    usize,
    [Option<f64>; 6],
    Option<f64>,
    Option<&'static str>,
);

fn bins2(rows: &[&Row], fx: fn(&Row) -> f64, ex: &[f64], fy: fn(&Row) -> f64, ey: &[f64]) -> Vec<Bin2> {
    let mut out = Vec::new();
    for x in 0..ex.len() - 1 {
        for y in 0..ey.len() - 1 {
            let rs: Vec<&&Row> = rows
                .iter()
                .filter(|r| bin_index(ex, fx(r)) == Some(x) && bin_index(ey, fy(r)) == Some(y))
                .collect();
            if rs.is_empty() {
                continue;
            }
            let links: [Option<f64>; 6] = std::array::from_fn(|k| median(rs.iter().map(|r| r.links[k])));
            let dominant = LINKS
                .iter()
                .zip(links)
                .filter_map(|(n, l)| l.map(|l| (*n, l)))
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .map(|(n, _)| n);
            out.push((
                [ex[x], ex[x + 1]],
                [ey[y], ey[y + 1]],
                rs.len(),
                links,
                median(rs.iter().map(|r| r.total)),
                dominant,
            ));
        }
    }
    out
}

fn by_method(rows: &[Row], iso_only: bool) -> Vec<(String, Vec<&Row>)> {
    let mut out: BTreeMap<String, Vec<&Row>> = BTreeMap::new();
    for r in rows {
        if !iso_only || r.published_total.is_finite() {
            out.entry(r.method.clone()).or_default().push(r);
        }
    }
    out.into_iter().collect()
}

/// One method on one family of roughness: what the findings say of its links.
#[derive(Clone, Debug)]
pub struct LinkFinding {
    pub method: String,
    pub family: String,
    pub configurations: usize,
    /// How many bins of α × view angle each link dominates, by link name.
    pub dominant: Vec<(&'static str, usize)>,
    /// Bins with a configuration.
    pub bins: usize,
    /// Each link's median over all its configurations, in [`LINKS`] order.
    pub medians: [Option<f64>; 6],
    pub total: Option<f64>,
}

/// One method fed our table and the published one, isotropic configurations.
#[derive(Clone, Debug)]
pub struct VersusPublished {
    pub method: String,
    pub configurations: usize,
    /// Median |GPU − T|/T fed ours, and fed the published table.
    pub ours: f64,
    pub theirs: f64,
    /// The configurations whose light passes within 5° of the mirror direction, and their
    /// medians (ours, published) when both exist.
    pub near: usize,
    pub near_medians: Option<(f64, f64)>,
}

/// One method on the anisotropic configurations.
#[derive(Clone, Debug)]
pub struct AnisoFinding {
    pub method: String,
    pub configurations: usize,
    /// Each link's median, in [`LINKS`] order, and the total's.
    pub medians: [Option<f64>; 6],
    pub total: Option<f64>,
    /// How many bins of r × view angle each link dominates, by link name, of `bins`.
    pub dominant: Vec<(&'static str, usize)>,
    pub bins: usize,
    /// The bin where the table link is largest.
    pub worst: Option<Bin2>,
}

/// How many bins each link dominates, in link-name order.
fn dominant_counts(dominant: impl Iterator<Item = Option<&'static str>>) -> Vec<(&'static str, usize)> {
    let mut counts: BTreeMap<&'static str, usize> = BTreeMap::new();
    for d in dominant.flatten() {
        *counts.entry(d).or_default() += 1;
    }
    counts.into_iter().collect()
}

/// The anisotropic rows, per method.
fn aniso_findings(rows: &[&Row]) -> Vec<AnisoFinding> {
    let mut methods: Vec<&str> = rows.iter().map(|r| r.method.as_str()).collect();
    methods.sort();
    methods.dedup();
    methods
        .into_iter()
        .map(|m| {
            let rs: Vec<&Row> = rows.iter().copied().filter(|r| r.method == m).collect();
            let bins = bins2(&rs, |r| r.ratio, &RATIO_EDGES, |r| r.view_angle, &VIEW_EDGES);
            let worst = bins
                .iter()
                .filter(|b| b.3[1].is_some())
                .max_by(|a, b| a.3[1].unwrap_or(0.0).total_cmp(&b.3[1].unwrap_or(0.0)))
                .cloned();
            AnisoFinding {
                method: m.to_string(),
                configurations: rs.len(),
                medians: std::array::from_fn(|k| median(rs.iter().map(|r| r.links[k]))),
                total: median(rs.iter().map(|r| r.total)),
                dominant: dominant_counts(bins.iter().map(|b| b.5)),
                bins: bins.len(),
                worst,
            }
        })
        .collect()
}

/// Per method and family, its links; the bins are `cells`'.
fn link_findings(all: &[Row], cells: &[Cell]) -> Vec<LinkFinding> {
    let mut out = Vec::new();
    for (method, rows) in by_method(all, false) {
        let mut fams: Vec<String> = rows.iter().map(|r| r.family.clone()).collect();
        fams.sort();
        fams.dedup();
        for fam in fams {
            let rs: Vec<&&Row> = rows.iter().filter(|r| r.family == fam).collect();
            let bins: Vec<&Cell> = cells
                .iter()
                .filter(|c| c.method == method && c.family == fam && c.count > 0)
                .collect();
            out.push(LinkFinding {
                method: method.clone(),
                family: fam,
                configurations: rs.len(),
                dominant: dominant_counts(bins.iter().map(|c| c.dominant)),
                bins: bins.len(),
                medians: std::array::from_fn(|k| median(rs.iter().map(|r| r.links[k]))),
                total: median(rs.iter().map(|r| r.total)),
            });
        }
    }
    out
}

/// Per method, our table against the published one (isotropic configurations).
fn versus_published(all: &[Row]) -> Vec<VersusPublished> {
    let mut out = Vec::new();
    for (method, rows) in by_method(all, true) {
        let ours = median(rows.iter().map(|r| r.total));
        let theirs = median(rows.iter().map(|r| r.published_total));
        if let (Some(ours), Some(theirs)) = (ours, theirs) {
            let near: Vec<&&Row> = rows.iter().filter(|r| r.miss < 5.0).collect();
            let near_medians = match (
                median(near.iter().map(|r| r.total)),
                median(near.iter().map(|r| r.published_total)),
            ) {
                (Some(a), Some(b)) => Some((a, b)),
                _ => None,
            };
            out.push(VersusPublished {
                method,
                configurations: rows.len(),
                ours,
                theirs,
                near: near.len(),
                near_medians,
            });
        }
    }
    out
}
