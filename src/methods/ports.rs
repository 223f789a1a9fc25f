//! CPU ports of the line methods in `kernels/line_*.wgsl`, generic over the float type.
//!
//! Each function mirrors its kernel operation for operation: same order, same guards, same
//! constants, same `D` (Listing 1.10). Evaluated in f32 it cross-checks the GPU port;
//! evaluated in f64 it shows the formula's own error, free of f32 rounding. Names follow
//! the listings. Inputs are converted to `T` first and everything after is done in `T`.
//!
//! `evaluate` does not check M⁻¹ support: `line.ltc2023` on a full M⁻¹ returns what the
//! listing computes (wrong), and the harness decides from the kernel header what to report.

#![allow(non_snake_case)] // the listings' names: Fpo, I_diffuse_line, ComputeLineWidthFactor…

use crate::scene::Config;
use num_traits::{Float, FloatConst, FromPrimitive};
use std::ops::{Add, Div, Mul, Neg, Sub};

/// A float type the ports are evaluated in.
pub trait Real: Float + FloatConst + FromPrimitive + Copy + Send + Sync + 'static {}
impl Real for f32 {}
impl Real for f64 {}

/// Method ids with a CPU port (one kernel file each).
pub const PORTED: [&str; 6] = [
    "line.ltc2017",
    "line.ltc2017_fwt",
    "line.ltc2023",
    "line.ltc2023_full",
    "line.numeric_paper",
    "line.numeric",
];

pub fn has_port(id: &str) -> bool {
    PORTED.contains(&id)
}

/// Evaluates method `id` on `config` in `T`. `params` are the kernel's override values in
/// header order (empty → defaults). None if `id` has no CPU port (e.g. a user kernel).
pub fn evaluate<T: Real>(id: &str, params: &[u32], config: &Config) -> Option<T> {
    let p1 = Vec3::from_f64(config.p1);
    let p2 = Vec3::from_f64(config.p2);
    let minv = Mat3::from_rows(config.material.minv());
    let value = match id {
        "line.ltc2017" => listing_1_6::I_ltc_line(minv, p1, p2, listing_1_6::Fwt),
        "line.ltc2017_fwt" => listing_1_6::I_ltc_line(minv, p1, p2, listing_1_6::Fwt_2023),
        "line.ltc2023" => ltc2023::method(minv, p1, p2, ltc2023::ComputeLineWidthFactor),
        "line.ltc2023_full" => ltc2023::method(minv, p1, p2, ltc2023::ComputeLineWidthFactor_full),
        "line.numeric_paper" => numeric::I_line_numerical(minv, p1, p2),
        "line.numeric" => {
            let samples = params.first().copied().unwrap_or(numeric::DEFAULT_SAMPLES);
            numeric::I_line_gauss(minv, p1, p2, samples)
        }
        _ => return None,
    };
    Some(value)
}

/// An f64 constant in `T` (rounded to nearest, as a WGSL f32 literal is).
fn lit<T: Real>(x: f64) -> T {
    T::from_f64(x).expect("constant representable in T")
}

/// WGSL `vec3<f32>`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Vec3<T> {
    x: T,
    y: T,
    z: T,
}

impl<T: Real> Vec3<T> {
    fn new(x: T, y: T, z: T) -> Self {
        Vec3 { x, y, z }
    }
    fn from_f64(v: [f64; 3]) -> Self {
        Vec3::new(lit(v[0]), lit(v[1]), lit(v[2]))
    }
}

impl<T: Real> Add for Vec3<T> {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Vec3::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}
impl<T: Real> Sub for Vec3<T> {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        Vec3::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}
impl<T: Real> Neg for Vec3<T> {
    type Output = Self;
    fn neg(self) -> Self {
        Vec3::new(-self.x, -self.y, -self.z)
    }
}
impl<T: Real> Mul<T> for Vec3<T> {
    type Output = Self;
    fn mul(self, s: T) -> Self {
        Vec3::new(self.x * s, self.y * s, self.z * s)
    }
}
impl<T: Real> Div<T> for Vec3<T> {
    type Output = Self;
    fn div(self, s: T) -> Self {
        Vec3::new(self.x / s, self.y / s, self.z / s)
    }
}

fn dot<T: Real>(a: Vec3<T>, b: Vec3<T>) -> T {
    a.x * b.x + a.y * b.y + a.z * b.z
}
fn cross<T: Real>(a: Vec3<T>, b: Vec3<T>) -> Vec3<T> {
    Vec3::new(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x)
}
fn length<T: Real>(v: Vec3<T>) -> T {
    dot(v, v).sqrt()
}
fn inverse_sqrt<T: Real>(x: T) -> T {
    T::one() / x.sqrt()
}
/// As GPU drivers lower it: v · rsqrt(v·v).
fn normalize<T: Real>(v: Vec3<T>) -> Vec3<T> {
    v * inverse_sqrt(dot(v, v))
}

/// WGSL `mat3x3<f32>`: column-major, `c[j]` is column j, so WGSL `m[j][i]` is `c[j]` row i.
#[derive(Clone, Copy, Debug)]
struct Mat3<T> {
    c: [Vec3<T>; 3],
}

impl<T: Real> Mat3<T> {
    /// From the row-major M⁻¹ of a configuration.
    fn from_rows(m: [[f64; 3]; 3]) -> Self {
        let col = |j: usize| Vec3::new(lit(m[0][j]), lit(m[1][j]), lit(m[2][j]));
        Mat3 {
            c: [col(0), col(1), col(2)],
        }
    }
    fn transpose(self) -> Self {
        let [a, b, c] = self.c;
        Mat3 {
            c: [
                Vec3::new(a.x, b.x, c.x),
                Vec3::new(a.y, b.y, c.y),
                Vec3::new(a.z, b.z, c.z),
            ],
        }
    }
    fn mul_vec(self, v: Vec3<T>) -> Vec3<T> {
        self.c[0] * v.x + self.c[1] * v.y + self.c[2] * v.z
    }
    fn scale(self, s: T) -> Self {
        Mat3 {
            c: self.c.map(|col| col * s),
        }
    }
    fn determinant(self) -> T {
        dot(self.c[0], cross(self.c[1], self.c[2]))
    }
}

/// The prelude's `inverse3` (GLSL `inverse`): adjugate over determinant.
fn inverse3<T: Real>(m: Mat3<T>) -> Mat3<T> {
    let c0 = cross(m.c[1], m.c[2]);
    let c1 = cross(m.c[2], m.c[0]);
    let c2 = cross(m.c[0], m.c[1]);
    let det = dot(m.c[0], c0);
    Mat3 { c: [c0, c1, c2] }.transpose().scale(T::one() / det)
}

/// Listing 1.10 as in the prelude (M⁻¹ = I gives the diffuse distribution).
fn D<T: Real>(minv: Mat3<T>, w: Vec3<T>) -> T {
    let wo = minv.mul_vec(w);
    let lo = length(wo);
    T::one() / T::PI() * T::zero().max(wo.z / lo) * minv.determinant().abs() / (lo * lo * lo)
}

/// `kernels/line_ltc2017.wgsl` and `line_ltc2017_fwt.wgsl`: Listings 1.6 + 1.7.
mod listing_1_6 {
    use super::*;

    /// Eq. 1.22. The seed's `1/(d*(d*d + 1*1))` is the letter l rendered as the digit 1.
    pub fn Fpo<T: Real>(d: T, l: T) -> T {
        l / (d * (d * d + l * l)) + (l / d).atan() / (d * d)
    }

    /// Eq. 1.23 as published: tends to 1/d for |l| ≫ d, so Fwt(l2) − Fwt(l1) cancels.
    pub fn Fwt<T: Real>(d: T, l: T) -> T {
        l * l / (d * (d * d + l * l))
    }

    /// Eq. 1.23 as corrected in 2023; differs from `Fwt` by the constant 1/d.
    pub fn Fwt_2023<T: Real>(d: T, l: T) -> T {
        -d / (d * d + l * l)
    }

    pub fn I_diffuse_line<T: Real>(mut p1: Vec3<T>, mut p2: Vec3<T>, Fwt: fn(T, T) -> T) -> T {
        let zero = T::zero();

        // tangent
        let wt = normalize(p2 - p1);

        // clamping
        if p1.z <= zero && p2.z <= zero {
            return zero;
        }
        if p1.z < zero {
            p1 = (p1 * p2.z - p2 * p1.z) / (p2.z - p1.z);
        }
        if p2.z < zero {
            p2 = (-p1 * p2.z + p2 * p1.z) / (-p2.z + p1.z);
        }

        // parameterization
        let l1 = dot(p1, wt);
        let l2 = dot(p2, wt);

        // shading point orthonormal projection on the line
        let po = p1 - wt * l1;

        // distance to line
        let d = length(po);

        // integral
        let I = (Fpo(d, l2) - Fpo(d, l1)) * po.z + (Fwt(d, l2) - Fwt(d, l1)) * wt.z;
        I / T::PI()
    }

    /// Listing 1.7.
    pub fn I_ltc_line<T: Real>(minv: Mat3<T>, p1: Vec3<T>, p2: Vec3<T>, Fwt: fn(T, T) -> T) -> T {
        // transform to diffuse configuration
        let p1o = minv.mul_vec(p1);
        let p2o = minv.mul_vec(p2);
        let I_diffuse = I_diffuse_line(p1o, p2o, Fwt);

        // width factor
        let ortho = normalize(cross(p1, p2));
        let w = T::one() / length(inverse3(minv.transpose()).mul_vec(ortho));

        w * I_diffuse
    }
}

/// `kernels/line_ltc2023.wgsl` and `line_ltc2023_full.wgsl`: the 2023 revision.
mod ltc2023 {
    use super::*;

    /// The listing's truncated 1/π (relative error −2.6e-10: visible in f64 only).
    #[allow(clippy::approx_constant)] // deliberately the listing's constant
    pub const INV_PI: f64 = 0.3183098861;

    pub fn I_diffuse_line<T: Real>(C: Vec3<T>, A: Vec3<T>, hl: T) -> T {
        let zero = T::zero();
        let one = T::one();

        // Solve C.z + h * A.z = 0.
        let h = -C.z * (one / A.z); // May be Inf, but never NaN

        // Clip the line segment against the z-plane if necessary.
        let h2 = if A.z >= zero { hl.max(h) } else { hl.min(h) }; // P2 = C + h2 * A
        let h1 = if A.z >= zero { (-hl).max(h) } else { (-hl).min(h) }; // P1 = C + h1 * A

        // Normalize the tangent.
        let as_ = dot(A, A); // |A|^2
        let ar = inverse_sqrt(as_); // 1/|A|
        let a = as_ * ar; // |A|
        let T_ = A * ar; // A/|A|

        // Orthogonal 2D coordinates: P(n, t) = n * N + t * T.
        let tc = dot(T_, C); // C = n * N + tc * T
        let P0 = C - T_ * tc; // P(n, 0) = n * N
        let ns = dot(P0, P0); // |P0|^2

        let nr = inverse_sqrt(ns); // 1/|P0|
        let n = ns * nr; // |P0|
        let Nz = P0.z * nr; // N.z = P0.z/|P0|

        let t2 = tc + h2 * a; // P2.t
        let t1 = tc + h1 * a; // P1.t
        let s2 = ns + t2 * t2; // |P2|^2
        let s1 = ns + t1 * t1; // |P1|^2
        let mr = inverse_sqrt(s1 * s2); // 1/(|P1|*|P2|)
        let r2 = s1 * (mr * mr); // 1/|P2|^2
        let r1 = s2 * (mr * mr); // 1/|P1|^2

        let i12 = (Nz * t2 - (T_.z * n)) * r2 - (Nz * t1 - (T_.z * n)) * r1;
        // Guard against numerical errors.
        let dt = one.min((ns + t1 * t2) * mr);
        let i3 = dt.acos() * (Nz * nr); // angle * cos(θ) / r^2

        // Guard against numerical errors.
        lit::<T>(INV_PI) * zero.max(i12 + i3)
    }

    /// As published: assumes M⁻¹ = [[a,0,b],[0,c,0],[d,0,1]] and reads only a, b, c, d.
    pub fn ComputeLineWidthFactor<T: Real>(invM: Mat3<T>, ortho: Vec3<T>, orthoSq: T) -> T {
        // HLSL invM[r][c] is column c, row r here.
        let a = invM.c[0].x; // HLSL invM[0][0]
        let b = invM.c[2].x; // HLSL invM[0][2]
        let c = invM.c[1].y; // HLSL invM[1][1]
        let d = invM.c[0].z; // HLSL invM[2][0]

        let det = c * (a - b * d);
        let X = Vec3::new(
            c * (ortho.x - d * ortho.z),
            ortho.y * (a - b * d),
            c * (-b * ortho.x + a * ortho.z),
        ); // mul(cof, ortho)

        // 1 / length(1/s * X) = abs(s) / length(X).
        det.abs() * inverse_sqrt(dot(X, X) * orthoSq) * orthoSq
    }

    /// The fix for any M⁻¹: the full cofactor matrix (row i = cross of the other two rows).
    pub fn ComputeLineWidthFactor_full<T: Real>(invM: Mat3<T>, ortho: Vec3<T>, orthoSq: T) -> T {
        let rows = invM.transpose();
        let cof0 = cross(rows.c[1], rows.c[2]);
        let cof1 = cross(rows.c[2], rows.c[0]);
        let cof2 = cross(rows.c[0], rows.c[1]);

        let det = dot(rows.c[0], cof0);
        let X = Vec3::new(dot(cof0, ortho), dot(cof1, ortho), dot(cof2, ortho));

        det.abs() * inverse_sqrt(dot(X, X) * orthoSq) * orthoSq
    }

    pub fn I_ltc_line<T: Real>(
        invM: Mat3<T>,
        center: Vec3<T>,
        axis: Vec3<T>,
        halfLength: T,
        ComputeLineWidthFactor: fn(Mat3<T>, Vec3<T>, T) -> T,
    ) -> T {
        let zero = T::zero();
        let ortho = cross(center, axis);
        let orthoSq = dot(ortho, ortho);

        // Check whether the line passes through the origin.
        let mut quit = orthoSq == zero;

        // Check whether the light is entirely below the surface (before the transform).
        quit = quit || (center.z + halfLength * axis.z.abs() <= zero);

        // Transform into the diffuse configuration.
        let C = invM.mul_vec(center);
        let A = invM.mul_vec(axis);

        // Check whether the light is entirely below the surface (after the transform).
        quit = quit || (C.z + halfLength * A.z.abs() <= zero);

        let mut result = zero;

        if !quit {
            let w = ComputeLineWidthFactor(invM, ortho, orthoSq);

            result = I_diffuse_line(C, A, halfLength) * w;
        }

        result
    }

    /// The kernel's `method`: centre, unit axis and half length from the end points.
    pub fn method<T: Real>(
        minv: Mat3<T>,
        p1: Vec3<T>,
        p2: Vec3<T>,
        ComputeLineWidthFactor: fn(Mat3<T>, Vec3<T>, T) -> T,
    ) -> T {
        let half = lit::<T>(0.5);
        let center = (p1 + p2) * half;
        let axis = normalize(p2 - p1);
        let halfLength = length(p2 - p1) * half;
        I_ltc_line(minv, center, axis, halfLength, ComputeLineWidthFactor)
    }
}

/// `kernels/line_numeric_paper.wgsl` and `line_numeric.wgsl`.
mod numeric {
    use super::*;

    /// Listing 1.4 as published: 100 samples, end points included, weight L/n.
    pub fn I_line_numerical<T: Real>(minv: Mat3<T>, p1: Vec3<T>, p2: Vec3<T>) -> T {
        let L = length(p2 - p1);
        let wt = normalize(p2 - p1);

        // integral discretization
        let mut I = T::zero();
        const N_SAMPLES: i32 = 100;
        let n = |i: i32| T::from_i32(i).expect("sample index fits in T");
        for i in 0..N_SAMPLES {
            // position
            let p = p1 + wt * (L * n(i) / n(N_SAMPLES - 1));

            // normalized direction
            let wp = normalize(p);

            // integrate
            I = I + lit::<T>(2.0) * D(minv, wp) * length(cross(wp, wt)) / dot(p, p);
        }

        I * (L / n(N_SAMPLES))
    }

    /// The kernel's `SAMPLES` default.
    pub const DEFAULT_SAMPLES: u32 = 64;

    // 4-point Gauss–Legendre nodes and weights on [−1, 1].
    const GL_X0: f64 = 0.3399810435848563;
    const GL_X1: f64 = 0.8611363115940526;
    const GL_W0: f64 = 0.6521451548625461;
    const GL_W1: f64 = 0.3478548451374538;

    /// Eq. 1.6 after l = d·tan θ: 2·D(ω_p)·cos θ / d.
    fn line_integrand<T: Real>(minv: Mat3<T>, po_dir: Vec3<T>, wt: Vec3<T>, d: T, theta: T) -> T {
        let wp = po_dir * theta.cos() + wt * theta.sin();
        lit::<T>(2.0) * D(minv, wp) * theta.cos() / d
    }

    /// Composite 4-point Gauss–Legendre in θ over the part of the segment where D can be
    /// non-zero (see the kernel for why it converges fast).
    pub fn I_line_gauss<T: Real>(minv: Mat3<T>, p1: Vec3<T>, p2: Vec3<T>, samples: u32) -> T {
        let zero = T::zero();
        let wt = normalize(p2 - p1);
        let l1 = dot(p1, wt);
        let l2 = dot(p2, wt);
        let po = p1 - wt * l1;
        let d = length(po);
        // The line passes through the origin: ω_p ∥ ωt, the integrand is 0.
        if d == zero {
            return zero;
        }
        let po_dir = po / d;
        let mut theta1 = l1.atan2(d);
        let mut theta2 = l2.atan2(d);

        // D(ω) > 0 iff n·ω > 0 with n = row 2 of M⁻¹; along the line n·p ∝ a·cos θ + b·sin θ.
        let n = minv.transpose().c[2];
        let a = dot(n, po_dir);
        let b = dot(n, wt);
        if b >= zero {
            theta1 = theta1.max((-a).atan2(b));
        } else {
            theta2 = theta2.min(a.atan2(-b));
        }
        if theta2 <= theta1 {
            return zero;
        }

        let panels = (samples / 4).max(1);
        let f = |i: u32| T::from_u32(i).expect("panel index fits in T");
        let half_width = lit::<T>(0.5) * (theta2 - theta1) / f(panels);
        let integrand = |theta: T| line_integrand(minv, po_dir, wt, d, theta);
        let mut I = zero;
        for k in 0..panels {
            let mid = theta1 + (lit::<T>(2.0) * f(k) + T::one()) * half_width;
            let dx0 = lit::<T>(GL_X0) * half_width;
            let dx1 = lit::<T>(GL_X1) * half_width;
            I = I
                + lit::<T>(GL_W0) * (integrand(mid - dx0) + integrand(mid + dx0))
                + lit::<T>(GL_W1) * (integrand(mid - dx1) + integrand(mid + dx1));
        }
        I * half_width
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Material;

    fn config(p1: [f64; 3], p2: [f64; 3], material: Material) -> Config {
        Config {
            id: "t".into(),
            p1,
            p2,
            radius: None,
            rect: None,
            material,
        }
    }

    fn ltc(minv: [[f64; 3]; 3]) -> Material {
        Material::Ltc { minv }
    }

    fn rel(value: f64, reference: f64) -> f64 {
        ((value - reference) / reference).abs()
    }

    fn eval64(id: &str, params: &[u32], c: &Config) -> f64 {
        evaluate::<f64>(id, params, c).unwrap()
    }

    /// Isotropic-GGX-shaped (sparse) M⁻¹.
    const SPARSE: [[[f64; 3]; 3]; 2] = [
        [[0.5, 0.0, 0.1], [0.0, 0.6, 0.0], [-0.2, 0.0, 1.0]],
        [[1.8, 0.0, -0.4], [0.0, 1.5, 0.0], [0.3, 0.0, 1.0]],
    ];
    /// A full (anisotropic) M⁻¹.
    const FULL: [[f64; 3]; 3] = [[0.7, 0.15, 0.1], [-0.1, 0.6, 0.05], [-0.2, 0.1, 1.0]];

    /// Well-conditioned segments (distance ~1, length ~1); the last crosses the horizon.
    const SEGMENTS: [([f64; 3], [f64; 3]); 4] = [
        ([0.3, -0.2, 1.0], [0.9, 0.4, 1.6]),
        ([-0.5, 0.3, 1.0], [0.8, -0.2, 1.4]),
        ([-1.0, -0.7, 0.6], [0.4, 1.1, 0.9]),
        ([0.2, 0.1, -0.3], [0.5, 0.4, 1.2]),
    ];

    fn materials() -> Vec<Material> {
        let mut m = vec![Material::Diffuse];
        m.extend(SPARSE.map(ltc));
        m.push(ltc(FULL));
        m
    }

    /// The 2023 listing's INV_PI = 0.3183098861 is 1/π truncated to 10 digits; this
    /// factor takes it out so the formulas themselves can be compared in f64.
    fn inv_pi_correction() -> f64 {
        std::f64::consts::FRAC_1_PI / ltc2023::INV_PI
    }

    #[test]
    fn analytic_forms_agree_in_f64() {
        let mut worst = std::collections::BTreeMap::new();
        for material in materials() {
            for (p1, p2) in SEGMENTS {
                let c = config(p1, p2, material.clone());
                let v2017 = eval64("line.ltc2017", &[], &c);
                assert!(v2017 > 1e-3, "{c:?}: {v2017}");
                let mut ids = vec!["line.ltc2017_fwt", "line.ltc2023_full"];
                if material.is_sparse() {
                    ids.push("line.ltc2023");
                }
                for id in ids {
                    let mut value = eval64(id, &[], &c);
                    if id.starts_with("line.ltc2023") {
                        // See ltc2023_inv_pi_constant_shows_in_f64.
                        value *= inv_pi_correction();
                    }
                    let e = rel(value, v2017);
                    assert!(e < 1e-10, "{c:?}: {id} {value} vs ltc2017 {v2017}");
                    let w = worst.entry(id).or_insert(0.0f64);
                    *w = w.max(e);
                }
            }
        }
        for (id, e) in worst {
            eprintln!("worst f64 relative difference {id} vs ltc2017: {e:.1e}");
        }
    }

    #[test]
    fn ltc2023_inv_pi_constant_shows_in_f64() {
        // Everything else being equal, the 2023 forms sit exactly at π·INV_PI − 1 from 2017.
        let expected = std::f64::consts::PI * ltc2023::INV_PI - 1.0;
        assert!(expected < -2.5e-10 && expected > -2.7e-10);
        let c = config(SEGMENTS[0].0, SEGMENTS[0].1, ltc(SPARSE[0]));
        let v2017 = eval64("line.ltc2017", &[], &c);
        for id in ["line.ltc2023", "line.ltc2023_full"] {
            let offset = eval64(id, &[], &c) / v2017 - 1.0;
            assert!((offset - expected).abs() < 2e-12, "{id}: {offset:e} vs {expected:e}");
        }
    }

    #[test]
    fn numeric_converges_to_the_analytic_forms_in_f64() {
        let mut worst = 0.0f64;
        for material in materials() {
            for (p1, p2) in SEGMENTS {
                let c = config(p1, p2, material.clone());
                let analytic = eval64("line.ltc2017", &[], &c);
                let numeric = eval64("line.numeric", &[256], &c);
                let e = rel(numeric, analytic);
                assert!(e < 1e-9, "{c:?}: numeric@256 {numeric} vs ltc2017 {analytic}");
                worst = worst.max(e);
            }
        }
        eprintln!("worst f64 relative difference numeric@256/ltc2017: {worst:.1e}");
    }

    #[test]
    fn numeric_default_and_parameter() {
        let c = config(SEGMENTS[1].0, SEGMENTS[1].1, ltc(SPARSE[1]));
        let default = eval64("line.numeric", &[], &c);
        assert_eq!(default, eval64("line.numeric", &[numeric::DEFAULT_SAMPLES], &c));
        // One 4-point panel is a different (coarser) rule.
        assert_ne!(default, eval64("line.numeric", &[4], &c));
        // Below 4 samples it still uses one panel.
        assert_eq!(eval64("line.numeric", &[1], &c), eval64("line.numeric", &[4], &c));
    }

    #[test]
    fn ltc2023_is_wrong_for_a_full_minv() {
        // The published ComputeLineWidthFactor reads only a, b, c, d of a sparse M⁻¹.
        for (p1, p2) in SEGMENTS {
            let c = config(p1, p2, ltc(FULL));
            let sparse = eval64("line.ltc2023", &[], &c);
            let full = eval64("line.ltc2023_full", &[], &c);
            let e = rel(sparse, full);
            eprintln!("full M⁻¹, {p1:?}–{p2:?}: ltc2023 {sparse:.9} ltc2023_full {full:.9} ({e:.1e})");
            // Far above the 1e-15 agreement of the analytic forms in f64.
            assert!(e > 1e-6, "{c:?}: ltc2023 {sparse} vs ltc2023_full {full}");
        }
    }

    #[test]
    fn numeric_paper_is_close_on_a_benign_configuration() {
        let c = config([-0.5, 0.3, 1.0], [0.5, 0.1, 1.2], Material::Diffuse);
        let paper = eval64("line.numeric_paper", &[], &c);
        let analytic = eval64("line.ltc2017_fwt", &[], &c);
        let e = rel(paper, analytic);
        eprintln!("numeric_paper {paper} vs analytic {analytic}: {e:.2e}");
        assert!(e < 0.05);
    }

    /// Relative error of the f32 port against an f64 reference.
    fn rel32(id: &str, c: &Config, reference: f64) -> f64 {
        rel(evaluate::<f32>(id, &[], c).unwrap() as f64, reference)
    }

    #[test]
    fn ltc2017_f32_cancels_far_along_the_line_and_fwt_holds() {
        // d = 1, a nearly vertical line (po.z = cos 1.55, so the Fpo term, which cancels
        // too, weighs little), the segment at l ∈ [1000, 3000]: the published Fwt tends to
        // 1/d at both ends and Fwt(l2) − Fwt(l1) keeps few significant bits in f32.
        let (s, c) = (1.55f64.sin(), 1.55f64.cos());
        let (po, wt) = ([-s, 0.0, c], [c, 0.0, s]);
        let at = |l: f64| [po[0] + l * wt[0], po[1] + l * wt[1], po[2] + l * wt[2]];
        let cfg = config(at(1000.0), at(3000.0), Material::Diffuse);
        let reference = eval64("line.numeric", &[256], &cfg);
        let (e2017, efwt) = (
            rel32("line.ltc2017", &cfg, reference),
            rel32("line.ltc2017_fwt", &cfg, reference),
        );
        eprintln!("l/d in [1000, 3000], reference {reference:e}: f32 relative error ltc2017 {e2017:.2e}, ltc2017_fwt {efwt:.2e}");
        assert!(efwt < e2017);
    }

    #[test]
    fn ltc2023_f32_loses_accuracy_when_the_light_subtends_a_small_angle() {
        // The 2023 listing replaces atan(l2/d) − atan(l1/d) by acos(P1·P2/(|P1||P2|)); for
        // a subtended angle Δ the argument is 1 − Δ²/2 and f32 rounding of it costs about
        // ε/Δ² relative. Here a 1 cm segment ~1.06 m away (Δ ≈ 0.008).
        let cfg = config([0.3, -0.2, 1.0], [0.306, -0.194, 1.0052915], Material::Diffuse);
        let reference = eval64("line.numeric", &[256], &cfg);
        let (e2023, efwt) = (
            rel32("line.ltc2023", &cfg, reference),
            rel32("line.ltc2017_fwt", &cfg, reference),
        );
        eprintln!(
            "short light, reference {reference:e}: f32 relative error ltc2023 {e2023:.2e}, ltc2017_fwt {efwt:.2e}"
        );
        assert!(e2023 > 10.0 * efwt);
    }

    #[test]
    fn ltc2023_returns_zero_for_a_light_below_the_surface_that_the_lobe_sees() {
        // The listing's first quit test (before the transform) removes the part of the
        // leak where the whole light is below the surface; `line` counts it.
        let cfg = config([-2.0, -0.5, -0.1], [-1.5, 0.5, -0.05], ltc(SPARSE[0]));
        let line = eval64("line.numeric", &[256], &cfg);
        assert!(rel(eval64("line.ltc2017", &[], &cfg), line) < 1e-12 && line > 0.1);
        assert_eq!(eval64("line.ltc2023", &[], &cfg), 0.0);
    }

    #[test]
    fn ports_match_the_kernel_files() {
        let kernels = [
            include_str!("../../kernels/line_ltc2017.wgsl"),
            include_str!("../../kernels/line_ltc2017_fwt.wgsl"),
            include_str!("../../kernels/line_ltc2023.wgsl"),
            include_str!("../../kernels/line_ltc2023_full.wgsl"),
            include_str!("../../kernels/line_numeric_paper.wgsl"),
            include_str!("../../kernels/line_numeric.wgsl"),
        ];
        for (id, text) in PORTED.iter().zip(kernels) {
            assert!(text.starts_with(&format!("//! id: {id}\n")), "{id}");
            assert!(has_port(id));
        }
        let params = format!("//! params: SAMPLES={}\n", numeric::DEFAULT_SAMPLES);
        assert!(kernels[5].contains(&params));
        assert!(kernels[5].contains(&format!("override SAMPLES: u32 = {};", numeric::DEFAULT_SAMPLES)));
        assert!(kernels[2].contains(&format!("const INV_PI: f32 = {};", ltc2023::INV_PI)));
        assert!(!has_port("line.user"));
        let c = config(SEGMENTS[0].0, SEGMENTS[0].1, Material::Diffuse);
        assert_eq!(evaluate::<f32>("line.user", &[], &c), None);
    }
}
