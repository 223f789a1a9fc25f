//! `sin` and `cos` of the chord angles, together and without a libm call: the inner
//! integrand of every reference (`line::integrate_chord_weighted`) needs both at each of its
//! nodes, and glibc's `sin` + `cos` were ~45 % of the references' time.
//!
//! The angles lie in [0, π] (χ of a chord's half), so the reduction is one step:
//! k = round(x·2/π) ∈ {0, 1, 2} and r = x − k·π/2 with |r| ≤ π/4. π/2 is split into
//! `FRAC_PI_2` (its f64 rounding) plus `PIO2_LO` = π/2 − fl(π/2) (computed with mpmath at
//! 40 digits: 6.123233995736766e-17); k·fl(π/2) is exact for k ≤ 2 and x − k·fl(π/2) is exact
//! by Sterbenz's lemma (x ∈ [π/4, 5π/4] is within a factor 2 of it), so r carries one
//! rounding plus |π/2 − fl(π/2) − PIO2_LO| < 1e-33 per k. On |r| ≤ π/4 the Taylor series
//! of sin through r¹⁷ and of cos through r¹⁸ leave at most π/4¹⁹/19! < 1e-19 and
//! π/4²⁰/20! < 4e-21: below ε/1000 of the values there. The coefficients are 1/n! rounded
//! to f64. Horner's rule without FMA (the build is portable and the bits must not depend on
//! the machine) keeps the result within ~1 ulp of the true value; the unit tests bound it
//! against `f64::sin`/`cos` on a dense grid of [0, π]. Outside [0, 3.9] (never for a chord,
//! but a caller may pass anything) the std functions are used.
//!
//! Why the references' error model still covers it: an integrand value carries a relative
//! rounding of a few ε however its sin and cos are computed (here ≤ 2 ulp from sin/cos plus
//! the arithmetic that follows, as before), and `quadrature::integrate`'s floor
//! `nodes·ε·∫|f|` with nodes ≥ 21 bounds a per-value relative error up to 21·ε.

use std::f64::consts::{FRAC_2_PI, FRAC_PI_2};

/// π/2 − fl(π/2).
const PIO2_LO: f64 = 6.123233995736766e-17;
/// 1.5·2⁵²: adding it rounds a value in [0, 2⁵¹) to an integer held in the low mantissa bits.
const ROUND: f64 = 6755399441055744.0;
/// Largest argument of the fast path: k ≤ 2 keeps the reduction exact.
const FAST_MAX: f64 = 3.9;

/// (−1)ⁿ/(2n+1)! for n = 1..=8 (sin: r + r³·(S1 + r²·(S2 + …))).
const S: [f64; 8] = [
    -1.0 / 6.0,
    1.0 / 120.0,
    -1.0 / 5040.0,
    1.0 / 362880.0,
    -1.0 / 39916800.0,
    1.0 / 6227020800.0,
    -1.0 / 1307674368000.0,
    1.0 / 355687428096000.0,
];
/// (−1)ⁿ/(2n)! for n = 2..=9 (cos: 1 − r²/2 + r⁴·(C2 + r²·(C3 + …))).
const C: [f64; 8] = [
    1.0 / 24.0,
    -1.0 / 720.0,
    1.0 / 40320.0,
    -1.0 / 3628800.0,
    1.0 / 479001600.0,
    -1.0 / 87178291200.0,
    1.0 / 20922789888000.0,
    -1.0 / 6402373705728000.0,
];

/// sin r and cos r for |r| ≤ π/4 (a little beyond is fine).
#[inline(always)]
fn kernel(r: f64) -> (f64, f64) {
    let z = r * r;
    let mut ps = S[7];
    let mut pc = C[7];
    for j in (0..7).rev() {
        ps = ps * z + S[j];
        pc = pc * z + C[j];
    }
    let sin = r + r * (z * ps);
    let cos = (1.0 - 0.5 * z) + (z * z) * pc;
    (sin, cos)
}

/// (sin x, cos x) for x ∈ [0, 3.9] without a branch on x; NaN or garbage elsewhere (the
/// callers below route those to std).
#[inline(always)]
fn fast(x: f64) -> (f64, f64) {
    let t = x * FRAC_2_PI + ROUND;
    let q = t.to_bits() & 3;
    let k = t - ROUND;
    let r = (x - k * FRAC_PI_2) - k * PIO2_LO;
    let (s, c) = kernel(r);
    // q = 0: (s, c); 1: (c, −s); 2: (−s, −c).
    let odd = q & 1 == 1;
    let (a, b) = if odd { (c, s) } else { (s, c) };
    let sin_sign = if q == 2 { 1u64 << 63 } else { 0 };
    let cos_sign = if q != 0 { 1u64 << 63 } else { 0 };
    (
        f64::from_bits(a.to_bits() ^ sin_sign),
        f64::from_bits(b.to_bits() ^ cos_sign),
    )
}

/// (sin x, cos x) for any x: the fast path on [0, 3.9], std elsewhere.
#[inline]
pub(crate) fn sin_cos(x: f64) -> (f64, f64) {
    if (0.0..=FAST_MAX).contains(&x) {
        fast(x)
    } else {
        x.sin_cos()
    }
}

/// `sin_cos` of every element of `x`, into `sin` and `cos`: a straight-line loop over the
/// batch, then std for the (rare) elements outside [0, 3.9].
#[inline]
#[allow(clippy::needless_range_loop)] // lockstep over four arrays, kept plain for the vectoriser
pub(crate) fn sin_cos_batch<const N: usize>(x: &[f64; N], sin: &mut [f64; N], cos: &mut [f64; N]) {
    for i in 0..N {
        let (s, c) = fast(x[i]);
        sin[i] = s;
        cos[i] = c;
    }
    for i in 0..N {
        if !(0.0..=FAST_MAX).contains(&x[i]) {
            (sin[i], cos[i]) = x[i].sin_cos();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// Distance in units of the last place of `b` (its ulp at |b|, and at least the ulp of
    /// 2⁻¹⁰⁰⁰ so that a zero does not divide by zero).
    fn ulps(a: f64, b: f64) -> f64 {
        let ulp = |v: f64| {
            let v = v.abs().max(1e-300);
            f64::from_bits(v.to_bits() + 1) - v
        };
        (a - b).abs() / ulp(b)
    }

    #[test]
    fn within_two_ulps_of_std_on_a_dense_grid_of_zero_to_pi() {
        // 2·10⁶ points on [0, π] plus the quadrant boundaries and their neighbours.
        let mut xs: Vec<f64> = (0..=2_000_000).map(|i| PI * i as f64 / 2e6).collect();
        for b in [0.25 * PI, 0.5 * PI, 0.75 * PI, PI, FRAC_PI_2] {
            let mut v = b;
            for _ in 0..20 {
                xs.extend([v, f64::from_bits(v.to_bits() + 1)]);
                v = f64::from_bits(v.to_bits() - 1);
            }
        }
        xs.extend([1e-300, 1e-20, 1e-8, 5e-324]);
        let (mut worst_s, mut worst_c) = (0.0f64, 0.0f64);
        for &x in &xs {
            let (s, c) = sin_cos(x);
            worst_s = worst_s.max(ulps(s, x.sin()));
            worst_c = worst_c.max(ulps(c, x.cos()));
        }
        // Measured: see docs/references.md; the bound is what the error model assumes.
        assert!(worst_s <= 2.0 && worst_c <= 2.0, "sin {worst_s} ulp, cos {worst_c} ulp");
        // Near π, sin is tiny and relatively accurate only through the reduction's PIO2_LO.
        let x = PI; // fl(π) = π − 1.2246467991473532e-16
        let (s, c) = sin_cos(x);
        assert!(ulps(s, 1.2246467991473532e-16) <= 1.0, "{s:e}");
        assert_eq!(c, -1.0);
    }

    #[test]
    #[allow(clippy::needless_range_loop)]
    fn batch_equals_scalar_and_outside_the_fast_range_is_std() {
        let mut x = [0.0; 21];
        for (i, v) in x.iter_mut().enumerate() {
            *v = -1.0 + 0.3 * i as f64; // −1 … 5: both sides of the fast range
        }
        x[3] = f64::NAN;
        let (mut s, mut c) = ([0.0; 21], [0.0; 21]);
        sin_cos_batch(&x, &mut s, &mut c);
        for i in 0..21 {
            let (a, b) = sin_cos(x[i]);
            assert!(
                a.to_bits() == s[i].to_bits() && b.to_bits() == c[i].to_bits(),
                "{}",
                x[i]
            );
            if !(0.0..=FAST_MAX).contains(&x[i]) {
                let (a, b) = x[i].sin_cos();
                assert!(
                    a.to_bits() == s[i].to_bits() && b.to_bits() == c[i].to_bits(),
                    "{}",
                    x[i]
                );
            }
        }
    }
}
