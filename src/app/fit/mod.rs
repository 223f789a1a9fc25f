//! `linelight fit`: the LTC tables fitted (src/input/ltc holds the fits and the table formats)
//! and written with a run record beside each (`<out>.run.json`: run time, threads, size), so the
//! table itself stays byte for byte the same on every run. The outputs are checked before the
//! minutes of work, progress has the plain lines off-terminal every command has, and the fit
//! error's median is the crate's one nearest-rank median.

use crate::input::ltc::{aniso, fit, table};
use crate::io::OutputPlan;
use crate::limits::MAX_SW_STEPS;
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
fn write(out: &Path, csv: String, record: serde_json::Value) -> anyhow::Result<std::path::PathBuf> {
    use crate::report::format::{write_file, Csv, Json, Layout};
    write_file(out, &Csv::new("LTC table", csv))?;
    let run = out.with_extension("run.json");
    write_file(&run, &Json::new("run record", record, Layout::PrettyLine))?;
    Ok(run)
}

/// `linelight fit`: the isotropic table.
pub fn iso(out: &Path, size: usize) -> anyhow::Result<()> {
    if size < 2 {
        anyhow::bail!("--size must be at least 2, got {size}");
    }
    fit::check_table_size("--size", &[size, size])?;
    check_outputs(out)?;
    let threads = rayon::current_num_threads();
    eprintln!("fitting a {size}×{size} isotropic GGX LTC table on {threads} thread(s)");
    let pb = crate::measure::progress::styled(
        (size * size) as u64,
        "fit",
        "{msg:>12} [{bar:40}] {pos}/{len} ({per_sec}, eta {eta})",
    );
    let start = std::time::Instant::now();
    let fits = fit::fit_table(size, &|| pb.inc(1));
    pb.finish_and_clear();
    let seconds = start.elapsed().as_secs_f64();
    let entries = fits
        .iter()
        .map(|f| table::Entry {
            minv: f.minv,
            magnitude: f.magnitude,
            fresnel: f.fresnel,
            l1: f.l1,
            l3: f.l3,
            params: f.params,
        })
        .collect();
    let t = table::Table {
        size,
        entries,
        source: out.display().to_string(),
    };
    let header = format!(
        "Isotropic GGX LTC table fitted by `linelight fit` (src/ltc/fit.rs); format: docs/ggx.md.\n\
         {size}×{size} entries (a, t): roughness a/{n}, alpha = max(roughness², {min}), cos θ = 1 − (t/{n})² (θ ≤ {max}).\n\
         M⁻¹ = [[m00,0,m02],[0,m11,0],[m20,0,1]] (row-major, ω_o = M⁻¹ω); magnitude = ∫D; fresnel = ∫D(1−v·h)⁵;\n\
         fit_l1 = ∫|mag·D_ltc − D|/∫D (the objective), fit_l3 = ∫|mag·D_ltc − D|³ (the paper's); p_* the fitted parameters.",
        n = size - 1,
        min = table::MIN_ALPHA,
        max = table::MAX_THETA
    );
    let worst = fits.iter().map(|f| f.l1).fold(0.0, f64::max);
    let record = serde_json::json!({
        "table": out.display().to_string(),
        "size": size,
        "threads": threads,
        "seconds": seconds,
        "objective": format!("{:?}", fit::OBJECTIVE),
        "objective_grid": fit::OBJECTIVE_GRID,
        "moment_grid": fit::MOMENT_GRID,
        "fit_l1_max": worst,
    });
    let run = write(out, t.to_csv(&header), record)?;
    eprintln!(
        "wrote {} and {}: {} entries in {seconds:.1} s on {threads} thread(s); largest relative L1 fit error {worst:.3e}",
        out.display(),
        run.display(),
        size * size
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
    use aniso::{ALPHA_MIN, RATIO_MIN, THETA_MAX};
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
    let threads = rayon::current_num_threads();
    let fitted = aniso::fitted_count(size);
    let (done, before) = resumed.map_or((Vec::new(), 0.0), |c| (c.entries, c.seconds));
    eprintln!(
        "fitting a {}×{}×{}×{} anisotropic GGX LTC table (θ × φ × α_max × r; {fitted} fits in {} chains, the rest by symmetry) on {threads} thread(s){}",
        size[0],
        size[1],
        size[2],
        size[3],
        aniso::chains(size).len(),
        if done.is_empty() {
            String::new()
        } else {
            format!("; resuming from {} ({} entries, {before:.0} s)", checkpoint.display(), done.len())
        }
    );
    let pb = crate::measure::progress::styled(
        fitted as u64,
        "fit",
        "{msg:>12} [{bar:40}] {pos}/{len} ({per_sec}, eta {eta})",
    );
    pb.inc(done.len() as u64);
    let start = std::time::Instant::now();
    let state = std::sync::Mutex::new((done.clone(), 0usize));
    let save = |entries: &[aniso::Fitted]| -> anyhow::Result<()> {
        let mut sorted = entries.to_vec();
        sorted.sort_by_key(|(i, _)| aniso::index(size, *i));
        let c = aniso::Checkpoint {
            size,
            slice,
            seconds: before + start.elapsed().as_secs_f64(),
            entries: sorted,
        };
        crate::io::write_atomic(checkpoint, c.to_text().as_bytes())
    };
    let failed = std::sync::Mutex::new(None::<anyhow::Error>);
    let table = aniso::fit_table_in(size, slice, &done, &|chain| {
        pb.inc(chain.len() as u64);
        let mut s = state.lock().unwrap_or_else(|e| e.into_inner());
        s.0.extend_from_slice(chain);
        s.1 += 1;
        if s.1 % every == 0 {
            if let Err(e) = save(&s.0) {
                failed.lock().unwrap_or_else(|e| e.into_inner()).get_or_insert(e);
            }
        }
    });
    pb.finish_and_clear();
    if let Some(e) = failed.into_inner().unwrap_or_else(|e| e.into_inner()) {
        return Err(e.context(format!("writing the checkpoint {}", checkpoint.display())));
    }
    let seconds = before + start.elapsed().as_secs_f64();
    let header = format!(
        "Anisotropic GGX LTC table (seed 004) fitted by `linelight fit --aniso` (src/ltc/aniso.rs); format: docs/ggx.md.\n\
         {}×{}×{}×{} entries (i_theta, i_phi, i_alpha, i_ratio), uniform: θ ∈ [0, {THETA_MAX}], φ ∈ [0, π/2] (view azimuth against the roughness axes),\n\
         alpha_max ∈ [{ALPHA_MIN}, 1] (αx = alpha_max, αy = ratio·alpha_max), ratio ∈ [{RATIO_MIN}, 1].\n\
         m* = M (row-major, roughness frame, ω = M ω_o / |M ω_o|), aligned (Eq. 12), third column of unit length; magnitude = ∫D; fresnel = ∫D(1−v·h)⁵;\n\
         fit_l1 = ∫|mag·D_ltc − D|/∫D and fit_l3 = ∫|mag·D_ltc − D|³ of the stored M; origin: fit (chains over α_max from 1 down, warm-started), theta0 (copy of φ = 0).",
        size[0], size[1], size[2], size[3]
    );
    let header = match slice {
        None => header,
        Some([phi, r]) => format!(
            "{header}\nA fine slice (the anisotropic table's resolution study): φ = {phi} and r = {r} fixed (the phi and ratio columns), θ and α_max as above."
        ),
    };
    let l1: Vec<f64> = table.entries.iter().map(|e| e.l1).collect();
    let worst = l1.iter().copied().fold(0.0, f64::max);
    let median = crate::analyse::stats::median(&l1).unwrap_or(f64::NAN);
    let record = serde_json::json!({
        "table": out.display().to_string(),
        "size": size,
        "fitted": fitted,
        "threads": threads,
        "seconds": seconds,
        "objective": format!("{:?}", fit::OBJECTIVE),
        "objective_grid": fit::OBJECTIVE_GRID,
        "moment_grid": fit::MOMENT_GRID,
        "fit_l1_max": worst,
        "fit_l1_median": median,
        "flipped": table.entries.iter().filter(|e| crate::input::geometry::det(&e.m) < 0.0).count(),
        "resumed": !done.is_empty(),
        "slice": slice.map(|[phi, r]| serde_json::json!({"phi": phi, "ratio": r})),
    });
    let run = write(out, table.to_csv(&header), record)?;
    if checkpoint.exists() {
        crate::io::remove(checkpoint, "the finished run's checkpoint")?;
    }
    eprintln!(
        "wrote {} and {}: {} entries ({fitted} fitted) in {seconds:.1} s on {threads} thread(s); relative L1 fit error median {median:.3e}, largest {worst:.3e}",
        out.display(),
        run.display(),
        table.entries.len()
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
    let subset = sw::subset(size);
    let threads = rayon::current_num_threads();
    eprintln!(
        "fitting {} entries of a {size:?} anisotropic table with the sliced-Wasserstein objective \
         ({} steps × {} directions × {} samples, learning rate {} decaying linearly) on {threads} thread(s)",
        subset.len(),
        params.steps,
        params.directions,
        params.samples,
        params.learning_rate
    );
    let pb = crate::measure::progress::styled(
        subset.len() as u64,
        "fit sw",
        "{msg:>12} [{bar:40}] {pos}/{len} ({per_sec}, eta {eta})",
    );
    let start = std::time::Instant::now();
    let entries = sw::fit_subset(size, &params, &|| pb.inc(1));
    pb.finish_and_clear();
    let seconds = start.elapsed().as_secs_f64();
    let slices: Vec<String> = sw::SUBSET_SLICES
        .iter()
        .map(|[p, r]| format!("(i_phi {p}, i_ratio {r})"))
        .collect();
    let header = format!(
        "Entries of the anisotropic GGX LTC table (seed 004) fitted with the seed's objective by `linelight fit --aniso --objective sw`\n\
         (src/input/ltc/sw.rs): sliced Wasserstein between GGX and LTC samples, SGD, {} steps × {} directions × {} samples per step,\n\
         learning rate {} decaying linearly to 0, cold start diag(αx, αy, 1), seed per entry (sw::entry_seed); then aligned and\n\
         post-processed as the L1 table (docs/ggx.md). Subset: every entry of the slices {} of a {}×{}×{}×{} table.\n\
         Columns as data/ltc_ggx_aniso.csv (fit_l1, fit_l3: the lobe errors of the stored M).",
        params.steps,
        params.directions,
        params.samples,
        params.learning_rate,
        slices.join(", "),
        size[0],
        size[1],
        size[2],
        size[3]
    );
    let l1: Vec<f64> = entries.iter().map(|(_, e)| e.l1).collect();
    let median = crate::analyse::stats::median(&l1).unwrap_or(f64::NAN);
    let worst = l1.iter().copied().fold(0.0, f64::max);
    let record = serde_json::json!({
        "table": out.display().to_string(),
        "size": size,
        "entries": entries.len(),
        "subset_slices_phi_ratio": sw::SUBSET_SLICES,
        "objective": "sliced_wasserstein",
        "optimizer": "sgd",
        "steps": params.steps,
        "directions": params.directions,
        "samples_per_step": params.samples,
        "learning_rate": params.learning_rate,
        "learning_rate_schedule": "linear to 0",
        "start": "cold: diag(alpha_x, alpha_y, 1)",
        "seeds": "sw::entry_seed(index)",
        "threads": threads,
        "seconds": seconds,
        "fit_l1_median": median,
        "fit_l1_max": worst,
        "flipped": entries.iter().filter(|(_, e)| crate::input::geometry::det(&e.m) < 0.0).count(),
    });
    let run = write(out, aniso::entries_csv(size, &entries, &header), record)?;
    eprintln!(
        "wrote {} and {}: {} entries in {seconds:.1} s on {threads} thread(s); relative L1 lobe error median {median:.3e}, largest {worst:.3e}",
        out.display(),
        run.display(),
        entries.len()
    );
    Ok(())
}
