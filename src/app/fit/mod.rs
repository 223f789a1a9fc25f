//! `linelight fit`: the LTC tables fitted (src/input/ltc holds the fits and the table formats)
//! and written with a run record beside each (`<out>.run.json`: run time, threads, size), so the
//! table itself stays byte for byte the same on every run. The outputs are checked before the
//! minutes of work. This file chains the stages: measure::fit (the fits, their progress and
//! time), analyse::fit (the fit errors), report::fit (the table, the record, the closing line).

use crate::input::ltc::{aniso, fit};
use crate::io::OutputPlan;
use crate::limits::MAX_SW_STEPS;
use crate::report::fit::FitFiles;
use std::path::Path;

mod options;
pub use options::{run, FitOptions};

/// Checks, before a fit's minutes of work, the table `out` and its run record beside it, as
/// every command's outputs are checked (`io::OutputPlan`).
fn check_outputs(out: &Path) -> anyhow::Result<()> {
    let mut plan = OutputPlan::new();
    plan.file("--out", out)
        .file("the run record", &out.with_extension("run.json"))
        .check()?;
    Ok(())
}

/// The table's CSV, then its run record, each written whole or not at all.
fn write(out: &Path, files: &FitFiles) -> anyhow::Result<std::path::PathBuf> {
    use crate::report::format::write_file;
    write_file(out, &files.table)?;
    let run = out.with_extension("run.json");
    write_file(&run, &files.record)?;
    Ok(run)
}

/// `linelight fit`: the isotropic table.
pub fn iso(out: &Path, size: usize) -> anyhow::Result<()> {
    if size < 2 {
        anyhow::bail!("--size must be at least 2, got {size}");
    }
    fit::check_table_size("--size", &[size, size])?;
    check_outputs(out)?;
    let run = crate::measure::fit::iso(size);
    let summary = crate::analyse::fit::iso(&run.value);
    let files = crate::report::fit::iso(out, size, &run.value, run.seconds, run.threads, &summary);
    let record = write(out, &files)?;
    eprintln!(
        "{}",
        crate::report::fit::iso_done(out, &record, size, run.seconds, run.threads, &summary)
    );
    Ok(())
}

/// Where `fit --aniso` keeps its checkpoint by default: beside the table.
pub fn default_checkpoint(out: &Path) -> std::path::PathBuf {
    out.with_extension("checkpoint.csv")
}

/// Reads the checkpoint at `path` if there is one (a run to resume); refuses one of another size.
fn read_checkpoint(path: &Path, size: [usize; 4], slice: aniso::Slice) -> anyhow::Result<Option<aniso::Checkpoint>> {
    if !path.exists() {
        return Ok(None);
    }
    let bytes = crate::io::read_regular(path, "the checkpoint", crate::limits::MAX_TEXT_INPUT)?;
    let text = String::from_utf8(bytes)
        .map_err(|_| crate::io::InputError(format!("{}: the checkpoint is not UTF-8", path.display())))?;
    let c = aniso::Checkpoint::parse(&text, &path.display().to_string()).map_err(crate::io::InputError)?;
    if c.size != size {
        return Err(crate::io::InputError(format!(
            "{}: a checkpoint of a {:?} table, not of the {size:?} asked for (remove it or pass that --aniso-size)",
            path.display(),
            c.size
        ))
        .into());
    }
    if c.slice != slice {
        return Err(crate::io::InputError(format!(
            "{}: a checkpoint of the slice {:?}, not of the {slice:?} asked for (remove it or pass that --aniso-slice)",
            path.display(),
            c.slice
        ))
        .into());
    }
    Ok(Some(c))
}

/// `linelight fit --aniso`: the anisotropic table (seed 004), resumable: every `every` chains
/// the finished chains go to `checkpoint` (written whole through io, so a killed run leaves
/// the last one intact), a run finding a checkpoint resumes from it, and a finished run
/// removes it. The table is the same bytes however often it was interrupted. With `slice`
/// (φ, r), a fine slice (size [nθ, 1, nα, 1]) at that view azimuth and ratio.
pub fn aniso(out: &Path, size: [usize; 4], slice: aniso::Slice, checkpoint: &Path, every: usize) -> anyhow::Result<()> {
    match slice {
        Some(s) => {
            aniso::check_slice(size, s).map_err(anyhow::Error::msg)?;
            if size[0] < 2 || size[2] < 2 {
                anyhow::bail!("--aniso-size: a slice needs at least 2 entries on θ and on α_max, got {size:?}");
            }
        }
        None if size.iter().any(|&n| n < 2) => {
            anyhow::bail!(
                "--aniso-size: every axis needs at least 2 entries, got {size:?} (one entry on φ and r is a slice: --aniso-slice φ,r)"
            );
        }
        None => {}
    }
    if every == 0 {
        anyhow::bail!("--checkpoint-every must be at least 1 chain");
    }
    fit::check_table_size("--aniso-size", &size)?;
    let mut plan = OutputPlan::new();
    plan.file("--out", out)
        .file("the run record", &out.with_extension("run.json"))
        .file("--checkpoint", checkpoint)
        .check()?;
    let resumed = read_checkpoint(checkpoint, size, slice)?;
    let (done, before) = resumed.map_or((Vec::new(), 0.0), |c| (c.entries, c.seconds));
    let resume = crate::measure::fit::Resume {
        checkpoint,
        done: &done,
        seconds: before,
    };
    // Written through io, whole: a killed run leaves the last checkpoint intact.
    let save = |c: &aniso::Checkpoint| crate::io::write_atomic(checkpoint, c.to_text().as_bytes());
    let run = crate::measure::fit::aniso(size, slice, &resume, every, &save)
        .map_err(|e| e.context(format!("writing the checkpoint {}", checkpoint.display())))?;
    let summary = crate::analyse::fit::aniso(&run.value);
    let files = crate::report::fit::aniso(out, &run.value, run.seconds, run.threads, !done.is_empty(), &summary);
    let record = write(out, &files)?;
    if checkpoint.exists() {
        crate::io::remove(checkpoint, "the finished run's checkpoint")?;
    }
    eprintln!(
        "{}",
        crate::report::fit::aniso_done(out, &record, size, run.seconds, run.threads, &summary)
    );
    Ok(())
}

/// `linelight fit --aniso --objective sw`: seed 004's own objective (sliced Wasserstein, SGD,
/// `input::ltc::sw`) on the documented subset of the table's entries (`sw::SUBSET_SLICES`),
/// each fitted cold from its own seed and post-processed as the L1 table's entries are, written
/// as the table's rows (`out`) with a run record beside it (hyperparameters, seeds, run time).
/// Minutes, not hours: no checkpoint.
pub fn aniso_sw(out: &Path, size: [usize; 4], steps: usize) -> anyhow::Result<()> {
    use crate::input::ltc::sw;
    if size.iter().any(|&n| n < 2) {
        anyhow::bail!("--aniso-size: every axis needs at least 2 entries, got {size:?}");
    }
    if !(1..=MAX_SW_STEPS).contains(&steps) {
        anyhow::bail!("--sw-steps {steps}: must be from 1 to {MAX_SW_STEPS}");
    }
    fit::check_table_size("--aniso-size", &size)?;
    check_outputs(out)?;
    let params = sw::Params { steps, ..sw::PARAMS };
    let run = crate::measure::fit::aniso_sw(size, &params);
    let summary = crate::analyse::fit::aniso_sw(&run.value);
    let files = crate::report::fit::aniso_sw(out, size, &params, &run.value, run.seconds, run.threads, &summary);
    let record = write(out, &files)?;
    eprintln!(
        "{}",
        crate::report::fit::aniso_sw_done(out, &record, run.seconds, run.threads, &summary)
    );
    Ok(())
}
