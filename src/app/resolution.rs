//! `linelight resolution`: the anisotropic table's resolution study (in the manner
//! of seed 004's Fig. 12), cases/ggx_resolution.toml → reports/ggx-resolution/resolution.md,
//! resolution.csv, resolution.json.
//!
//! The tables are read from files (`--table`, each checked as an input by
//! `AnisoTable::load`): by default the 4⁴ table (`data/ltc_ggx_aniso_4.csv`), the committed
//! 8⁴ (`data/ltc_ggx_aniso.csv`) and the fine slice (`data/ltc_ggx_aniso_slice.csv`, 32 × 32
//! over θ and α_max at one φ and one r). Each is fed to the case's configurations as
//! `ltc = "aniso"` feeds ours, and its LTC integrated exactly, beside the exact fit of each
//! configuration's own lobe and the GGX truth (measure::resolution measures,
//! analyse::resolution analyses, report::resolution writes, this file chains them). A slice
//! is fed only to the configurations at its (φ, r) (the case's `slice` family).

use crate::input::case::Case;
use crate::input::ltc::aniso::AnisoTable;
use crate::limits::MAX_TABLES;
use crate::measure::resolution::StudyTable;
use std::path::{Path, PathBuf};

/// The default tables, coarsest first.
pub const DEFAULT_TABLES: [&str; 3] = [
    "data/ltc_ggx_aniso_4.csv",
    "data/ltc_ggx_aniso.csv",
    "data/ltc_ggx_aniso_slice.csv",
];

fn label(t: &AnisoTable) -> String {
    let [a, b, c, d] = t.size;
    match t.slice {
        Some([phi, r]) => format!("slice {a}×{c} (φ = {:.2}°, r = {r:.4})", phi.to_degrees()),
        None if a == b && b == c && c == d => format!("{a}⁴"),
        None => format!("{a}×{b}×{c}×{d}"),
    }
}

/// A sentence on a table: its file, size and what its run record says.
fn describe(path: &Path, t: &AnisoTable) -> String {
    let mut s = format!("{}: `{}`, {} entries", label(t), path.display(), t.entries.len());
    let record = crate::io::read_record(&path.with_extension("run.json"), crate::limits::MAX_RECORD_BYTES);
    if let Some(r) = record {
        if let (Some(fitted), Some(seconds), Some(threads)) =
            (r["fitted"].as_u64(), r["seconds"].as_f64(), r["threads"].as_u64())
        {
            let _ = std::fmt::Write::write_fmt(
                &mut s,
                format_args!(", {fitted} fitted in {seconds:.0} s on {threads} thread(s) (its run record)"),
            );
        }
    }
    s
}

/// Options of `linelight resolution`.
#[derive(clap::Args)]
pub struct ResolutionOptions {
    /// Case file with anisotropic ggx families (a `slice` family for a slice table).
    #[arg(default_value = "cases/ggx_resolution.toml")]
    pub case: PathBuf,
    /// An anisotropic table file (repeatable, coarsest first; default: the 4⁴ table, the
    /// committed 8⁴ and the fine slice in data/).
    #[arg(long = "table")]
    pub tables: Vec<PathBuf>,
    /// Output folder (default: reports/<case name with - for _>).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// `linelight resolution [CASE] [--table FILE]… [--out DIR]`.
pub fn run(case_path: &Path, tables: Vec<PathBuf>, out: Option<PathBuf>) -> anyhow::Result<super::Status> {
    let case = Case::load(case_path)?;
    let tables: Vec<PathBuf> = if tables.is_empty() {
        DEFAULT_TABLES.iter().map(PathBuf::from).collect()
    } else {
        tables
    };
    if tables.len() > MAX_TABLES {
        return Err(crate::io::InputError(format!(
            "--table: {} tables, more than the {MAX_TABLES} a study takes",
            tables.len()
        ))
        .into());
    }
    let dir = out.unwrap_or_else(|| Path::new("reports").join(case.name.replace('_', "-")));
    let mut plan = crate::io::OutputPlan::new();
    plan.input("the case file", case_path);
    for t in &tables {
        plan.input("--table", t);
    }
    plan.set("--out", &dir, crate::io::SetKind::Chain).check()?;
    let loaded: Vec<(PathBuf, AnisoTable)> = tables
        .into_iter()
        .map(|p| AnisoTable::load(&p, "--table").map(|t| (p, t)))
        .collect::<anyhow::Result<_>>()?;
    let descriptions: Vec<String> = loaded.iter().map(|(p, t)| describe(p, t)).collect();
    let study: Vec<StudyTable> = loaded
        .into_iter()
        .map(|(_, t)| StudyTable {
            label: label(&t),
            table: t,
        })
        .collect();
    let run = crate::measure::resolution::measure(&case, &study)?;
    let analysed = crate::analyse::resolution::analyse(&case, &run);
    let command = format!("linelight resolution {}", case_path.display());
    let points = serde_json::to_value(&run.points)?;
    let outputs = crate::report::resolution::outputs(&command, &case.title, &analysed, &descriptions, points);
    for path in crate::report::format::write_set(&dir, crate::io::SetKind::Chain, &outputs)? {
        eprintln!("wrote {}", path.display());
    }
    Ok(super::Status::Ok)
}
