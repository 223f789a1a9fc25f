//! CSV tables: one row per method × material × bin (the whole sample is bin `all`). `rel_*` is
//! the relative error with no floor over non-zero references; `floored_*` the labelled variant;
//! `zero_reference`/`false_*` the configurations whose reference is 0 (false light).
//! Written by the `csv` crate, so a name with a comma or a quote stays one field.

use crate::analyse::analysis::{Analysis, PairStats};
use crate::analyse::stats::{BinStats, Quantiles};

/// Rows of fields → CSV text (RFC 4180 quoting where a field needs it).
fn table(header: &str, rows: Vec<Vec<String>>) -> String {
    let mut w = csv::Writer::from_writer(Vec::new());
    let header: Vec<&str> = header.split(',').collect();
    let written = std::iter::once(w.write_record(&header))
        .chain(rows.iter().map(|r| w.write_record(r)))
        .collect::<Result<(), _>>();
    written.expect("writing CSV to memory cannot fail");
    String::from_utf8(w.into_inner().expect("in-memory CSV flushes")).expect("CSV of UTF-8 fields is UTF-8")
}

fn q(x: Option<Quantiles>) -> [String; 4] {
    match x {
        Some(q) => [q.median, q.p90, q.p99, q.max].map(|v| format!("{v:e}")),
        None => std::array::from_fn(|_| String::new()),
    }
}

fn stats_row(s: &BinStats) -> Vec<String> {
    let mut cols = vec![s.count.to_string(), s.nan.to_string(), s.inf.to_string()];
    cols.extend(q(s.rel));
    cols.extend(q(s.abs));
    cols.extend(q(s.rel_cpu_f32));
    cols.extend(q(s.rel_f64));
    cols.push(s.nan_f64.to_string());
    cols.extend(q(s.bits));
    cols.extend(s.within.map(|w| format!("{w}")));
    cols.extend(q(s.reference_rel).into_iter().skip(3)); // the worst reference error
    cols.push(s.reference_flag.to_string());
    cols.extend(q(s.rel_floored));
    cols.push(s.below_floor.to_string());
    let f = &s.false_light;
    cols.extend([f.configurations, f.lit, f.nonfinite, f.lit_f64].map(|n| n.to_string()));
    cols.push(f.value.map_or(String::new(), |q| format!("{:e}", q.max)));
    // Which kind the relative-error quantiles of the row are (exact nearest-rank or sketch).
    cols.push(s.rel.map_or(String::new(), |q| q.kind.name().to_string()));
    cols.extend([s.dark, s.dark_f64].map(|n| n.to_string()));
    cols
}

pub fn stats(analysis: &Analysis) -> String {
    let header = "method,target,material,supported,axis,bin_lo,bin_hi,count,nan,inf,\
         rel_median,rel_p90,rel_p99,rel_max,abs_median,abs_p90,abs_p99,abs_max,\
         cpu_f32_rel_median,cpu_f32_rel_p90,cpu_f32_rel_p99,cpu_f32_rel_max,f64_rel_median,f64_rel_p90,f64_rel_p99,f64_rel_max,f64_nan,\
         bits_median,bits_p90,bits_p99,bits_max,within_1e-3,within_1e-2,within_1e-1,reference_rel_max,reference_flag,\
         floored_rel_median,floored_rel_p90,floored_rel_p99,floored_rel_max,below_floor,\
         zero_reference,false_lit,false_nonfinite,false_lit_f64,false_value_max,quantiles,dark,dark_f64";
    let mut rows = Vec::new();
    for m in &analysis.methods {
        for mat in &m.materials {
            let head = [
                m.label.clone(),
                m.target.to_string(),
                mat.material.clone(),
                mat.supported.to_string(),
            ];
            let row = |bin: [String; 3], stats: Vec<String>| head.iter().cloned().chain(bin).chain(stats).collect();
            rows.push(row(["all".into(), String::new(), String::new()], stats_row(&mat.all)));
            for axis in &mat.axes {
                for b in &axis.bins {
                    rows.push(row(
                        [axis.axis.clone(), b.lo.to_string(), b.hi.to_string()],
                        stats_row(&b.stats),
                    ));
                }
            }
        }
    }
    table(header, rows)
}

fn pair_row(s: &PairStats) -> Vec<String> {
    let mut cols = vec![s.count.to_string()];
    cols.extend(q(s.diff_f32));
    cols.extend(q(s.diff_f64));
    cols
}

pub fn comparisons(analysis: &Analysis) -> String {
    let header = "a,b,material,axis,bin_lo,bin_hi,count,f32_diff_median,f32_diff_p90,f32_diff_p99,f32_diff_max,\
         f64_diff_median,f64_diff_p90,f64_diff_p99,f64_diff_max";
    let mut rows = Vec::new();
    for c in &analysis.comparisons {
        for mat in &c.materials {
            let head = [c.a.clone(), c.b.clone(), mat.material.clone()];
            let row = |bin: [String; 3], stats: Vec<String>| head.iter().cloned().chain(bin).chain(stats).collect();
            rows.push(row(["all".into(), String::new(), String::new()], pair_row(&mat.all)));
            for axis in &mat.axes {
                for b in &axis.bins {
                    rows.push(row(
                        [axis.axis.clone(), b.lo.to_string(), b.hi.to_string()],
                        pair_row(&b.stats),
                    ));
                }
            }
        }
    }
    table(header, rows)
}
