//! Our LTC tables as a shader reads them (the device look-ups): the isotropic 2D table
//! (`table::ours`) and the anisotropic 4D table of seed 004 (`aniso::ours`), their texels in
//! f32 (RGBA32F), laid out in one array of f32 behind a header, which the GPU binds as
//! `ll_ltc` (binding 4, declared in kernels/prelude.wgsl) and the CPU evaluator reads the same.
//! The look-ups that read it are kernels (kernels/ltc/), so that their cost can be timed.
//!
//! Layout (indices into the array; integers are stored as exact f32):
//!
//! | index | what |
//! |---|---|
//! | 0 | N, the isotropic table's size (N × N) |
//! | 1 | the isotropic table's first texel |
//! | 2 | the anisotropic table's first texel |
//! | 3..7 | the anisotropic table's size (θ, φ, α_max, r) |
//! | 7..11 | its axes' upper θ, upper φ (π/2), lower α_max, lower r, as f32 (`aniso::THETA_MAX`, …) |
//! | 11..16 | 0 |
//!
//! Isotropic texel (a, t) (α column a, θ row t, as `table::entry_point`) at
//! `iso + 6·(a + N·t)`: (a, b, c, d) of the sparse M⁻¹ `[[a,0,b],[0,c,0],[d,0,1]]`, magnitude,
//! Fresnel term (`Table::texel`). Anisotropic entry (iθ, iφ, iα, ir) at
//! `aniso + 11·aniso::index(size, i)`: M row-major (third column of unit length), magnitude,
//! Fresnel term (`AnisoTable::texel`).

use super::aniso::{self, AnisoTable};
use super::table::{self, Storage, Table};

/// Floats before the first texel.
pub const HEADER: usize = 16;
/// Floats per isotropic texel and per anisotropic entry.
pub const ISO_TEXEL: usize = 6;
pub const ANISO_TEXEL: usize = 11;

/// The array for `iso` and `aniso` (a full table, not a slice).
pub fn layout(iso: &Table, aniso_table: &AnisoTable) -> Result<Vec<f32>, String> {
    if aniso_table.slice.is_some() || aniso_table.size.iter().any(|&n| n < 2) {
        return Err(format!(
            "the device look-up reads full anisotropic tables, not a {:?} slice",
            aniso_table.size
        ));
    }
    let n = iso.size;
    let iso_base = HEADER;
    let aniso_base = iso_base + ISO_TEXEL * n * n;
    let cells: usize = aniso_table.size.iter().product();
    let total = aniso_base + ANISO_TEXEL * cells;
    // Every index must be an exact f32 (the kernels convert them to u32).
    if total >= 1 << 24 {
        return Err(format!("{total} floats: too many for f32 indices"));
    }
    let mut out = vec![0.0f32; total];
    out[0] = n as f32;
    out[1] = iso_base as f32;
    out[2] = aniso_base as f32;
    for k in 0..4 {
        out[3 + k] = aniso_table.size[k] as f32;
    }
    out[7] = aniso::THETA_MAX as f32;
    out[8] = std::f64::consts::FRAC_PI_2 as f32;
    out[9] = aniso::ALPHA_MIN as f32;
    out[10] = aniso::RATIO_MIN as f32;
    for t in 0..n {
        for a in 0..n {
            let at = iso_base + ISO_TEXEL * (a + n * t);
            out[at..at + ISO_TEXEL].copy_from_slice(&iso.texel(a, t, Storage::F32));
        }
    }
    let s = aniso_table.size;
    for i0 in 0..s[0] {
        for i1 in 0..s[1] {
            for i2 in 0..s[2] {
                for i3 in 0..s[3] {
                    let i = [i0, i1, i2, i3];
                    let at = aniso_base + ANISO_TEXEL * aniso::index(s, i);
                    out[at..at + ANISO_TEXEL].copy_from_slice(&aniso_table.texel(i, Storage::F32));
                }
            }
        }
    }
    Ok(out)
}

/// Our committed tables' array (`table::ours`, `aniso::ours`), made once.
pub fn ours() -> &'static [f32] {
    static T: std::sync::OnceLock<Vec<f32>> = std::sync::OnceLock::new();
    T.get_or_init(|| layout(table::ours(), aniso::ours()).expect("the committed tables are full (tests check them)"))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The header and a texel of each table read back as the host look-ups see them.
    #[test]
    fn the_layout_holds_both_tables() {
        let t = ours();
        let (iso, an) = (table::ours(), aniso::ours());
        assert_eq!(t[0] as usize, iso.size);
        let n = iso.size;
        assert_eq!(t[2] as usize, HEADER + ISO_TEXEL * n * n);
        assert_eq!(t.len(), t[2] as usize + ANISO_TEXEL * an.entries.len());
        let (a, r) = (5, 17);
        let at = t[1] as usize + ISO_TEXEL * (a + n * r);
        assert_eq!(&t[at..at + ISO_TEXEL], &iso.texel(a, r, Storage::F32));
        let i = [3, 2, 7, 1];
        let at = t[2] as usize + ANISO_TEXEL * aniso::index(an.size, i);
        assert_eq!(&t[at..at + ANISO_TEXEL], &an.texel(i, Storage::F32));
        assert_eq!(
            t[at + 9] as f64,
            an.entries[aniso::index(an.size, i)].magnitude as f32 as f64
        );
    }
}
