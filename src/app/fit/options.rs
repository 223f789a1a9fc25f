//! The options of `linelight fit` and their checks: which table is fitted (isotropic,
//! anisotropic by L1, or the sliced-Wasserstein subset), with what sizes, before any work.

use std::path::PathBuf;

/// Options of `linelight fit`.
#[derive(clap::Args)]
pub struct FitOptions {
    /// Table file (CSV, docs/ggx.md; default data/ltc_ggx_iso.csv, with --aniso
    /// data/ltc_ggx_aniso.csv); a run record goes beside it (`.run.json`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Entries per axis of the isotropic table (roughness × view angle).
    #[arg(long, default_value_t = 64)]
    pub size: usize,
    /// Fit the anisotropic 4D table instead (θ × φ × α_max × ratio).
    #[arg(long)]
    pub aniso: bool,
    /// Entries per axis of the anisotropic table: θ,φ,α_max,ratio.
    #[arg(long, value_delimiter = ',', default_values_t = crate::input::ltc::aniso::SIZE)]
    pub aniso_size: Vec<usize>,
    /// With --aniso: fit a fine slice instead, one view azimuth φ (radians, in [0, π/2])
    /// and one ratio r (in [0.25, 1]), with --aniso-size Nθ,1,Nα,1 (docs/ggx.md).
    #[arg(long, value_delimiter = ',', value_name = "PHI,R")]
    pub aniso_slice: Option<Vec<f64>>,
    /// With --aniso: the checkpoint file (default: the table's path with
    /// `.checkpoint.csv`); a run finding one resumes from it, a finished run removes it.
    #[arg(long)]
    pub checkpoint: Option<PathBuf>,
    /// With --aniso: write the checkpoint every this many finished chains (one chain: the
    /// α_max axis at one θ, φ, r).
    #[arg(long, default_value_t = 4)]
    pub checkpoint_every: usize,
    /// With --aniso: the objective, `l1` (the table, by Nelder–Mead) or `sw` (seed 004's
    /// sliced Wasserstein by SGD, on a documented subset of entries; default out
    /// data/ltc_ggx_aniso_sw_subset.csv).
    #[arg(long, default_value = "l1", value_parser = ["l1", "sw"])]
    pub objective: String,
    /// With --objective sw: SGD steps per entry.
    #[arg(long, default_value_t = crate::input::ltc::sw::PARAMS.steps)]
    pub sw_steps: usize,
}

/// The fit asked for, its options checked.
enum Fit {
    Iso {
        out: PathBuf,
        size: usize,
    },
    Aniso {
        out: PathBuf,
        size: [usize; 4],
        slice: Option<[f64; 2]>,
        checkpoint: PathBuf,
        every: usize,
    },
    AnisoSw {
        out: PathBuf,
        size: [usize; 4],
        steps: usize,
    },
}

/// `--aniso-size` as the four axes.
fn aniso_size(v: Vec<usize>) -> anyhow::Result<[usize; 4]> {
    v.try_into()
        .map_err(|v: Vec<usize>| anyhow::anyhow!("--aniso-size takes 4 numbers, got {}", v.len()))
}

impl FitOptions {
    /// Which fit, refusing options that belong to another one.
    fn fit(self) -> anyhow::Result<Fit> {
        let FitOptions {
            out,
            size,
            aniso,
            aniso_size: sizes,
            aniso_slice,
            checkpoint,
            checkpoint_every,
            objective,
            sw_steps,
        } = self;
        if !aniso && aniso_slice.is_some() {
            anyhow::bail!("--aniso-slice is for --aniso fits");
        }
        if !aniso && checkpoint.is_some() {
            anyhow::bail!("--checkpoint is for --aniso fits (the isotropic table takes minutes, not hours)");
        }
        if objective == "sw" {
            if !aniso {
                anyhow::bail!("--objective sw is for --aniso fits (seed 004's objective)");
            }
            if checkpoint.is_some() {
                anyhow::bail!("--checkpoint is for the L1 table's fit (--objective sw fits a subset in minutes)");
            }
            let size = aniso_size(sizes)?;
            let out = out.unwrap_or_else(|| PathBuf::from("data/ltc_ggx_aniso_sw_subset.csv"));
            Ok(Fit::AnisoSw {
                out,
                size,
                steps: sw_steps,
            })
        } else if aniso {
            let size = aniso_size(sizes)?;
            let out = out.unwrap_or_else(|| PathBuf::from("data/ltc_ggx_aniso.csv"));
            let checkpoint = checkpoint.unwrap_or_else(|| super::default_checkpoint(&out));
            let slice = aniso_slice
                .map(|v| {
                    <[f64; 2]>::try_from(v)
                        .map_err(|v| anyhow::anyhow!("--aniso-slice takes 2 numbers (φ,r), got {}", v.len()))
                })
                .transpose()?;
            Ok(Fit::Aniso {
                out,
                size,
                slice,
                checkpoint,
                every: checkpoint_every,
            })
        } else {
            let out = out.unwrap_or_else(|| PathBuf::from("data/ltc_ggx_iso.csv"));
            Ok(Fit::Iso { out, size })
        }
    }
}

/// `linelight fit`: the options checked, then the table fitted and written.
pub fn run(options: FitOptions) -> anyhow::Result<crate::app::Status> {
    match options.fit()? {
        Fit::AnisoSw { out, size, steps } => super::aniso_sw(&out, size, steps)?,
        Fit::Aniso {
            out,
            size,
            slice,
            checkpoint,
            every,
        } => super::aniso(&out, size, slice, &checkpoint, every)?,
        Fit::Iso { out, size } => super::iso(&out, size)?,
    }
    Ok(crate::app::Status::Ok)
}
