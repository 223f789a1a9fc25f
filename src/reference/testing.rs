//! Helpers for the unit tests: a brute-force quadrature that shares nothing with the
//! adaptive one, and random configurations.

use crate::input::geometry::{self, v3};
use crate::input::scene::{Mat3, Material, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// n-point Gauss–Legendre nodes and weights on [−1, 1] (Newton on P_n).
pub fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 0.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let k = k as f64;
                    (p0, p1) = (p1, ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k);
                }
                dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-17 {
                    break;
                }
            }
            (x, 2.0 / ((1.0 - x * x) * dp * dp))
        })
        .collect()
}

/// Composite Gauss–Legendre over `[a, b]` cut at `cuts`, `panels` equal panels per piece,
/// summed with Neumaier compensation.
pub fn brute(f: impl Fn(f64) -> f64, a: f64, b: f64, cuts: &[f64], panels: usize) -> f64 {
    let rule = gauss_legendre(20);
    let mut ends: Vec<f64> = cuts.iter().copied().filter(|&c| c > a && c < b).collect();
    ends.extend([a, b]);
    ends.sort_by(f64::total_cmp);
    let (mut sum, mut comp) = (0.0f64, 0.0f64);
    for w in ends.windows(2) {
        let h = (w[1] - w[0]) / panels as f64;
        for i in 0..panels {
            let c = w[0] + (i as f64 + 0.5) * h;
            let v: f64 = rule.iter().map(|&(x, wt)| wt * f(c + 0.5 * h * x)).sum::<f64>() * 0.5 * h;
            let t = sum + v;
            comp += if sum.abs() >= v.abs() {
                (sum - t) + v
            } else {
                (v - t) + sum
            };
            sum = t;
        }
    }
    sum + comp
}

/// The sign changes of `f` on `[a, b]`, located by bisection from a grid of `n` cells.
pub fn sign_changes(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> Vec<f64> {
    let x = |i: usize| a + (b - a) * i as f64 / n as f64;
    (0..n)
        .filter(|&i| (f(x(i)) > 0.0) != (f(x(i + 1)) > 0.0))
        .map(|i| {
            let (mut lo, mut hi) = (x(i), x(i + 1));
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if (f(mid) > 0.0) == (f(lo) > 0.0) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            0.5 * (lo + hi)
        })
        .collect()
}

pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

pub fn point(rng: &mut ChaCha8Rng, r: f64) -> Vec3 {
    [0; 3].map(|_| rng.random_range(-r..r))
}

/// A random rotation (from a random unit quaternion).
pub fn rotation(rng: &mut ChaCha8Rng) -> Mat3 {
    let q: [f64; 4] = loop {
        let q = [0; 4].map(|_| rng.random_range(-1.0..1.0f64));
        let n = q.iter().map(|x| x * x).sum::<f64>().sqrt();
        if n > 0.1 && n < 1.0 {
            break q.map(|x| x / n);
        }
    };
    let [w, x, y, z] = q;
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ]
}

pub use crate::input::geometry::{inverse, mat_vec};

/// A sparse isotropic-GGX-like LTC `[[a,0,b],[0,c,0],[d,0,1]]`, lobe widths down to ~1/20.
pub fn sparse_ltc(rng: &mut ChaCha8Rng) -> Material {
    let (a, c) = (rng.random_range(1.0..20.0), rng.random_range(1.0..20.0));
    let (b, d) = (rng.random_range(-2.0..2.0), rng.random_range(-0.8..0.8));
    Material::Ltc {
        minv: [[a, 0.0, b], [0.0, c, 0.0], [d, 0.0, 1.0]],
    }
}

/// A full 3×3 LTC: a sparse one times a random rotation plus a perturbation.
pub fn full_ltc(rng: &mut ChaCha8Rng) -> Material {
    let Material::Ltc { minv } = sparse_ltc(rng) else {
        unreachable!()
    };
    let mut m = geometry::mat_mul(&minv, &rotation(rng));
    for x in m.iter_mut().flatten() {
        *x += rng.random_range(-0.3..0.3);
    }
    Material::Ltc { minv: m }
}

/// A segment of length `len` across the direction the LTC `material` maps to its pole (the
/// neighbourhood of its peak), at distance `dist`, offset by `shift` along the segment.
pub fn segment_through_lobe(
    material: &Material,
    dist: f64,
    len: f64,
    shift: f64,
    rng: &mut ChaCha8Rng,
) -> (Vec3, Vec3) {
    let m = inverse(&material.minv());
    let pole = mat_vec(&m, [0.0, 0.0, 1.0]);
    let pole = v3(pole).normalize();
    let t = loop {
        let r = v3(point(rng, 1.0));
        let t = r - r.dot(pole) * pole;
        let l = t.length();
        if l > 0.1 {
            break t / l;
        }
    };
    let at = |s: f64| (dist * pole + (s + shift) * t).to_array();
    (at(-0.5 * len), at(0.5 * len))
}
