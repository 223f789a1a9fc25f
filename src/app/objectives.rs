//! `linelight objectives`: the comparison of seed 004's fitting objective (sliced
//! Wasserstein, SGD) with ours (L1, Nelder–Mead) by what users see (reports/ggx-objectives/).
//! The fits are committed data (`data/ltc_ggx_aniso_sw_subset.csv` from `linelight fit --aniso
//! --objective sw`, and the L1 table compiled in), so this command only evaluates: lines drawn
//! per entry (measure::objectives), statistics and findings (analyse::objectives), the files
//! (report::objectives), written as one set through io.

use crate::input::ltc::aniso;
use crate::limits::MAX_LINES;
use std::path::Path;

/// Options of `linelight objectives`.
#[derive(clap::Args)]
pub struct ObjectivesOptions {
    /// The SW-fitted entries (`linelight fit --aniso --objective sw`).
    #[arg(long, default_value = "data/ltc_ggx_aniso_sw_subset.csv")]
    pub subset: std::path::PathBuf,
    /// Output folder, a report folder of its own.
    #[arg(long, default_value = "reports/ggx-objectives")]
    pub out: std::path::PathBuf,
    /// Lines per region (near the highlight, natural) and entry.
    #[arg(long, default_value_t = 8)]
    pub lines: usize,
}

/// Runs the comparison: the SW subset read from `subset`, the L1 table's same entries, `lines`
/// lines per region and entry, the report set written to `out`.
pub fn run(subset: &Path, out: &Path, lines: usize) -> anyhow::Result<super::Status> {
    if !(1..=MAX_LINES).contains(&lines) {
        anyhow::bail!("--lines {lines}: must be from 1 to {MAX_LINES}");
    }
    let mut plan = crate::io::OutputPlan::new();
    plan.input("--subset", subset);
    plan.set("--out", out, crate::io::SetKind::Objectives).check()?;
    let bytes = crate::io::read_regular(subset, "the SW subset", crate::limits::MAX_TEXT_INPUT)?;
    let text =
        String::from_utf8(bytes).map_err(|_| crate::io::InputError(format!("{}: not UTF-8", subset.display())))?;
    let entries = aniso::parse_entries(&text, &subset.display().to_string()).map_err(crate::io::InputError)?;
    if entries.is_empty() {
        return Err(crate::io::InputError(format!("{}: no entries", subset.display())).into());
    }
    let table = aniso::ours();
    for (i, _) in &entries {
        if (0..4).any(|k| i[k] >= table.size[k]) {
            return Err(crate::io::InputError(format!(
                "{}: entry {i:?} is outside the committed {:?} table",
                subset.display(),
                table.size
            ))
            .into());
        }
    }
    eprintln!(
        "comparing {} SW-fitted entries with the L1 table's, {lines} lines per region and entry",
        entries.len()
    );
    let pb = crate::measure::progress::bar(entries.len() as u64, "objectives");
    let run = crate::measure::objectives::measure(table, &entries, lines, &|| pb.inc(1))?;
    pb.finish_and_clear();
    let analysis = crate::analyse::objectives::analyse(&run);
    let record = |p: &Path| crate::io::read_record(p, crate::limits::MAX_RECORD_BYTES);
    let inputs = crate::report::objectives::Inputs {
        command: format!("linelight objectives --subset {} --lines {lines}", subset.display()),
        sw_record: record(&subset.with_extension("run.json")),
        subset: subset.display().to_string(),
        sw_record_path: subset.with_extension("run.json").display().to_string(),
        l1_record: record(&Path::new(env!("CARGO_MANIFEST_DIR")).join("data/ltc_ggx_aniso.run.json")),
    };
    let outputs = crate::report::objectives::outputs(&analysis, &inputs);
    for path in crate::report::format::write_set(out, crate::io::SetKind::Objectives, &outputs)? {
        eprintln!("wrote {}", path.display());
    }
    Ok(super::Status::Ok)
}
