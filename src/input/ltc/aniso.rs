//! The anisotropic GGX LTC table of seed 004 (Kt, Heitz, Dupuy, Narayanan, "Bringing
//! Linearly Transformed Cosines to Anisotropic GGX"), written here from its description, at a
//! resolution this shared 2-core machine can fit: `data/ltc_ggx_aniso.csv`, written by
//! `linelight fit --aniso`, format in docs/ggx.md.
//!
//! What follows the seed:
//! - the 4D parameterisation (Sec. 6.1): view angle θ, view azimuth φ against the roughness
//!   axes reduced to [0, π/2] by the GGX lobe's axial symmetries (Eq. 13), the largest
//!   roughness α_max and the ratio r = α_min/α_max (Eq. 15, the roughness symmetry of Eq. 14),
//!   each on a uniform grid;
//! - the full matrix M (not M⁻¹) stored, divided by the length of its third column, and
//!   interpolated (Sec. 7), then inverted as a shader would (f32);
//! - alignment against the non-uniqueness of LTCs (Sec. 5.2, Eq. 12): M·R_z(γ) or M·F·R_z(γ)
//!   (F the x-flip; with R_z(π) these are the seed's four flipping cases) with the γ and case
//!   that minimise the mean squared distance between cosine samples and their transforms, by a
//!   linear search refined by golden section. A flip gives det M < 0, the same distribution
//!   (the density uses |det|), and it is stored as found; the run record counts them;
//! - the post-processing of Sec. 6.2 (Eq. 16): entries that the lobe's symmetries make zero
//!   are set to zero at φ = 0, φ = π/2 and θ = 0, and at θ = 0 every φ holds the same entry;
//! - the fitting order of Sec. 4.1: along α_max from rough to smooth, each entry started from
//!   the one before (plus one cold start, which the seed's robustness argument asks for);
//! - the resolution 8⁴ (Sec. 8), every r including r = 1 fitted;
//! - the magnitude and the Schlick term as two extra channels (Sec. 9, "Fresnel").
//!
//! What does not: the seed fits each entry with a sliced-Wasserstein loss, 10 000 SGD steps in
//! PyTorch (two hours on a GPU). Here each entry is the fit of `fit::fit_general_from` (our L1
//! objective, Nelder–Mead with restarts), so a table node holds a fit of its own lobe, before
//! alignment. The table is fitted chain by chain ([`chains`]) with checkpoints
//! (`linelight fit --aniso`), so a run of hours survives being killed.

use super::fit::{self, Ltc, M3};
use super::ggx::Ggx;
use super::table::Storage;
use crate::input::geometry::{self, transpose};
use std::f64::consts::FRAC_PI_2;

/// The table's axes: θ ∈ [0, THETA_MAX], φ ∈ [0, π/2], α_max ∈ [ALPHA_MIN, 1], r ∈ [RATIO_MIN, 1].
pub const THETA_MAX: f64 = 1.57;
pub const ALPHA_MIN: f64 = 0.02;
pub const RATIO_MIN: f64 = 0.25;
/// The committed resolution (θ, φ, α_max, r).
pub const SIZE: [usize; 4] = [8, 8, 8, 8];

/// Cosine samples per axis of the alignment's objective (Eq. 12).
const ALIGN_GRID: usize = 16;

/// Where an entry came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Origin {
    /// Fitted (fit::fit_general), aligned, post-processed.
    Fit,
    /// θ = 0: the entry of φ = 0 (the lobe does not depend on φ there).
    Theta0,
    /// Read only, from tables fitted before the r = 1 slice was fitted (8×5×5×4): the entry
    /// of φ = 0 turned about z by φ. `fit_table` never makes one.
    IsoRotation,
}

impl Origin {
    fn name(self) -> &'static str {
        match self {
            Origin::Fit => "fit",
            Origin::Theta0 => "theta0",
            Origin::IsoRotation => "iso_rotation",
        }
    }
    fn parse(s: &str) -> Option<Origin> {
        [Origin::Fit, Origin::Theta0, Origin::IsoRotation]
            .into_iter()
            .find(|o| o.name() == s)
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Entry {
    /// M in the roughness frame (row-major), aligned, third column of unit length.
    pub m: M3,
    pub magnitude: f64,
    pub fresnel: f64,
    /// Relative L1 lobe error of the stored M (after alignment and post-processing) and its L3.
    pub l1: f64,
    pub l3: f64,
    pub origin: Origin,
}

/// A fitted entry with its index (iθ, iφ, iα, ir): what chains and checkpoints hold.
pub type Fitted = ([usize; 4], Entry);

#[derive(Clone, Debug)]
pub struct AnisoTable {
    pub size: [usize; 4],
    /// Entry (iθ, iφ, iα, ir) at `index`.
    pub entries: Vec<Entry>,
    /// A fine slice's fixed (φ, r) (size [nθ, 1, nα, 1]), None for a full table.
    pub slice: Slice,
}

/// A fine slice (the resolution study's): one view azimuth φ and one ratio r, fixed, with
/// the θ and α_max axes as in a full table; its size is [nθ, 1, nα, 1]. None: a full table.
pub type Slice = Option<[f64; 2]>;

/// Checks a slice request against its size: (φ, r) finite and inside the table's domain,
/// φ ∈ [0, π/2] and r ∈ [RATIO_MIN, 1], and the size one entry on φ and on r.
pub fn check_slice(size: [usize; 4], slice: [f64; 2]) -> Result<(), String> {
    let [phi, r] = slice;
    if !phi.is_finite() || !(0.0..=FRAC_PI_2).contains(&phi) {
        return Err(format!("--aniso-slice: φ = {phi} is not in [0, π/2] (radians)"));
    }
    if !r.is_finite() || !(RATIO_MIN..=1.0).contains(&r) {
        return Err(format!("--aniso-slice: r = {r} is not in [{RATIO_MIN}, 1]"));
    }
    if size[1] != 1 || size[3] != 1 {
        return Err(format!(
            "--aniso-slice needs one entry on φ and on r (--aniso-size Nθ,1,Nα,1), got {size:?}"
        ));
    }
    Ok(())
}

fn axis_value(i: usize, n: usize, lo: f64, hi: f64) -> f64 {
    if n == 1 {
        return hi;
    }
    lo + (hi - lo) * i as f64 / (n - 1) as f64
}

/// (θ, φ, α_max, r) of entry (iθ, iφ, iα, ir).
pub fn entry_point(size: [usize; 4], i: [usize; 4]) -> [f64; 4] {
    entry_point_in(size, None, i)
}

/// (θ, φ, α_max, r) of entry (iθ, iφ, iα, ir) of a full table or a slice (its fixed φ and r).
pub fn entry_point_in(size: [usize; 4], slice: Slice, i: [usize; 4]) -> [f64; 4] {
    let mut p = [
        axis_value(i[0], size[0], 0.0, THETA_MAX),
        axis_value(i[1], size[1], 0.0, FRAC_PI_2),
        axis_value(i[2], size[2], ALPHA_MIN, 1.0),
        axis_value(i[3], size[3], RATIO_MIN, 1.0),
    ];
    if let Some([phi, r]) = slice {
        (p[1], p[3]) = (phi, r);
    }
    p
}

pub fn index(size: [usize; 4], i: [usize; 4]) -> usize {
    ((i[0] * size[1] + i[1]) * size[2] + i[2]) * size[3] + i[3]
}

/// The GGX lobe of a table point: αx = α_max, αy = r·α_max, view at (θ, φ).
pub fn lobe(p: [f64; 4]) -> Ggx {
    let [theta, phi, a, r] = p;
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    Ggx {
        ax: a,
        ay: a * r,
        view: [st * cp, st * sp, ct],
    }
}

fn rot_z(g: f64) -> M3 {
    let (s, c) = g.sin_cos();
    [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
}

/// Eq. 12: the mean squared distance between cosine samples ω_o and normalize(M ω_o).
fn alignment_cost(m: &M3) -> f64 {
    let n = ALIGN_GRID;
    let mut sum = 0.0;
    for i in 0..n {
        for j in 0..n {
            let (u1, u2) = ((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
            let r = u1.sqrt();
            let (s, c) = (std::f64::consts::TAU * u2).sin_cos();
            let wo = [r * c, r * s, (1.0 - u1).sqrt()];
            let w = geometry::mat_vec(m, wo);
            let l = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
            sum += (0..3).map(|k| (wo[k] - w[k] / l).powi(2)).sum::<f64>();
        }
    }
    sum / (n * n) as f64
}

/// The reflection x → −x (one of the seed's "flipping cases"; y → −y is this one turned by π,
/// and flipping both is the rotation by π, so rotations and this one cover all four).
const FLIP_X: M3 = [[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// M·R_z(γ) for the γ that minimises Eq. 12, by a linear search over 720 angles refined by
/// golden section, among the rotations and the flipped rotations M·F·R_z(γ) (the seed's "four
/// flipping cases"). A flip keeps the distribution (|det| is what the density uses) but makes
/// det M < 0; the shading integrators orient by M⁻¹'s sign (a reversed winding), so a flip is
/// taken only where it is strictly nearer the cosine samples, and `fit_entry` records it.
pub fn align(m: &M3) -> M3 {
    let rotated = align_from(m);
    let flipped = align_from(&geometry::mat_mul(m, &FLIP_X));
    if alignment_cost(&flipped) < alignment_cost(&rotated) {
        flipped
    } else {
        rotated
    }
}

fn align_from(m: &M3) -> M3 {
    let cost = |g: f64| alignment_cost(&geometry::mat_mul(m, &rot_z(g)));
    let steps = 720;
    let h = std::f64::consts::TAU / steps as f64;
    let best = (0..steps)
        .map(|k| k as f64 * h)
        .min_by(|a, b| cost(*a).total_cmp(&cost(*b)))
        .unwrap_or(0.0);
    let (mut lo, mut hi) = (best - h, best + h);
    for _ in 0..50 {
        let (a, b) = (lo + (hi - lo) * 0.381_966, lo + (hi - lo) * 0.618_034);
        if cost(a) < cost(b) {
            hi = b;
        } else {
            lo = a;
        }
    }
    let g = 0.5 * (lo + hi);
    let g = if cost(g) <= cost(best) { g } else { best };
    geometry::mat_mul(m, &rot_z(g))
}

/// Sec. 7: M divided by the length of its third column.
fn unit_third_column(m: &M3) -> M3 {
    let l = (m[0][2].powi(2) + m[1][2].powi(2) + m[2][2].powi(2)).sqrt();
    m.map(|r| r.map(|x| x / l))
}

/// Eq. 16: the entries the lobe's symmetries make zero. φ = 0 (view in the xz-plane): the
/// lobe is symmetric under y → −y; φ = π/2: under x → −x; θ = 0: under both. A slice's φ is
/// its fixed value, so these hold there only when it is 0 or π/2.
fn symmetrize(m: &mut M3, i: [usize; 4], size: [usize; 4], slice: Slice) {
    let (phi0, phi1) = match slice {
        None => (i[1] == 0, i[1] == size[1] - 1),
        Some([phi, _]) => (phi == 0.0, phi == FRAC_PI_2),
    };
    let sym_y = phi0 || i[0] == 0;
    let sym_x = phi1 || i[0] == 0;
    if sym_y {
        m[0][1] = 0.0;
        m[1][0] = 0.0;
        m[1][2] = 0.0;
        m[2][1] = 0.0;
    }
    if sym_x {
        m[0][1] = 0.0;
        m[1][0] = 0.0;
        m[0][2] = 0.0;
        m[2][0] = 0.0;
    }
}

fn finish(g: &Ggx, m: M3, magnitude: f64, fresnel: f64, origin: Origin) -> Entry {
    let (l3, l1) = fit::errors(g, &Ltc::new(m), magnitude, fit::OBJECTIVE_GRID);
    Entry {
        m,
        magnitude,
        fresnel,
        l1,
        l3,
        origin,
    }
}

/// Fits entry `i` of a table of `size` (an `Origin::Fit` entry) cold (three starts): the
/// exact fit, aligned, post-processed, third column of unit length, with its errors.
pub fn fit_entry(size: [usize; 4], i: [usize; 4]) -> Entry {
    fit_entry_from(size, i, None).0
}

/// [`fit_entry`] warm-started from a neighbour's parameters (fit::fit_general_from); returns
/// the entry and the parameters for the next.
pub fn fit_entry_from(size: [usize; 4], i: [usize; 4], warm: Option<[f64; 6]>) -> (Entry, [f64; 6]) {
    fit_entry_from_in(size, None, i, warm)
}

/// [`fit_entry_from`] in a full table or a slice.
pub fn fit_entry_from_in(size: [usize; 4], slice: Slice, i: [usize; 4], warm: Option<[f64; 6]>) -> (Entry, [f64; 6]) {
    let g = lobe(entry_point_in(size, slice, i));
    let (f, params) = fit::fit_general_from(&g, warm);
    let mut m = unit_third_column(&align(&geometry::inverse(&f.minv)));
    symmetrize(&mut m, i, size, slice);
    let m = unit_third_column(&m);
    (finish(&g, m, f.magnitude, f.fresnel, Origin::Fit), params)
}

/// What every fitted entry goes through after its fit, whatever the objective (the SW fit of
/// `sw.rs` too): M (ω = M ω_o/‖M ω_o‖, in the roughness frame) aligned (Eq. 12), third column
/// of unit length, the Eq. 16 zeros of entry `i` of a table of `size`, and its lobe errors.
pub fn post_process(size: [usize; 4], i: [usize; 4], m: &M3, magnitude: f64, fresnel: f64) -> Entry {
    let g = lobe(entry_point(size, i));
    let mut m = unit_third_column(&align(m));
    symmetrize(&mut m, i, size, None);
    let m = unit_third_column(&m);
    finish(&g, m, magnitude, fresnel, Origin::Fit)
}

/// Some entries of a table of `size` as CSV: the table's columns, `header` as `#` lines
/// (read back by [`parse_entries`]).
pub fn entries_csv(size: [usize; 4], entries: &[Fitted], header: &str) -> String {
    let mut s = String::new();
    for line in header.lines() {
        s.push_str(&format!("# {line}\n"));
    }
    s.push_str(COLUMNS);
    s.push('\n');
    for (i, e) in entries {
        s.push_str(&row(size, None, *i, e));
    }
    s
}

/// The rows of [`entries_csv`] (or of a table): each entry with its index.
pub fn parse_entries(text: &str, source: &str) -> Result<Vec<Fitted>, String> {
    parse_rows(text, source)
}

/// Which entries are fitted; the others (θ = 0, φ > 0) are copies of φ = 0.
fn origin_of(i: [usize; 4]) -> Origin {
    if i[0] == 0 && i[1] > 0 {
        Origin::Theta0
    } else {
        Origin::Fit
    }
}

fn all_indices(size: [usize; 4]) -> Vec<[usize; 4]> {
    let mut v = Vec::new();
    for a in 0..size[0] {
        for b in 0..size[1] {
            for c in 0..size[2] {
                for d in 0..size[3] {
                    v.push([a, b, c, d]);
                }
            }
        }
    }
    v
}

/// How many entries of a table of `size` are fitted (the rest are copies).
pub fn fitted_count(size: [usize; 4]) -> usize {
    all_indices(size)
        .into_iter()
        .filter(|&i| origin_of(i) == Origin::Fit)
        .count()
}

/// The fitted chains of a table: one per (θ, φ, r), its entries from the roughest α_max to
/// the smoothest, each warm-started from the one before (the paper's order, seed 004
/// Sec. 4.1). A chain is the unit of parallel work and of checkpoints: it depends on nothing
/// outside itself, so the table is the same for any thread count, order or resume.
pub fn chains(size: [usize; 4]) -> Vec<[usize; 3]> {
    let mut v = Vec::new();
    for a in 0..size[0] {
        for b in 0..size[1] {
            for d in 0..size[3] {
                if origin_of([a, b, 0, d]) == Origin::Fit {
                    v.push([a, b, d]);
                }
            }
        }
    }
    v
}

/// Fits one chain (see [`chains`]): the entries (iθ, iφ, iα, ir) for iα from the top down,
/// returned in that order with their indices.
pub fn fit_chain(size: [usize; 4], chain: [usize; 3]) -> Vec<Fitted> {
    fit_chain_in(size, None, chain)
}

/// [`fit_chain`] in a full table or a slice.
pub fn fit_chain_in(size: [usize; 4], slice: Slice, chain: [usize; 3]) -> Vec<Fitted> {
    let [a, b, d] = chain;
    let mut warm = None;
    let mut out = Vec::with_capacity(size[2]);
    for c in (0..size[2]).rev() {
        let i = [a, b, c, d];
        let (e, params) = fit_entry_from_in(size, slice, i, warm);
        warm = Some(params);
        out.push((i, e));
    }
    out
}

/// Fits the whole table: the chains not in `done` in parallel (`on_chain` is told of each as
/// it finishes, for checkpoints and progress), then the copies. `done` holds whole chains of
/// an earlier run (a checkpoint) and is trusted as fitted by this code.
pub fn fit_table(size: [usize; 4], done: &[Fitted], on_chain: &(dyn Fn(&[Fitted]) + Sync)) -> AnisoTable {
    fit_table_in(size, None, done, on_chain)
}

/// [`fit_table`] of a full table or a slice (a slice has no copies: its θ = 0 entry is fitted).
pub fn fit_table_in(
    size: [usize; 4],
    slice: Slice,
    done: &[Fitted],
    on_chain: &(dyn Fn(&[Fitted]) + Sync),
) -> AnisoTable {
    use rayon::prelude::*;
    let mut slots: Vec<Option<Entry>> = vec![None; size.iter().product()];
    for (i, e) in done {
        slots[index(size, *i)] = Some(e.clone());
    }
    let todo: Vec<[usize; 3]> = chains(size)
        .into_iter()
        .filter(|&[a, b, d]| slots[index(size, [a, b, 0, d])].is_none())
        .collect();
    let fitted: Vec<Vec<Fitted>> = todo
        .par_iter()
        .map(|&chain| {
            let entries = fit_chain_in(size, slice, chain);
            on_chain(&entries);
            entries
        })
        .collect();
    for (i, e) in fitted.into_iter().flatten() {
        slots[index(size, i)] = Some(e);
    }
    let entries = all_indices(size)
        .into_iter()
        .map(|i| match origin_of(i) {
            Origin::Fit | Origin::IsoRotation => slots[index(size, i)].clone().expect("every chain fitted"),
            Origin::Theta0 => {
                let base = slots[index(size, [0, 0, i[2], i[3]])]
                    .as_ref()
                    .expect("φ = 0 is fitted");
                let g = lobe(entry_point_in(size, slice, i));
                finish(&g, base.m, base.magnitude, base.fresnel, Origin::Theta0)
            }
        })
        .collect();
    AnisoTable { size, entries, slice }
}

const COLUMNS: &str = "i_theta,i_phi,i_alpha,i_ratio,theta,phi,alpha_max,ratio,m00,m01,m02,m10,m11,m12,m20,m21,m22,magnitude,fresnel,fit_l1,fit_l3,origin";

fn round(x: f64, storage: Storage) -> f32 {
    match storage {
        Storage::F32 => x as f32,
        Storage::F16 => half::f16::from_f64(x).to_f32(),
    }
}

/// The reflection Q (orthogonal, fixing z) that takes a configuration to the table's domain,
/// and the reduced (α_max, r, θ, φ) there: lobe(ω) = lobe_reduced(Q ω) (Eqs. 13 and 14).
fn reduce(alpha: [f64; 2], view: [f64; 3]) -> (M3, [f32; 4]) {
    let mut q: M3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let (mut vx, mut vy) = (view[0], view[1]);
    if vy < 0.0 {
        vy = -vy;
        q[1][1] = -1.0;
    }
    if vx < 0.0 {
        vx = -vx;
        q[0][0] = -1.0;
    }
    let (mut ax, mut ay) = (alpha[0], alpha[1]);
    if ay > ax {
        (ax, ay) = (ay, ax);
        (vx, vy) = (vy, vx);
        q = [q[1], q[0], q[2]];
    }
    // The shader's coordinates, in f32.
    let (vx, vy, vz) = (vx as f32, vy as f32, view[2] as f32);
    let theta = vz.clamp(-1.0, 1.0).acos();
    let phi = vy.atan2(vx);
    (q, [theta, phi, ax as f32, (ay / ax) as f32])
}

/// f32 inverse (adjugate / determinant, each entry divided), as a shader computes it: an
/// emulation of the shader's arithmetic like the CPU evaluator's builtins, not host
/// geometry, so it stays written out (glam's inverse multiplies by 1/det, other bits).
fn inverse_f32(m: &[[f32; 3]; 3]) -> [[f32; 3]; 3] {
    let c = |a: usize, b: usize, c: usize, d: usize| m[a][b] * m[c][d] - m[a][d] * m[c][b];
    let adj = [
        [c(1, 1, 2, 2), -c(0, 1, 2, 2), c(0, 1, 1, 2)],
        [-c(1, 0, 2, 2), c(0, 0, 2, 2), -c(0, 0, 1, 2)],
        [c(1, 0, 2, 1), -c(0, 0, 2, 1), c(0, 0, 1, 1)],
    ];
    let det = m[0][0] * adj[0][0] + m[0][1] * adj[1][0] + m[0][2] * adj[2][0];
    adj.map(|r| r.map(|x| x / det))
}

impl AnisoTable {
    /// Entry `i` as a shader's textures hold it: M row-major (third column of unit length),
    /// magnitude, Fresnel term, each rounded to `storage` (the device tables, `device.rs`).
    pub(crate) fn texel(&self, i: [usize; 4], storage: Storage) -> [f32; 11] {
        let e = &self.entries[index(self.size, i)];
        let mut t = [0.0f32; 11];
        for r in 0..3 {
            for c in 0..3 {
                t[3 * r + c] = round(e.m[r][c], storage);
            }
        }
        t[9] = round(e.magnitude, storage);
        t[10] = round(e.fresnel, storage);
        t
    }

    /// A shader's look-up for roughness (αx, αy) and a unit view (vz > 0), both in the
    /// roughness frame: the reduction to the table's domain, a quadrilinear look-up of M,
    /// magnitude and Fresnel term with f32 weights (clamped to the table's edges; trilinear
    /// 3D-texture filtering plus one lerp), M inverted in f32 and mapped back by Q. Returns
    /// M⁻¹ in the roughness frame (ω_o = M⁻¹ω), the magnitude and the Fresnel term.
    pub fn sample(&self, alpha: [f64; 2], view: [f64; 3], storage: Storage) -> (M3, f64, f64) {
        let (q, coords) = reduce(alpha, view);
        let range = [
            (0.0f32, THETA_MAX as f32),
            (0.0, FRAC_PI_2 as f32),
            (ALPHA_MIN as f32, 1.0),
            (RATIO_MIN as f32, 1.0),
        ];
        let mut lo = [0usize; 4];
        let mut frac = [0.0f32; 4];
        for k in 0..4 {
            let n = self.size[k];
            if n == 1 {
                continue;
            }
            let (a, b) = range[k];
            let pos = ((coords[k] - a) / (b - a) * (n - 1) as f32).clamp(0.0, (n - 1) as f32);
            let i = (pos.floor() as usize).min(n - 2);
            lo[k] = i;
            frac[k] = pos - i as f32;
        }
        let mut acc = [0.0f32; 11];
        // The 16 corners, weights as products of f32 lerp factors.
        for corner in 0..16usize {
            let mut idx = lo;
            let mut w = 1.0f32;
            for k in 0..4 {
                let up = corner >> k & 1 == 1;
                if self.size[k] > 1 && up {
                    idx[k] += 1;
                }
                w *= if self.size[k] == 1 {
                    if up {
                        0.0
                    } else {
                        1.0
                    }
                } else if up {
                    frac[k]
                } else {
                    1.0 - frac[k]
                };
            }
            if w == 0.0 {
                continue;
            }
            let t = self.texel(idx, storage);
            for (a, v) in acc.iter_mut().zip(t) {
                *a += w * v;
            }
        }
        let m = [
            [acc[0], acc[1], acc[2]],
            [acc[3], acc[4], acc[5]],
            [acc[6], acc[7], acc[8]],
        ];
        let minv_red = inverse_f32(&m).map(|r| r.map(f64::from));
        // M⁻¹ = Qᵀ M_red⁻¹ Q (Q is a signed permutation: exact).
        let minv = geometry::mat_mul(&geometry::mat_mul(&transpose(&q), &minv_red), &q);
        (minv, f64::from(acc[9]), f64::from(acc[10]))
    }

    /// The CSV text (inverse of `parse`).
    pub fn to_csv(&self, header: &str) -> String {
        let mut s = String::new();
        for line in header.lines() {
            s.push_str(&format!("# {line}\n"));
        }
        s.push_str(COLUMNS);
        s.push('\n');
        for i in all_indices(self.size) {
            s.push_str(&row(self.size, self.slice, i, &self.entries[index(self.size, i)]));
        }
        s
    }

    /// Reads a table written by [`AnisoTable::to_csv`], checked as an input: every entry once,
    /// at most `crate::limits::MAX_TABLE_ENTRIES` of them, every number finite, M invertible
    /// and the magnitude positive, and the (θ, φ, α_max, r) columns the grid's own (to 1e-12):
    /// a table of one entry on φ and on r is a slice (its fixed φ and r read from those
    /// columns, the same on every row, inside the table's domain).
    pub fn parse(text: &str, source: &str) -> Result<AnisoTable, String> {
        let rows = parse_rows(text, source)?;
        let mut size = [0usize; 4];
        for (i, _) in &rows {
            for k in 0..4 {
                size[k] = size[k].max(i[k] + 1);
            }
        }
        let cells = size.iter().try_fold(1usize, |n, &k| n.checked_mul(k));
        if cells.is_none_or(|n| n > crate::limits::MAX_TABLE_ENTRIES) {
            return Err(format!(
                "{source}: a {size:?} table, more than the {} entries a table may have",
                crate::limits::MAX_TABLE_ENTRIES
            ));
        }
        if rows.len() != size.iter().product::<usize>() || rows.is_empty() {
            return Err(format!("{source}: {} entries, not a full {size:?} table", rows.len()));
        }
        let slice = if size[1] == 1 && size[3] == 1 {
            let points = grid_columns(text);
            let first = points.first().copied().unwrap_or([f64::NAN; 4]);
            let s = [first[1], first[3]];
            check_slice(size, s).map_err(|e| format!("{source}: a slice table's (φ, r) columns: {e}"))?;
            Some(s)
        } else if size[1] == 1 || size[3] == 1 {
            return Err(format!(
                "{source}: a {size:?} table: one entry on φ or on r alone is neither a full table nor a slice (one on both)"
            ));
        } else {
            None
        };
        let mut entries: Vec<Option<Entry>> = vec![None; rows.len()];
        for ((i, e), p) in rows.into_iter().zip(grid_columns(text)) {
            let want = entry_point_in(size, slice, i);
            if (0..4).any(|k| (p[k] - want[k]).abs() > 1e-12) {
                return Err(format!(
                    "{source}: entry {i:?} has (θ, φ, α_max, r) = {p:?}, not its grid point {want:?}"
                ));
            }
            let tail = [e.magnitude, e.fresnel, e.l1, e.l3];
            if e.m.iter().flatten().chain(&tail).any(|x| !x.is_finite()) {
                return Err(format!("{source}: entry {i:?} has a number that is not finite"));
            }
            if geometry::det(&e.m) == 0.0 || !(e.magnitude > 0.0) {
                return Err(format!(
                    "{source}: entry {i:?}: M is singular or the magnitude not positive (det {}, magnitude {})",
                    geometry::det(&e.m),
                    e.magnitude
                ));
            }
            let slot = &mut entries[index(size, i)];
            if slot.is_some() {
                return Err(format!("{source}: entry {i:?} appears twice"));
            }
            *slot = Some(e);
        }
        let entries = entries
            .into_iter()
            .collect::<Option<Vec<_>>>()
            .ok_or_else(|| format!("{source}: an entry appears twice"))?;
        Ok(AnisoTable { size, entries, slice })
    }

    /// Reads a table file (`--aniso-table`, a study's other resolutions) through io, checked
    /// as [`AnisoTable::parse`] checks.
    pub fn load(path: &std::path::Path, what: &str) -> anyhow::Result<AnisoTable> {
        let bytes = crate::io::read_regular(path, what, crate::limits::MAX_TEXT_INPUT)?;
        let text = String::from_utf8(bytes)
            .map_err(|_| crate::io::InputError(format!("{}: {what} is not UTF-8", path.display())))?;
        Ok(AnisoTable::parse(&text, &path.display().to_string()).map_err(crate::io::InputError)?)
    }
}

/// The (θ, φ, α_max, r) columns of the rows, in the order of `parse_rows` (NaN where a field
/// does not read; `parse_rows` has refused such a row already).
fn grid_columns(text: &str) -> Vec<[f64; 4]> {
    text.lines()
        .map(str::trim)
        .filter(|l| !(l.is_empty() || l.starts_with('#') || l.starts_with("i_theta,")))
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            [4, 5, 6, 7].map(|k| f.get(k).and_then(|x| x.parse::<f64>().ok()).unwrap_or(f64::NAN))
        })
        .collect()
}

/// The rows of a table or checkpoint text (comments and the column line skipped).
fn parse_rows(text: &str, source: &str) -> Result<Vec<Fitted>, String> {
    let mut rows = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') || line.starts_with("i_theta,") {
            continue;
        }
        let f: Vec<&str> = line.split(',').collect();
        if f.len() != 22 {
            return Err(format!("{source}:{}: {} fields, expected 22", n + 1, f.len()));
        }
        let num = |k: usize| {
            f[k].parse::<f64>()
                .map_err(|e| format!("{source}:{}: field {} `{}`: {e}", n + 1, k + 1, f[k]))
        };
        let idx = |k: usize| {
            f[k].parse::<usize>()
                .map_err(|e| format!("{source}:{}: field {} `{}`: {e}", n + 1, k + 1, f[k]))
        };
        let i = [idx(0)?, idx(1)?, idx(2)?, idx(3)?];
        let v: Vec<f64> = (8..21).map(num).collect::<Result<_, _>>()?;
        let origin = Origin::parse(f[21]).ok_or_else(|| format!("{source}:{}: unknown origin `{}`", n + 1, f[21]))?;
        rows.push((
            i,
            Entry {
                m: [[v[0], v[1], v[2]], [v[3], v[4], v[5]], [v[6], v[7], v[8]]],
                magnitude: v[9],
                fresnel: v[10],
                l1: v[11],
                l3: v[12],
                origin,
            },
        ));
    }
    Ok(rows)
}

fn row(size: [usize; 4], slice: Slice, i: [usize; 4], e: &Entry) -> String {
    let p = entry_point_in(size, slice, i);
    let mut line = format!("{},{},{},{}", i[0], i[1], i[2], i[3]);
    for v in p
        .iter()
        .chain(e.m.iter().flatten())
        .chain(&[e.magnitude, e.fresnel, e.l1, e.l3])
    {
        // `{:e}` prints the shortest digits that read back to the same f64.
        line.push_str(&format!(",{v:e}"));
    }
    format!("{line},{}\n", e.origin.name())
}

/// What a checkpoint of an unfinished `fit --aniso` run holds: the table's size, the seconds
/// spent so far, and the entries of the chains finished (whole chains only).
#[derive(Clone, Debug, PartialEq)]
pub struct Checkpoint {
    pub size: [usize; 4],
    /// A slice's fixed (φ, r) (a `# slice φ,r` line), None for a full table.
    pub slice: Slice,
    pub seconds: f64,
    pub entries: Vec<Fitted>,
}

const CHECKPOINT_TAG: &str = "# linelight fit --aniso checkpoint v1";

impl Checkpoint {
    /// The checkpoint's text: a tag line, size and seconds, then the table's rows (exact f64).
    pub fn to_text(&self) -> String {
        let [a, b, c, d] = self.size;
        let mut s = format!(
            "{CHECKPOINT_TAG}\n# size {a},{b},{c},{d}\n# seconds {:e}\n",
            self.seconds
        );
        if let Some([phi, r]) = self.slice {
            s.push_str(&format!("# slice {phi:e},{r:e}\n"));
        }
        s.push_str(COLUMNS);
        s.push('\n');
        for (i, e) in &self.entries {
            s.push_str(&row(self.size, self.slice, *i, e));
        }
        s
    }

    /// Reads a checkpoint written by [`Checkpoint::to_text`]; refuses another file, a row
    /// outside the size, and a chain that is not whole.
    pub fn parse(text: &str, source: &str) -> Result<Checkpoint, String> {
        let mut lines = text.lines();
        if lines.next() != Some(CHECKPOINT_TAG) {
            return Err(format!(
                "{source}: not a checkpoint of `linelight fit --aniso` (no `{CHECKPOINT_TAG}` line)"
            ));
        }
        let field = |line: Option<&str>, key: &str| -> Result<String, String> {
            line.and_then(|l| l.strip_prefix(&format!("# {key} ")))
                .map(str::to_string)
                .ok_or_else(|| format!("{source}: line `# {key} …` missing"))
        };
        let size_text = field(lines.next(), "size")?;
        let size: Vec<usize> = size_text
            .split(',')
            .map(|x| x.parse::<usize>())
            .collect::<Result<_, _>>()
            .map_err(|e| format!("{source}: size `{size_text}`: {e}"))?;
        let size: [usize; 4] = size
            .try_into()
            .map_err(|_| format!("{source}: size `{size_text}` is not 4 numbers"))?;
        let seconds_text = field(lines.next(), "seconds")?;
        let seconds = seconds_text
            .parse::<f64>()
            .map_err(|e| format!("{source}: seconds `{seconds_text}`: {e}"))?;
        let slice = match lines.next().and_then(|l| l.strip_prefix("# slice ")) {
            None => None,
            Some(t) => {
                let v: Vec<f64> = t
                    .split(',')
                    .map(|x| x.parse::<f64>())
                    .collect::<Result<_, _>>()
                    .map_err(|e| format!("{source}: slice `{t}`: {e}"))?;
                let v: [f64; 2] = v
                    .try_into()
                    .map_err(|_| format!("{source}: slice `{t}` is not 2 numbers"))?;
                check_slice(size, v).map_err(|e| format!("{source}: {e}"))?;
                Some(v)
            }
        };
        let entries = parse_rows(text, source)?;
        let mut per_chain = std::collections::BTreeMap::<[usize; 3], usize>::new();
        for (i, e) in &entries {
            if (0..4).any(|k| i[k] >= size[k]) || origin_of(*i) != Origin::Fit || e.origin != Origin::Fit {
                return Err(format!(
                    "{source}: entry {i:?} is not a fitted entry of a {size:?} table"
                ));
            }
            *per_chain.entry([i[0], i[1], i[3]]).or_default() += 1;
        }
        if let Some((chain, n)) = per_chain.iter().find(|(_, &n)| n != size[2]) {
            return Err(format!("{source}: chain {chain:?} has {n} of {} entries", size[2]));
        }
        Ok(Checkpoint {
            size,
            slice,
            seconds,
            entries,
        })
    }
}

/// Our committed anisotropic table, compiled in.
pub fn ours() -> &'static AnisoTable {
    static T: std::sync::OnceLock<AnisoTable> = std::sync::OnceLock::new();
    T.get_or_init(|| {
        AnisoTable::parse(
            include_str!("../../../data/ltc_ggx_aniso.csv"),
            "data/ltc_ggx_aniso.csv",
        )
        .expect("the committed table parses (tests check it)")
    })
}
