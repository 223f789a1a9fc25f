//! `linelight fit`: the LTC tables fitted (src/input/ltc holds the fits and the table formats)
//! and written with a run record beside each (`<out>.run.json`: run time, threads, size), so the
//! table itself stays byte for byte the same on every run. The outputs are checked before the
//! minutes of work, progress has the plain lines off-terminal every command has, and the fit
//! error's median is the crate's one nearest-rank median.

use crate::input::ltc::{aniso, fit, table};
use crate::io::OutputPlan;
use std::path::Path;

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

/// `linelight fit --aniso`: the anisotropic table (seed 004).
pub fn aniso(out: &Path, size: [usize; 4]) -> anyhow::Result<()> {
    use aniso::{ALPHA_MIN, RATIO_MIN, THETA_MAX};
    if size.iter().any(|&n| n < 2) {
        anyhow::bail!("--aniso-size: every axis needs at least 2 entries, got {size:?}");
    }
    fit::check_table_size("--aniso-size", &size)?;
    check_outputs(out)?;
    let threads = rayon::current_num_threads();
    let fitted = aniso::fitted_count(size);
    eprintln!(
        "fitting a {}×{}×{}×{} anisotropic GGX LTC table (θ × φ × α_max × r; {fitted} fits, the rest by symmetry) on {threads} thread(s)",
        size[0], size[1], size[2], size[3]
    );
    let pb = crate::measure::progress::styled(
        fitted as u64,
        "fit",
        "{msg:>12} [{bar:40}] {pos}/{len} ({per_sec}, eta {eta})",
    );
    let start = std::time::Instant::now();
    let table = aniso::fit_table(size, &|| pb.inc(1));
    pb.finish_and_clear();
    let seconds = start.elapsed().as_secs_f64();
    let header = format!(
        "Anisotropic GGX LTC table (seed 004) fitted by `linelight fit --aniso` (src/ltc/aniso.rs); format: docs/ggx.md.\n\
         {}×{}×{}×{} entries (i_theta, i_phi, i_alpha, i_ratio), uniform: θ ∈ [0, {THETA_MAX}], φ ∈ [0, π/2] (view azimuth against the roughness axes),\n\
         alpha_max ∈ [{ALPHA_MIN}, 1] (αx = alpha_max, αy = ratio·alpha_max), ratio ∈ [{RATIO_MIN}, 1].\n\
         m* = M (row-major, roughness frame, ω = M ω_o / |M ω_o|), aligned (Eq. 12), third column of unit length; magnitude = ∫D; fresnel = ∫D(1−v·h)⁵;\n\
         fit_l1 = ∫|mag·D_ltc − D|/∫D and fit_l3 = ∫|mag·D_ltc − D|³ of the stored M; origin: fit, theta0 (copy of φ = 0), iso_rotation (φ = 0 turned by φ).",
        size[0], size[1], size[2], size[3]
    );
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
    });
    let run = write(out, table.to_csv(&header), record)?;
    eprintln!(
        "wrote {} and {}: {} entries ({fitted} fitted) in {seconds:.1} s on {threads} thread(s); relative L1 fit error median {median:.3e}, largest {worst:.3e}",
        out.display(),
        run.display(),
        table.entries.len()
    );
    Ok(())
}
