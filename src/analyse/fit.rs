//! `linelight fit`'s summary of a fitted table: its entries' relative L1 lobe errors (the
//! largest, and the crate's one nearest-rank median) and how many stored matrices are flipped
//! (negative determinant).

use crate::input::ltc::{aniso, fit};

/// The typed summary `report::fit` writes into the run record and the closing line.
#[derive(Clone, Copy, Debug)]
pub struct FitSummary {
    pub entries: usize,
    /// The largest relative L1 error (0 for no entries).
    pub l1_max: f64,
    /// The median relative L1 error (NaN for no entries).
    pub l1_median: f64,
    /// Entries whose stored M has a negative determinant (None: the isotropic table, which
    /// stores M⁻¹).
    pub flipped: Option<usize>,
}

fn summary(l1: &[f64], flipped: Option<usize>) -> FitSummary {
    FitSummary {
        entries: l1.len(),
        l1_max: l1.iter().copied().fold(0.0, f64::max),
        l1_median: super::stats::median(l1).unwrap_or(f64::NAN),
        flipped,
    }
}

fn flipped<'a>(entries: impl Iterator<Item = &'a aniso::Entry>) -> usize {
    entries.filter(|e| crate::input::geometry::det(&e.m) < 0.0).count()
}

/// The isotropic table's fits.
pub fn iso(fits: &[fit::Fit]) -> FitSummary {
    let l1: Vec<f64> = fits.iter().map(|f| f.l1).collect();
    summary(&l1, None)
}

/// The anisotropic table (or a slice).
pub fn aniso(table: &aniso::AnisoTable) -> FitSummary {
    let l1: Vec<f64> = table.entries.iter().map(|e| e.l1).collect();
    summary(&l1, Some(flipped(table.entries.iter())))
}

/// The sliced-Wasserstein subset's entries.
pub fn aniso_sw(entries: &[aniso::Fitted]) -> FitSummary {
    let l1: Vec<f64> = entries.iter().map(|(_, e)| e.l1).collect();
    summary(&l1, Some(flipped(entries.iter().map(|(_, e)| e))))
}
