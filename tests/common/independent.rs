//! What the independent-reference tests (tests/reference_independent.rs,
//! tests/ggx_reference.rs, tests/mrp_specular.rs) share, written from docs/conventions.md alone and never from src/: vector
//! arithmetic on `[f64; 3]`, Gauss–Legendre nodes by Newton on Pₙ, a basis about a
//! direction, and the GGX lobe term by term.

use linelight::input::scene::Vec3;
use std::f64::consts::PI;

pub fn add(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
pub fn sub(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
pub fn mul(a: Vec3, s: f64) -> Vec3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
pub fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
pub fn cross(a: Vec3, b: Vec3) -> Vec3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
pub fn norm(a: Vec3) -> f64 {
    dot(a, a).sqrt()
}
pub fn unit(a: Vec3) -> Vec3 {
    mul(a, 1.0 / norm(a))
}

/// The 16-point Gauss–Legendre rule on [−1, 1], computed once.
pub fn gauss16() -> &'static [(f64, f64)] {
    static RULE: std::sync::OnceLock<Vec<(f64, f64)>> = std::sync::OnceLock::new();
    RULE.get_or_init(|| legendre(16))
}

/// The n-point Gauss–Legendre rule on [−1, 1] (nodes, weights) by Newton on Pₙ.
pub fn legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            loop {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let k = k as f64;
                    (p0, p1) = (p1, ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k);
                }
                let dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-16 {
                    return (x, 2.0 / ((1.0 - x * x) * dp * dp));
                }
            }
        })
        .collect()
}

/// Two unit vectors completing ω_t to an orthonormal basis.
pub fn basis(t: Vec3) -> (Vec3, Vec3) {
    let helper = if t[2].abs() < 0.9 {
        [0.0, 0.0, 1.0]
    } else {
        [1.0, 0.0, 0.0]
    };
    let e1 = unit(cross(helper, t));
    (e1, cross(t, e1))
}

/// docs/conventions.md `ggx`, written from the text: NDF(h)·G2(v, ω)/(4 v.z) for ω.z > 0, with the
/// normalised half vector and height-correlated Smith Λ as written.
pub fn ggx_d(alpha: [f64; 2], v: Vec3, w: Vec3) -> f64 {
    if w[2] <= 0.0 {
        return 0.0;
    }
    let (ax, ay) = (alpha[0], alpha[1]);
    let h = unit(add(v, w));
    let k = (h[0] / ax).powi(2) + (h[1] / ay).powi(2) + h[2] * h[2];
    let ndf = 1.0 / (PI * ax * ay * k * k);
    let lambda = |u: Vec3| (-1.0 + (1.0 + ((ax * u[0]).powi(2) + (ay * u[1]).powi(2)) / (u[2] * u[2])).sqrt()) / 2.0;
    ndf / (1.0 + lambda(v) + lambda(w)) / (4.0 * v[2])
}

/// Listing 1.10, the LTC distribution of M⁻¹ `minv` (diffuse is M⁻¹ = I) at the unit `w`.
pub fn ltc_d(minv: &[[f64; 3]; 3], w: Vec3) -> f64 {
    let wo = minv.map(|r| dot(r, w));
    let lo = norm(wo);
    let det = minv[0][0] * (minv[1][1] * minv[2][2] - minv[1][2] * minv[2][1])
        - minv[0][1] * (minv[1][0] * minv[2][2] - minv[1][2] * minv[2][0])
        + minv[0][2] * (minv[1][0] * minv[2][1] - minv[1][1] * minv[2][0]);
    (wo[2] / lo).max(0.0) * det.abs() / (std::f64::consts::PI * lo * lo * lo)
}

/// The ends of the pieces of [a, b] cut at those `cuts` inside it, in order, each once.
pub fn pieces(a: f64, b: f64, cuts: &[f64]) -> Vec<f64> {
    let mut ends: Vec<f64> = cuts.iter().copied().filter(|&c| c > a && c < b).collect();
    ends.extend([a, b]);
    ends.sort_by(f64::total_cmp);
    ends.dedup();
    ends
}

/// ∫ f over [a, b] cut at `cuts`, `per` equal Gauss–Legendre-16 panels on every piece.
pub fn composite(f: &dyn Fn(f64) -> f64, a: f64, b: f64, cuts: &[f64], per: usize) -> f64 {
    let mut sum = 0.0;
    for w in pieces(a, b, cuts).windows(2) {
        let h = (w[1] - w[0]) / per as f64;
        for i in 0..per {
            let c = w[0] + (i as f64 + 0.5) * h;
            sum += gauss16().iter().map(|&(x, wt)| wt * f(c + 0.5 * h * x)).sum::<f64>() * 0.5 * h;
        }
    }
    sum
}
