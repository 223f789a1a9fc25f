//! SVG heat maps of a validity map: one cell per (x, y) bin, coloured by the p99 relative
//! error in the bands the reports state (≤0.1 %, ≤1 %, ≤5 %, ≤10 %, more), value printed.

use crate::analyse::analysis::MapStats;
use crate::report::markup::{xml_escape as escape, Doc as _};

/// Upper edges of the colour bands and their colours (colour-blind-safe sequential).
pub const BANDS: [(f64, &str, &str); 5] = [
    (1e-3, "#1a9850", "≤ 0.1 %"),
    (1e-2, "#91cf60", "≤ 1 %"),
    (5e-2, "#fee08b", "≤ 5 %"),
    (1e-1, "#fc8d59", "≤ 10 %"),
    (f64::INFINITY, "#d73027", "> 10 %"),
];

fn colour(p99: f64) -> &'static str {
    BANDS
        .iter()
        .find(|(limit, _, _)| p99 <= *limit)
        .map_or("#d73027", |b| b.1)
}

fn edge(x: f64) -> String {
    if x != 0.0 && (x.abs() < 1e-2 || x.abs() >= 1e4) {
        format!("{x:.0e}")
    } else {
        format!("{x}")
    }
}

pub fn heat_map(map: &MapStats, title: &str) -> String {
    let (nx, ny) = (map.x.edges.len() - 1, map.y.edges.len() - 1);
    let (cw, ch) = (74.0, 34.0);
    let (left, top) = (90.0, 50.0);
    let width = left + cw * nx as f64 + 150.0;
    let height = top + ch * ny as f64 + 70.0;
    let mut s = String::new();
    s.line(format_args!(r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" font-family="sans-serif" font-size="11">"#));
    s.line(format_args!(r#"<rect width="100%" height="100%" fill="white"/>"#));
    s.line(format_args!(
        r#"<text x="{left}" y="20" font-size="13" font-weight="bold">{}</text>"#,
        escape(title)
    ));
    s.line(format_args!(
        r#"<text x="{left}" y="36">p99 relative error per cell (count below); grey: no sample</text>"#
    ));
    // Rows: y grows upwards, as on a chart.
    for (ky, row) in map.cells.iter().enumerate() {
        let y = top + ch * (ny - 1 - ky) as f64;
        for (kx, stats) in row.iter().enumerate() {
            let x = left + cw * kx as f64;
            let n = stats.count + stats.nan + stats.inf;
            // NaN/inf make a cell red whatever its finite errors say.
            let p99 = stats
                .rel
                .map(|q| q.p99)
                .map(|p| if stats.nan + stats.inf > 0 { f64::INFINITY } else { p });
            let fill = p99.map_or("#dddddd", colour);
            s.line(format_args!(
                r#"<rect x="{x}" y="{y}" width="{cw}" height="{ch}" fill="{fill}" stroke="white"/>"#
            ));
            let label = match stats.rel {
                Some(q) if stats.nan + stats.inf > 0 => format!("{:.0e} +NaN", q.p99),
                Some(q) => format!("{:.1e}", q.p99),
                None => "—".into(),
            };
            s.line(format_args!(
                r#"<text x="{}" y="{}" text-anchor="middle">{label}</text>"#,
                x + cw / 2.0,
                y + 15.0
            ));
            s.line(format_args!(
                r##"<text x="{}" y="{}" text-anchor="middle" font-size="9" fill="#333">n={n}</text>"##,
                x + cw / 2.0,
                y + 28.0
            ));
        }
    }
    // Axes: bin edges.
    for (k, e) in map.x.edges.iter().enumerate() {
        let x = left + cw * k as f64;
        s.line(format_args!(
            r#"<text x="{x}" y="{}" text-anchor="middle">{}</text>"#,
            top + ch * ny as f64 + 14.0,
            edge(*e)
        ));
    }
    s.line(format_args!(
        r#"<text x="{}" y="{}" text-anchor="middle" font-weight="bold">{}</text>"#,
        left + cw * nx as f64 / 2.0,
        top + ch * ny as f64 + 34.0,
        escape(&map.x.axis)
    ));
    for (k, e) in map.y.edges.iter().enumerate() {
        let y = top + ch * (ny - k) as f64;
        s.line(format_args!(
            r#"<text x="{}" y="{}" text-anchor="end">{}</text>"#,
            left - 6.0,
            y + 4.0,
            edge(*e)
        ));
    }
    s.line(format_args!(
        r#"<text x="20" y="{}" font-weight="bold" transform="rotate(-90 20 {})" text-anchor="middle">{}</text>"#,
        top + ch * ny as f64 / 2.0,
        top + ch * ny as f64 / 2.0,
        escape(&map.y.axis)
    ));
    // Legend.
    let lx = left + cw * nx as f64 + 20.0;
    for (k, (_, fill, text)) in BANDS.iter().enumerate() {
        let ly = top + 20.0 * k as f64;
        s.line(format_args!(
            r#"<rect x="{lx}" y="{ly}" width="14" height="14" fill="{fill}"/>"#
        ));
        s.line(format_args!(
            r#"<text x="{}" y="{}">{text}</text>"#,
            lx + 20.0,
            ly + 11.0
        ));
    }
    s.push_str("</svg>\n");
    s
}

/// For each y bin: the largest x edge below which every populated cell, from the first x bin
/// on, keeps the chosen quantile of its error under `limit` (None: not even the first). Cells without samples are
/// skipped, not assumed good; NaN/inf in a cell ends the run.
pub fn valid_up_to(
    map: &MapStats,
    limit: f64,
    quantile: fn(&crate::analyse::stats::Quantiles) -> f64,
) -> Vec<Option<f64>> {
    map.cells
        .iter()
        .map(|row| {
            let mut upto = None;
            for (kx, stats) in row.iter().enumerate() {
                match stats.rel {
                    None => continue,
                    Some(q) if quantile(&q) <= limit && stats.nan + stats.inf == 0 => upto = Some(map.x.edges[kx + 1]),
                    Some(_) => break,
                }
            }
            upto
        })
        .collect()
}
