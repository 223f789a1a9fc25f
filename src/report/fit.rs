//! `linelight fit`'s files: the table's CSV with its header, the run record beside it
//! (`<out>.run.json`: run time, threads, size, the fit errors), and the closing line that
//! names both. The table stays byte for byte the same on every run; the record varies.

use crate::analyse::fit::FitSummary;
use crate::input::ltc::{aniso, fit, sw, table};
use crate::report::format::{Csv, Json, Layout};
use std::path::Path;

/// The table `out` and its run record, as written (`io` writes each whole).
pub struct FitFiles {
    pub table: Csv,
    pub record: Json<serde_json::Value>,
}

fn files(csv: String, record: serde_json::Value) -> FitFiles {
    FitFiles {
        table: Csv::new("LTC table", csv),
        record: Json::new("run record", record, Layout::PrettyLine),
    }
}

/// The isotropic table of `size`×`size` fits, `seconds` on `threads`.
pub fn iso(out: &Path, size: usize, fits: &[fit::Fit], seconds: f64, threads: usize, s: &FitSummary) -> FitFiles {
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
    let record = serde_json::json!({
        "table": out.display().to_string(),
        "size": size,
        "threads": threads,
        "seconds": seconds,
        "objective": format!("{:?}", fit::OBJECTIVE),
        "objective_grid": fit::OBJECTIVE_GRID,
        "moment_grid": fit::MOMENT_GRID,
        "fit_l1_max": s.l1_max,
    });
    files(t.to_csv(&header), record)
}

/// The closing line of the isotropic fit.
pub fn iso_done(out: &Path, run: &Path, size: usize, seconds: f64, threads: usize, s: &FitSummary) -> String {
    format!(
        "wrote {} and {}: {} entries in {seconds:.1} s on {threads} thread(s); largest relative L1 fit error {:.3e}",
        out.display(),
        run.display(),
        size * size,
        s.l1_max
    )
}

/// The anisotropic table (or a slice), `seconds` on `threads`; `resumed`: from a checkpoint.
pub fn aniso(
    out: &Path,
    table: &aniso::AnisoTable,
    seconds: f64,
    threads: usize,
    resumed: bool,
    s: &FitSummary,
) -> FitFiles {
    use aniso::{ALPHA_MIN, RATIO_MIN, THETA_MAX};
    let (size, slice) = (table.size, table.slice);
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
    let record = serde_json::json!({
        "table": out.display().to_string(),
        "size": size,
        "fitted": aniso::fitted_count(size),
        "threads": threads,
        "seconds": seconds,
        "objective": format!("{:?}", fit::OBJECTIVE),
        "objective_grid": fit::OBJECTIVE_GRID,
        "moment_grid": fit::MOMENT_GRID,
        "fit_l1_max": s.l1_max,
        "fit_l1_median": s.l1_median,
        "flipped": s.flipped,
        "resumed": resumed,
        "slice": slice.map(|[phi, r]| serde_json::json!({"phi": phi, "ratio": r})),
    });
    files(table.to_csv(&header), record)
}

/// The closing line of the anisotropic fit.
pub fn aniso_done(out: &Path, run: &Path, size: [usize; 4], seconds: f64, threads: usize, s: &FitSummary) -> String {
    format!(
        "wrote {} and {}: {} entries ({} fitted) in {seconds:.1} s on {threads} thread(s); relative L1 fit error median {:.3e}, largest {:.3e}",
        out.display(),
        run.display(),
        s.entries,
        aniso::fitted_count(size),
        s.l1_median,
        s.l1_max
    )
}

/// The sliced-Wasserstein subset of a `size` table, fitted with `params`.
pub fn aniso_sw(
    out: &Path,
    size: [usize; 4],
    params: &sw::Params,
    entries: &[aniso::Fitted],
    seconds: f64,
    threads: usize,
    s: &FitSummary,
) -> FitFiles {
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
        "fit_l1_median": s.l1_median,
        "fit_l1_max": s.l1_max,
        "flipped": s.flipped,
    });
    files(aniso::entries_csv(size, entries, &header), record)
}

/// The closing line of the sliced-Wasserstein fit.
pub fn aniso_sw_done(out: &Path, run: &Path, seconds: f64, threads: usize, s: &FitSummary) -> String {
    format!(
        "wrote {} and {}: {} entries in {seconds:.1} s on {threads} thread(s); relative L1 lobe error median {:.3e}, largest {:.3e}",
        out.display(),
        run.display(),
        s.entries,
        s.l1_median,
        s.l1_max
    )
}
