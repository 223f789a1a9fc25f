//! CPU ports of the built-in kernels (`kernels/line_*.wgsl`, `cylinder_*`, `caps_*`,
//! `tube_*`, `rectangle_*`), generic over the float type.
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

/// Method ids with a CPU port in [`evaluate`] (one kernel file each).
pub const PORTED: [&str; 12] = [
    "line.ltc2017",
    "line.ltc2017_fwt",
    "line.ltc2023",
    "line.ltc2023_full",
    "line.ltc2023_fix",
    "line.numeric_paper",
    "line.numeric",
    "cylinder.numeric_paper",
    "cylinder.numeric",
    "caps.numeric_paper",
    "caps.point",
    "rectangle.numeric",
];

/// Composite method ids (`//! uses: line`) with a CPU port in [`evaluate_composite`].
pub const PORTED_COMPOSITE: [&str; 4] = ["cylinder.line", "tube.line", "rectangle.line", "rectangle.line_fixed"];

pub fn has_port(id: &str) -> bool {
    PORTED.contains(&id) || PORTED_COMPOSITE.contains(&id)
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
        "line.ltc2023" => ltc2023::method(minv, p1, p2, ltc2023::ComputeLineWidthFactor, ltc2023::angle_acos),
        "line.ltc2023_full" => ltc2023::method(minv, p1, p2, ltc2023::ComputeLineWidthFactor_full, ltc2023::angle_acos),
        "line.ltc2023_fix" => ltc2023::method(minv, p1, p2, ltc2023::ComputeLineWidthFactor_full, ltc2023::angle_atan2),
        "line.numeric_paper" => numeric::I_line_numerical(minv, p1, p2),
        "line.numeric" => {
            let samples = params.first().copied().unwrap_or(numeric::DEFAULT_SAMPLES);
            numeric::I_line_gauss(minv, p1, p2, samples)
        }
        "cylinder.numeric_paper" => listing_1_2::I_cylinder_numerical(minv, p1, p2, radius(config)),
        "cylinder.numeric" => {
            let nphi = params.first().copied().unwrap_or(surface::DEFAULT_NPHI);
            let nl = params.get(1).copied().unwrap_or(surface::DEFAULT_NL);
            surface::I_cylinder_gauss(minv, p1, p2, radius(config), nphi, nl)
        }
        "caps.numeric_paper" => listing_1_8::I_disks_numerical(minv, p1, p2, radius(config)),
        "caps.point" => listing_1_9::I_ltc_disks(minv, p1, p2, radius(config)),
        "rectangle.numeric" => {
            let nw = params.first().copied().unwrap_or(surface::DEFAULT_NW);
            let nl = params.get(1).copied().unwrap_or(surface::DEFAULT_NL);
            let (wn, width) = rect(config);
            surface::I_rectangle_gauss(minv, p1, p2, wn, width, nw, nl)
        }
        _ => return None,
    };
    Some(value)
}

/// Composite methods (`//! uses: line`): `i_line` is the inner line method's port.
pub fn evaluate_composite<T: Real>(
    id: &str,
    params: &[u32],
    config: &crate::scene::Config,
    i_line: &dyn Fn([T; 3], [T; 3]) -> T,
) -> Option<T> {
    let _ = params; // none of the composites has parameters
    let p1 = Vec3::from_f64(config.p1);
    let p2 = Vec3::from_f64(config.p2);
    let minv = Mat3::from_rows(config.material.minv());
    let I_line = |a: Vec3<T>, b: Vec3<T>| i_line([a.x, a.y, a.z], [b.x, b.y, b.z]);
    let half = lit::<T>(0.5);
    let value = match id {
        "cylinder.line" => composite::I_cylinder_approx(p1, p2, radius(config), &I_line),
        "tube.line" => composite::tube(minv, p1, p2, radius(config), &I_line),
        "rectangle.line" => {
            let (wn, width) = rect(config);
            half * width * composite::I_ltc_line_rectangle(p1, p2, wn, &I_line)
        }
        "rectangle.line_fixed" => {
            let (wn, width) = rect(config);
            half * width * composite::I_line_rectangle_fixed(p1, p2, wn, &I_line)
        }
        _ => return None,
    };
    Some(value)
}

/// `scene.radius` in `T`: 0 when the configuration has none, as in `GpuScene`.
fn radius<T: Real>(config: &Config) -> T {
    lit(config.radius.unwrap_or(0.0))
}

/// `scene.rect_normal` and `scene.rect_width` in `T`: zeros when there is no rectangle.
fn rect<T: Real>(config: &Config) -> (Vec3<T>, T) {
    match &config.rect {
        Some(r) => (Vec3::from_f64(r.normal), lit(r.width)),
        None => (Vec3::from_f64([0.0; 3]), T::zero()),
    }
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

    /// The angle between P1 and P2 as the listing takes it: acos of the clamped cosine.
    pub fn angle_acos<T: Real>(ns: T, t1: T, t2: T, mr: T, _n: T) -> T {
        // Guard against numerical errors.
        let dt = T::one().min((ns + t1 * t2) * mr);
        dt.acos()
    }

    /// The fix (`line.ltc2023_fix`): atan2(|P1 × P2|, P1 · P2) = atan2(n (t2 − t1), ns + t1 t2),
    /// accurate at every angle where acos of a cosine near 1 loses ~ε/Δ².
    pub fn angle_atan2<T: Real>(ns: T, t1: T, t2: T, _mr: T, n: T) -> T {
        (n * (t2 - t1)).atan2(ns + t1 * t2)
    }

    pub fn I_diffuse_line<T: Real>(C: Vec3<T>, A: Vec3<T>, hl: T, angle: fn(T, T, T, T, T) -> T) -> T {
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
        let i3 = angle(ns, t1, t2, mr, n) * (Nz * nr); // angle * cos(θ) / r^2

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
        angle: fn(T, T, T, T, T) -> T,
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

            result = I_diffuse_line(C, A, halfLength, angle) * w;
        }

        result
    }

    /// The kernel's `method`: centre, unit axis and half length from the end points.
    pub fn method<T: Real>(
        minv: Mat3<T>,
        p1: Vec3<T>,
        p2: Vec3<T>,
        ComputeLineWidthFactor: fn(Mat3<T>, Vec3<T>, T) -> T,
        angle: fn(T, T, T, T, T) -> T,
    ) -> T {
        let half = lit::<T>(0.5);
        let center = (p1 + p2) * half;
        let axis = normalize(p2 - p1);
        let halfLength = length(p2 - p1) * half;
        I_ltc_line(minv, center, axis, halfLength, ComputeLineWidthFactor, angle)
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
    pub(super) const GL_X0: f64 = 0.3399810435848563;
    pub(super) const GL_X1: f64 = 0.8611363115940526;
    pub(super) const GL_W0: f64 = 0.6521451548625461;
    pub(super) const GL_W1: f64 = 0.3478548451374538;

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
            // WGSL `I += a + b` is I + (a + b).
            I = I
                + (lit::<T>(GL_W0) * (integrand(mid - dx0) + integrand(mid + dx0))
                    + lit::<T>(GL_W1) * (integrand(mid - dx1) + integrand(mid + dx1)));
        }
        I * half_width
    }
}

/// Listing 1.3 as in the prelude: an orthonormal basis (b1, b2) completing the unit `n`.
fn buildOrthonormalBasis<T: Real>(n: Vec3<T>) -> (Vec3<T>, Vec3<T>) {
    let (zero, one) = (T::zero(), T::one());
    if n.z < lit(-0.9999999) {
        return (Vec3::new(zero, -one, zero), Vec3::new(-one, zero, zero));
    }
    let a = one / (one + n.z);
    let b = -n.x * n.y * a;
    (
        Vec3::new(one - n.x * n.x * a, b, -n.x),
        Vec3::new(b, one - n.y * n.y * a, -n.y),
    )
}

/// A loop index in `T` (WGSL `f32(i)`).
fn idx<T: Real>(i: i32) -> T {
    T::from_i32(i).expect("sample index fits in T")
}

/// `kernels/cylinder_numeric_paper.wgsl`: Listing 1.2 as published (20 × 100 samples,
/// l = L·j/(n−1) with weight L/n, φ = 2π·i/n).
mod listing_1_2 {
    use super::*;

    pub fn I_cylinder_numerical<T: Real>(minv: Mat3<T>, p1: Vec3<T>, p2: Vec3<T>, R: T) -> T {
        // init orthonormal basis
        let L = length(p2 - p1);
        let wt = normalize(p2 - p1);
        let (wt1, wt2) = buildOrthonormalBasis(wt);

        // integral discretization
        let mut I = T::zero();
        const N_SAMPLES_PHI: i32 = 20;
        const N_SAMPLES_L: i32 = 100;
        for i in 0..N_SAMPLES_PHI {
            for j in 0..N_SAMPLES_L {
                // normal
                let phi = lit::<T>(2.0) * T::PI() * idx(i) / idx(N_SAMPLES_PHI);
                let wn = wt1 * phi.cos() + wt2 * phi.sin();

                // position
                let l = L * idx(j) / idx(N_SAMPLES_L - 1);
                let p = p1 + wt * l + wn * R;

                // normalized direction
                let wp = normalize(p);

                // integrate
                I = I + D(minv, wp) * T::zero().max(dot(-wp, wn)) / dot(p, p);
            }
        }

        I * (lit::<T>(2.0) * T::PI() * R * L / idx(N_SAMPLES_PHI * N_SAMPLES_L))
    }
}

/// `kernels/caps_numeric_paper.wgsl`: Listing 1.8 as published (20 × 200 samples,
/// r = R·j/(n−1) with weight R/n, φ = 2π·i/n).
mod listing_1_8 {
    use super::*;

    pub fn I_disks_numerical<T: Real>(minv: Mat3<T>, p1: Vec3<T>, p2: Vec3<T>, R: T) -> T {
        let zero = T::zero();
        // init orthonormal basis (the listing's `L` is never used)
        let wt = normalize(p2 - p1);
        let (wt1, wt2) = buildOrthonormalBasis(wt);

        // integration
        let mut Idisks = zero;
        const N_SAMPLES_PHI: i32 = 20;
        const N_SAMPLES_R: i32 = 200;
        for i in 0..N_SAMPLES_PHI {
            for j in 0..N_SAMPLES_R {
                let phi = lit::<T>(2.0) * T::PI() * idx(i) / idx(N_SAMPLES_PHI);
                let r = R * idx(j) / idx(N_SAMPLES_R - 1);

                let p = p1 + (wt1 * phi.cos() + wt2 * phi.sin()) * r;
                let wp = normalize(p);
                Idisks = Idisks + r * D(minv, wp) * zero.max(dot(wp, wt)) / dot(p, p);

                let p = p2 + (wt1 * phi.cos() + wt2 * phi.sin()) * r;
                let wp = normalize(p);
                Idisks = Idisks + r * D(minv, wp) * zero.max(dot(wp, -wt)) / dot(p, p);
            }
        }

        Idisks * (lit::<T>(2.0) * T::PI() * R / idx(N_SAMPLES_R * N_SAMPLES_PHI))
    }
}

/// `kernels/caps_point.wgsl` (and inlined in `tube_line.wgsl`): Listing 1.9.
mod listing_1_9 {
    use super::*;

    pub fn I_ltc_disks<T: Real>(minv: Mat3<T>, p1: Vec3<T>, p2: Vec3<T>, R: T) -> T {
        let zero = T::zero();
        let A = T::PI() * R * R;
        let wt = normalize(p2 - p1);
        let wp1 = normalize(p1);
        let wp2 = normalize(p2);
        A * (D(minv, wp1) * zero.max(dot(wt, wp1)) / dot(p1, p1) + D(minv, wp2) * zero.max(dot(-wt, wp2)) / dot(p2, p2))
    }
}

/// `kernels/cylinder_numeric.wgsl` and `rectangle_numeric.wgsl`: composite Gauss–Legendre
/// in angles seen from the origin (see the kernels for the rule and why it converges).
mod surface {
    use super::numeric::{GL_W0, GL_W1, GL_X0, GL_X1};
    use super::*;

    /// The kernels' `NPHI`, `NW` and `NL` defaults.
    pub const DEFAULT_NPHI: u32 = 32;
    pub const DEFAULT_NW: u32 = 8;
    pub const DEFAULT_NL: u32 = 64;

    fn f<T: Real>(i: u32) -> T {
        T::from_u32(i).expect("panel index fits in T")
    }

    /// Row 2 of M⁻¹: D(ω) > 0 iff n·ω > 0.
    fn support<T: Real>(minv: Mat3<T>) -> Vec3<T> {
        minv.transpose().c[2]
    }

    /// `cyl_integrand` / `rect_integrand`: D(ω)·cos θ at ω = cos τ·wm + sin τ·wq, cos θ = ω·g.
    fn integrand<T: Real>(minv: Mat3<T>, wm: Vec3<T>, wq: Vec3<T>, g: Vec3<T>, tau: T) -> T {
        let w = wm * tau.cos() + wq * tau.sin();
        D(minv, w) * dot(w, g)
    }

    /// `cyl_generator` / `rect_strip`: ∫ D(cos θ·g + sin θ·ωt) cos θ dθ from s1 to s2 = s1 + L
    /// along the line with unit foot direction g at distance rho, where D can be non-zero;
    /// τ = θ − θm from the bisector wm of the directions to the ends, towards ωt (wq).
    /// The kernel's half-span is `cyl_angle`/`rect_angle`, a portable f32 atan2 (GPU atan2
    /// may be 4096 ULP off); the port uses the atan2 it approximates (to ~2e-7).
    #[allow(clippy::too_many_arguments)] // the kernel's signature, plus M⁻¹ and the count
    fn generator<T: Real>(minv: Mat3<T>, g: Vec3<T>, wt: Vec3<T>, rho: T, s1: T, s2: T, L: T, nl: u32) -> T {
        let zero = T::zero();
        let wm = normalize(normalize(g * rho + wt * s1) + normalize(g * rho + wt * s2));
        let wq = cross(cross(g, wt), wm);
        let half = lit::<T>(0.5) * (L * rho).atan2(rho * rho + s1 * s2);
        let mut lo = -half;
        let mut hi = half;
        let n = support(minv);
        let a = dot(n, wm);
        let b = dot(n, wq);
        if b >= zero {
            lo = lo.max((-a).atan2(b));
        } else {
            hi = hi.min(a.atan2(-b));
        }
        if hi <= lo {
            return zero;
        }
        let panels = (nl / 4).max(1);
        let hw = lit::<T>(0.5) * (hi - lo) / f(panels);
        let at = |tau: T| integrand(minv, wm, wq, g, tau);
        let mut I = zero;
        for k in 0..panels {
            let mid = lo + (lit::<T>(2.0) * f(k) + T::one()) * hw;
            let dx0 = lit::<T>(GL_X0) * hw;
            let dx1 = lit::<T>(GL_X1) * hw;
            I = I
                + (lit::<T>(GL_W0) * (at(mid - dx0) + at(mid + dx0))
                    + lit::<T>(GL_W1) * (at(mid - dx1) + at(mid + dx1)));
        }
        I * hw
    }

    /// Sorts `bounds[..m]` in place (the kernels' insertion sort).
    fn insertion_sort<T: Real>(bounds: &mut [T]) {
        for i in 1..bounds.len() {
            let v = bounds[i];
            let mut j = i;
            while j > 0 && bounds[j - 1] > v {
                bounds[j] = bounds[j - 1];
                j -= 1;
            }
            bounds[j] = v;
        }
    }

    /// Composite 4-point Gauss–Legendre of `column` over the sorted `bounds`, `density`
    /// panels per unit length shared out by piece (at least one each).
    fn pieces<T: Real>(bounds: &[T], density: T, column: impl Fn(T) -> T) -> T {
        let mut I = T::zero();
        for piece in bounds.windows(2) {
            let (v1, v2) = (piece[0], piece[1]);
            if v2 <= v1 {
                continue;
            }
            let panels = (density * (v2 - v1) + lit(0.5)).floor().to_u32().unwrap_or(0).max(1);
            let hw = lit::<T>(0.5) * (v2 - v1) / f(panels);
            let mut sum = T::zero();
            for pk in 0..panels {
                let mid = v1 + (lit::<T>(2.0) * f(pk) + T::one()) * hw;
                let dx0 = lit::<T>(GL_X0) * hw;
                let dx1 = lit::<T>(GL_X1) * hw;
                sum = sum
                    + (lit::<T>(GL_W0) * (column(mid - dx0) + column(mid + dx0))
                        + lit::<T>(GL_W1) * (column(mid - dx1) + column(mid + dx1)));
            }
            I = I + sum * hw;
        }
        I
    }

    /// What `cyl_column` takes besides u: the frame (x towards the axis, y = ωt × x, ωt),
    /// the axis distance d, R, and the end abscissae l1, l2 = l1 + L from the foot.
    #[derive(Clone, Copy)]
    struct Tube<T> {
        x: Vec3<T>,
        y: Vec3<T>,
        wt: Vec3<T>,
        d: T,
        R: T,
        l1: T,
        l2: T,
        L: T,
    }

    /// `cyl_column`: (dα/du)·(the generator integral) at u, α = asin((R/d)·sin u).
    fn cyl_column<T: Real>(minv: Mat3<T>, u: T, c: Tube<T>, nl: u32) -> T {
        let Tube {
            x,
            y,
            wt,
            d,
            R,
            l1,
            l2,
            L,
        } = c;
        let k = R / d;
        let gap2 = (d - R) * (d + R);
        let su = u.sin();
        let cu = u.cos();
        let sa = k * su;
        let ca = (cu * cu + gap2 / (d * d) * su * su).sqrt();
        let rho = gap2 / (d * ca + R * cu);
        let g = x * ca + y * sa;
        k * cu / ca * generator(minv, g, wt, rho, l1, l2, L, nl)
    }

    pub fn I_cylinder_gauss<T: Real>(minv: Mat3<T>, p1: Vec3<T>, p2: Vec3<T>, R: T, nphi: u32, nl: u32) -> T {
        let zero = T::zero();
        let pi = T::PI();
        let L = length(p2 - p1);
        let wt = normalize(p2 - p1);
        let l1 = dot(p1, wt);
        let l2 = dot(p2, wt);
        let po = p1 - wt * l1;
        let d = length(po);
        // Within R of the axis line (beyond an end): no point of the side faces the origin.
        if d <= R {
            return zero;
        }
        let x = po / d;
        let y = cross(wt, x);

        // Cuts where the support plane of D crosses a rim, on the facing arc |δ| < β.
        let n = support(minv);
        let beta = (R / d).acos();
        let B = -R * dot(n, x);
        let C = R * dot(n, y);
        let H = (B * B + C * C).sqrt();
        let half_pi = lit::<T>(std::f64::consts::FRAC_PI_2);
        let mut bounds = [zero; 6];
        bounds[0] = -half_pi;
        let mut m = 1;
        for e in 0..2 {
            let s_end = if e == 1 { l2 } else { l1 };
            let A = dot(n, po) + s_end * dot(n, wt);
            if H > A.abs() {
                let psi = C.atan2(B);
                let c = (-A / H).acos();
                for s in 0..2 {
                    let mut delta = if s == 1 { psi + c } else { psi - c };
                    if delta > pi {
                        delta = delta - lit::<T>(2.0) * pi;
                    }
                    if delta < -pi {
                        delta = delta + lit::<T>(2.0) * pi;
                    }
                    if delta.abs() < beta {
                        // The rim point's u: sin α / k = d sin δ / ρ.
                        let gx = d - R * delta.cos();
                        let gy = R * delta.sin();
                        let sin_u = d * delta.sin() / (gx * gx + gy * gy).sqrt();
                        bounds[m] = sin_u.max(-T::one()).min(T::one()).asin();
                        m += 1;
                    }
                }
            }
        }
        bounds[m] = half_pi;
        m += 1;
        insertion_sort(&mut bounds[..m]);

        let tube = Tube {
            x,
            y,
            wt,
            d,
            R,
            l1,
            l2,
            L,
        };
        let density = f::<T>((nphi / 4).max(1)) / pi;
        pieces(&bounds[..m], density, |u| cyl_column(minv, u, tube, nl))
    }

    pub fn I_rectangle_gauss<T: Real>(
        minv: Mat3<T>,
        p1: Vec3<T>,
        p2: Vec3<T>,
        wn_in: Vec3<T>,
        W: T,
        nw: u32,
        nl: u32,
    ) -> T {
        let zero = T::zero();
        let L = length(p2 - p1);
        let wt = normalize(p2 - p1);
        let wb = normalize(cross(wn_in, wt));
        let wn = cross(wt, wb);
        let h = dot(p1, wn);
        if h == zero {
            return zero;
        }
        let ah = h.abs();
        let e = if h > zero { wn } else { -wn };
        let l1 = dot(p1, wt);
        let l2 = dot(p2, wt);
        let y1 = dot(p1, wb) - lit::<T>(0.5) * W;
        let y2 = y1 + W;
        // t = ψ − ψm from the bisector gm of the directions to the long edges' feet.
        let gm = normalize(normalize(wn * h + wb * y1) + normalize(wn * h + wb * y2));
        let gq = cross(cross(e, wb), gm);
        let half = lit::<T>(0.5) * (W * ah).atan2(ah * ah + y1 * y2); // rect_angle

        // Cuts where the support plane of D crosses a short edge.
        let n = support(minv);
        let nb = dot(n, wb);
        let mut bounds = [zero; 4];
        bounds[0] = -half;
        let mut m = 1;
        if nb != zero {
            for end in 0..2 {
                let s_end = if end == 1 { l2 } else { l1 };
                let Y = -(h * dot(n, wn) + s_end * dot(n, wt)) / nb;
                let c = wn * h + wb * Y;
                let t = dot(c, gq).atan2(dot(c, gm));
                if t > -half && t < half {
                    bounds[m] = t;
                    m += 1;
                }
            }
        }
        bounds[m] = half;
        m += 1;
        insertion_sort(&mut bounds[..m]);

        let density = f::<T>((nw / 4).max(1)) / (lit::<T>(2.0) * half);
        pieces(&bounds[..m], density, |t| {
            // rect_column
            let g = gm * t.cos() + gq * t.sin();
            let rho = ah / dot(g, e);
            generator(minv, g, wt, rho, l1, l2, L, nl)
        })
    }
}

/// The composites (`//! uses: line`): `cylinder_line.wgsl`, `tube_line.wgsl`,
/// `rectangle_line.wgsl`, `rectangle_line_fixed.wgsl`. `I_line` is the inner method's port.
mod composite {
    use super::*;

    /// Listing 1.5 (its `float p2` is a typo for `vec3 p2`).
    pub fn I_cylinder_approx<T: Real>(p1: Vec3<T>, p2: Vec3<T>, R: T, I_line: &dyn Fn(Vec3<T>, Vec3<T>) -> T) -> T {
        T::one().min(R * I_line(p1, p2))
    }

    /// Section 1.5.3: min(1, R·I_line + Listing 1.9).
    pub fn tube<T: Real>(minv: Mat3<T>, p1: Vec3<T>, p2: Vec3<T>, R: T, I_line: &dyn Fn(Vec3<T>, Vec3<T>) -> T) -> T {
        T::one().min(R * I_line(p1, p2) + listing_1_9::I_ltc_disks(minv, p1, p2, R))
    }

    /// Listing 1.11 (the caller scales by W/2).
    pub fn I_ltc_line_rectangle<T: Real>(
        p1: Vec3<T>,
        p2: Vec3<T>,
        wn: Vec3<T>,
        I_line: &dyn Fn(Vec3<T>, Vec3<T>) -> T,
    ) -> T {
        let wortho = normalize(cross(p1, p2));
        dot(wortho, wn).abs() * I_line(p1, p2)
    }

    /// Listing 1.11 with the width direction ωb = normalize(ωn × ωt) in place of ωn.
    pub fn I_line_rectangle_fixed<T: Real>(
        p1: Vec3<T>,
        p2: Vec3<T>,
        wn: Vec3<T>,
        I_line: &dyn Fn(Vec3<T>, Vec3<T>) -> T,
    ) -> T {
        let wortho = normalize(cross(p1, p2));
        let wb = normalize(cross(wn, normalize(p2 - p1)));
        dot(wortho, wb).abs() * I_line(p1, p2)
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

    // ---- surfaces: cylinder, caps, tube, rectangle ----

    use crate::reference::reference;
    use crate::scene::Rect;
    use crate::target::Target;

    fn with_radius(p1: [f64; 3], p2: [f64; 3], material: Material, r: f64) -> Config {
        Config {
            radius: Some(r),
            ..config(p1, p2, material)
        }
    }

    fn with_rect(p1: [f64; 3], p2: [f64; 3], material: Material, normal: [f64; 3], width: f64) -> Config {
        Config {
            rect: Some(Rect { normal, width }),
            ..config(p1, p2, material)
        }
    }

    fn sub3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
    }
    fn dot3(a: [f64; 3], b: [f64; 3]) -> f64 {
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    }
    fn cross3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    }
    fn unit3(a: [f64; 3]) -> [f64; 3] {
        let l = dot3(a, a).sqrt();
        [a[0] / l, a[1] / l, a[2] / l]
    }

    /// Distance from the origin to the segment's line.
    fn axis_distance(p1: [f64; 3], p2: [f64; 3]) -> f64 {
        let t = unit3(sub3(p2, p1));
        let c = cross3(p1, t);
        dot3(c, c).sqrt()
    }

    /// A unit rectangle normal ⟂ the segment, turned by `angle` about it from the normal
    /// of the plane through the origin and the segment.
    fn rect_normal(p1: [f64; 3], p2: [f64; 3], angle: f64) -> [f64; 3] {
        let t = unit3(sub3(p2, p1));
        let perp = unit3(cross3(p1, p2)); // ω⊥
        let u = cross3(perp, t);
        let (s, c) = angle.sin_cos();
        [0, 1, 2].map(|k| c * perp[k] + s * u[k])
    }

    /// A composite's f64 port with `inner` as its line method.
    fn composite64(id: &str, c: &Config, inner: &str) -> f64 {
        let i_line = |a: [f64; 3], b: [f64; 3]| {
            let segment = Config {
                p1: a,
                p2: b,
                ..c.clone()
            };
            eval64(inner, &[], &segment)
        };
        evaluate_composite::<f64>(id, &[], c, &i_line).unwrap()
    }

    /// The reference when it is there and tight, else None (the other integrals still test).
    fn reference64(c: &Config, target: Target) -> Option<f64> {
        let e = reference(c, target)?;
        (e.error <= 1e-9 * e.value.abs().max(1e-12)).then_some(e.value)
    }

    /// Relative differences, shown as `[1.2e-3, …]`.
    struct Sci(Vec<f64>);

    impl std::fmt::Debug for Sci {
        fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            let items: Vec<String> = self.0.iter().map(|x| format!("{x:.1e}")).collect();
            write!(f, "[{}]", items.join(", "))
        }
    }

    impl std::ops::Deref for Sci {
        type Target = [f64];
        fn deref(&self) -> &[f64] {
            &self.0
        }
    }

    /// (NPHI, NL) or (NW, NL) pairs, each doubling both.
    const LADDER: [[u32; 2]; 5] = [[8, 16], [16, 32], [32, 64], [64, 128], [128, 256]];

    /// Successive differences of a method over `LADDER`, relative to the last value.
    fn ladder(id: &str, c: &Config) -> (f64, Sci) {
        let values: Vec<f64> = LADDER.iter().map(|p| eval64(id, p, c)).collect();
        let last = *values.last().unwrap();
        let steps = values.windows(2).map(|w| ((w[1] - w[0]) / last).abs()).collect();
        (last, Sci(steps))
    }

    /// Asserts that `steps` (successive differences) fall fast to the f64 floor.
    fn assert_converges(what: &str, steps: &Sci) {
        let n = steps.len();
        // The last two refinements change little (h⁸: ×256 per doubling once resolved), and
        // the one before that changed far more than the last (or was already at the floor).
        assert!(steps[n - 1] < 1e-11 && steps[n - 2] < 1e-8, "{what}: {steps:?}");
        assert!(
            steps[n - 3] > 1e3 * steps[n - 1] || steps[n - 3] < 1e-12,
            "{what}: {steps:?}"
        );
    }

    #[test]
    fn cylinder_numeric_converges_in_f64() {
        let mut worst_ref = 0.0f64;
        for material in materials() {
            for (p1, p2) in SEGMENTS {
                let d = axis_distance(p1, p2);
                // Up to R/d = 0.6 (the sweeps go to 0.5); closer: cylinder_numeric_close_to_the_tube.
                for ratio in [0.01, 0.3, 0.6] {
                    let c = with_radius(p1, p2, material.clone(), ratio * d);
                    let (value, steps) = ladder("cylinder.numeric", &c);
                    let what = format!("{material:?} {p1:?}–{p2:?} R/d={ratio}: {value:e}");
                    assert!(value > 0.0, "{what}");
                    assert_converges(&what, &steps);
                    if let Some(r) = reference64(&c, Target::Cylinder) {
                        let e = rel(value, r);
                        assert!(e < 1e-8, "{what} vs reference {r:e}");
                        worst_ref = worst_ref.max(e);
                    }
                    if ratio == 0.3 {
                        eprintln!("cylinder.numeric {what}, steps {steps:?}");
                    }
                }
            }
        }
        eprintln!("worst cylinder.numeric@128x256 vs reference: {worst_ref:.1e}");
    }

    #[test]
    fn cylinder_numeric_default_counts_are_accurate() {
        // The defaults (32 × 64) on a benign configuration: well below f32 rounding.
        let c = with_radius(SEGMENTS[0].0, SEGMENTS[0].1, ltc(SPARSE[0]), 0.1);
        let fine = eval64("cylinder.numeric", &[128, 256], &c);
        let default = eval64("cylinder.numeric", &[], &c);
        assert_eq!(default, eval64("cylinder.numeric", &[32, 64], &c));
        let e = rel(default, fine);
        eprintln!("cylinder.numeric defaults vs 128x256: {e:.1e}");
        assert!(e < 1e-9);
    }

    #[test]
    fn cylinder_numeric_close_to_the_tube() {
        // d − R = d/100: the hard case (grazing generators, see the kernel); it converges
        // in NPHI, more slowly.
        let (p1, p2) = SEGMENTS[0];
        let d = axis_distance(p1, p2);
        let c = with_radius(p1, p2, ltc(SPARSE[1]), 0.99 * d);
        let values: Vec<f64> = [[32, 64], [128, 64], [512, 64]]
            .iter()
            .map(|p| eval64("cylinder.numeric", p, &c))
            .collect();
        let (e1, e2) = (rel(values[0], values[2]), rel(values[1], values[2]));
        eprintln!("cylinder.numeric at R = 0.99 d: NPHI 32 {e1:.1e}, 128 {e2:.1e} from 512");
        assert!(e2 < e1 && e2 < 1e-6);
        if let Some(r) = reference64(&c, Target::Cylinder) {
            assert!(rel(values[2], r) < 1e-8, "{} vs {r}", values[2]);
        }
    }

    #[test]
    fn thin_cylinder_over_radius_tends_to_the_line() {
        for material in materials() {
            for (p1, p2) in SEGMENTS {
                let line = eval64("line.ltc2017", &[], &config(p1, p2, material.clone()));
                let d = axis_distance(p1, p2);
                let mut gaps = Sci(Vec::new());
                for ratio in [1e-2, 1e-3, 1e-4] {
                    let r = ratio * d;
                    let c = with_radius(p1, p2, material.clone(), r);
                    gaps.0.push(rel(eval64("cylinder.numeric", &[128, 256], &c) / r, line));
                }
                // O(R): each tenfold thinner tube is about ten times closer.
                assert!(
                    gaps[1] < 0.2 * gaps[0] && gaps[2] < 0.2 * gaps[1],
                    "{material:?} {p1:?}: {gaps:?}"
                );
                assert!(gaps[2] < 1e-3, "{material:?} {p1:?}: {gaps:?}");
            }
        }
    }

    #[test]
    fn cylinder_line_agrees_with_the_quadrature_for_thin_tubes() {
        // Listing 1.5 with the 2017 line integral against the converged quadrature: the
        // relative gap is O(R/d), below R/d here.
        for material in materials() {
            let (p1, p2) = SEGMENTS[0];
            let d = axis_distance(p1, p2);
            for ratio in [1e-2, 1e-3] {
                let c = with_radius(p1, p2, material.clone(), ratio * d);
                let approx = composite64("cylinder.line", &c, "line.ltc2017");
                let numeric = eval64("cylinder.numeric", &[128, 256], &c);
                let e = rel(approx, numeric);
                eprintln!("cylinder.line[ltc2017] {material:?} R/d={ratio}: {e:.1e}");
                assert!(e < ratio, "{material:?} R/d={ratio}: {approx} vs {numeric}");
            }
        }
    }

    #[test]
    fn cylinder_line_clamps_to_one() {
        // A glossy lobe looking straight at a fat tube: R·I_line > 1 and is clamped.
        let c = with_radius(
            [-1.0, 0.0, 0.3],
            [1.0, 0.0, 0.3],
            ltc([[8.0, 0.0, 0.0], [0.0, 8.0, 0.0], [0.0, 0.0, 1.0]]),
            0.25,
        );
        let raw = 0.25 * eval64("line.ltc2017", &[], &c);
        assert!(raw > 1.0, "{raw}");
        assert_eq!(composite64("cylinder.line", &c, "line.ltc2017"), 1.0);
        let numeric = eval64("cylinder.numeric", &[128, 256], &c);
        eprintln!("clamp: R·I_line = {raw:.3}, cylinder.numeric {numeric:.4}");
        assert!(numeric < 1.0);
    }

    #[test]
    fn cylinder_numeric_paper_is_close_on_a_benign_configuration() {
        let (p1, p2) = SEGMENTS[0];
        for material in [Material::Diffuse, ltc(SPARSE[0])] {
            let c = with_radius(p1, p2, material.clone(), 0.1);
            let paper = eval64("cylinder.numeric_paper", &[], &c);
            let numeric = eval64("cylinder.numeric", &[128, 256], &c);
            let e = rel(paper, numeric);
            eprintln!("cylinder.numeric_paper {material:?}: {paper:.6e} vs {numeric:.6e} ({e:.1e})");
            assert!(e < 0.05, "{e}");
        }
    }

    #[test]
    fn cylinder_numeric_paper_weight_bias() {
        // Listing 1.2's axis samples include both ends (spacing L/(n−1)) but are weighted
        // L/n: the sum is (n−1)/n·trapezoid + (L/n)·(end columns)/2. A 6 m tube 0.2 m above
        // the point has almost dark ends, so the listing comes out low by about 1/n = 1%.
        let (p1, p2) = ([-3.0, 0.0, 0.2], [3.0, 0.0, 0.2]);
        let c = with_radius(p1, p2, Material::Diffuse, 0.05);
        let paper = eval64("cylinder.numeric_paper", &[], &c);
        let numeric = eval64("cylinder.numeric", &[128, 256], &c);
        let offset = paper / numeric - 1.0;
        eprintln!("cylinder.numeric_paper, 6 m tube 0.2 m up: {paper:.6e} vs {numeric:.6e} ({offset:.2e})");
        assert!((offset + 0.01).abs() < 1e-3, "{offset:e}");
    }

    /// A segment pointing away from the origin: only the cap at p1 faces it; and reversed.
    const CAP_SEGMENTS: [([f64; 3], [f64; 3]); 3] = [
        ([0.2, 0.1, 1.0], [0.5, 0.3, 2.0]),
        ([0.5, 0.3, 2.0], [0.2, 0.1, 1.0]),
        ([-0.6, 0.4, 0.8], [-1.5, 0.9, 1.1]),
    ];

    #[test]
    fn caps_point_tends_to_the_caps_integral() {
        let Some(_) = reference64(
            &with_radius(CAP_SEGMENTS[0].0, CAP_SEGMENTS[0].1, Material::Diffuse, 0.01),
            Target::Caps,
        ) else {
            eprintln!("caps reference not available: skipped");
            return;
        };
        for material in materials() {
            for (p1, p2) in CAP_SEGMENTS {
                let mut gaps = Sci(Vec::new());
                for r in [1e-1, 1e-2, 1e-3] {
                    let c = with_radius(p1, p2, material.clone(), r);
                    let caps = reference64(&c, Target::Caps).unwrap();
                    gaps.0.push(rel(eval64("caps.point", &[], &c), caps));
                }
                eprintln!("caps.point {material:?} {p1:?}: R = 0.1, 0.01, 0.001: {gaps:?}");
                assert!(gaps[2] < 1e-3 && gaps[2] < gaps[1] && gaps[1] < gaps[0], "{gaps:?}");
            }
        }
    }

    #[test]
    fn caps_numeric_paper_loosely_matches() {
        for material in [Material::Diffuse, ltc(SPARSE[1])] {
            for (p1, p2) in CAP_SEGMENTS {
                let c = with_radius(p1, p2, material.clone(), 0.2);
                let paper = eval64("caps.numeric_paper", &[], &c);
                let point = eval64("caps.point", &[], &c);
                let Some(caps) = reference64(&c, Target::Caps) else {
                    // Without the reference: the point-disk limit, loosely.
                    assert!(rel(paper, point) < 0.3, "{paper} vs {point}");
                    continue;
                };
                let e = rel(paper, caps);
                eprintln!(
                    "caps.numeric_paper {material:?} {p1:?} R=0.2: {e:.1e} (caps.point {:.1e})",
                    rel(point, caps)
                );
                assert!(e < 0.02, "{paper} vs {caps}");
            }
        }
    }

    #[test]
    fn caps_signs_follow_the_outward_normals() {
        // p1 = (0,0,1) → p2 = (0,0,2): the cap at p1 (normal −z) faces the origin, the cap
        // at p2 is hidden. Reversed, the visible cap is at p2 (normal +ω_t = −z).
        let up = with_radius([0.0, 0.0, 1.0], [0.0, 0.0, 2.0], Material::Diffuse, 1e-3);
        let down = with_radius([0.0, 0.0, 2.0], [0.0, 0.0, 1.0], Material::Diffuse, 1e-3);
        let point = 1e-6; // πR²·D(z)·cos/‖p‖² = π·1e-6·(1/π)·1/1
        for id in ["caps.point", "caps.numeric_paper"] {
            for c in [&up, &down] {
                let e = rel(eval64(id, &[], c), point);
                assert!(e < 1e-5, "{id}: {e:e}");
            }
        }
        // A tube lying across above the point: both caps face away from it.
        let hidden = with_radius([-1.0, 0.0, 1.0], [1.0, 0.0, 1.0], Material::Diffuse, 1e-3);
        for id in ["caps.point", "caps.numeric_paper"] {
            assert_eq!(eval64(id, &[], &hidden), 0.0, "{id}");
        }
    }

    #[test]
    fn tube_line_is_cylinder_line_plus_caps_point() {
        for material in materials() {
            for (p1, p2) in CAP_SEGMENTS {
                let mut gaps = Sci(Vec::new());
                for r in [1e-2, 1e-3, 1e-4] {
                    let c = with_radius(p1, p2, material.clone(), r);
                    let tube = composite64("tube.line", &c, "line.ltc2017");
                    let parts = composite64("cylinder.line", &c, "line.ltc2017") + eval64("caps.point", &[], &c);
                    assert!(rel(tube, parts) < 1e-14, "{tube} vs {parts}");
                    // The side by cylinder.numeric, the caps by the reference (or by caps.point
                    // when it is missing: then this checks the side only).
                    let caps = reference64(&c, Target::Caps).unwrap_or_else(|| eval64("caps.point", &[], &c));
                    let target = eval64("cylinder.numeric", &[128, 256], &c) + caps;
                    if let Some(r) = reference64(&c, Target::Tube) {
                        assert!(rel(target, r) < 1e-9, "{target} vs {r}");
                    }
                    gaps.0.push(rel(tube, target));
                }
                // The line part dominates: O(R/d), d the distance to the axis (0.13 for the
                // first two segments, seen nearly end-on, where it is largest).
                eprintln!("tube.line[ltc2017] {material:?} {p1:?} R = 1e-2..1e-4: {gaps:?}");
                assert!(
                    gaps[2] < 0.2 * gaps[1] && gaps[1] < 0.2 * gaps[0] && gaps[2] < 5e-3,
                    "{gaps:?}"
                );
            }
        }
    }

    /// Rectangles: the segments above, normals at a few angles about the segment.
    const RECT_ANGLES: [f64; 3] = [0.3, 1.0, 1.4];

    #[test]
    fn rectangle_numeric_converges_in_f64() {
        let mut worst_ref = 0.0f64;
        for material in materials() {
            for (p1, p2) in SEGMENTS {
                let d = axis_distance(p1, p2);
                for (angle, ratio) in RECT_ANGLES.into_iter().zip([0.01, 0.5, 2.0]) {
                    let c = with_rect(p1, p2, material.clone(), rect_normal(p1, p2, angle), ratio * d);
                    let (value, steps) = ladder("rectangle.numeric", &c);
                    let what = format!("{material:?} {p1:?}–{p2:?} angle {angle} W/d={ratio}: {value:e}");
                    assert!(value > 0.0, "{what}");
                    assert_converges(&what, &steps);
                    if let Some(r) = reference64(&c, Target::Rectangle) {
                        let e = rel(value, r);
                        assert!(e < 1e-8, "{what} vs reference {r:e}");
                        worst_ref = worst_ref.max(e);
                    }
                    if ratio == 0.5 {
                        eprintln!("rectangle.numeric {what}, steps {steps:?}");
                    }
                }
            }
        }
        eprintln!("worst rectangle.numeric@128x256 vs reference: {worst_ref:.1e}");
    }

    #[test]
    fn rectangle_numeric_matches_the_parallel_rectangle_form_factor() {
        // Diffuse, a rectangle parallel to the surface with a corner above the origin:
        // F = (1/2π)[a/√(1+a²)·atan(b/√(1+a²)) + b/√(1+b²)·atan(a/√(1+b²))], sides a, b at h = 1.
        let corner = |a: f64, b: f64| {
            let (sa, sb) = ((1.0 + a * a).sqrt(), (1.0 + b * b).sqrt());
            (a / sa * (b / sa).atan() + b / sb * (a / sb).atan()) / (2.0 * std::f64::consts::PI)
        };
        for (len, w) in [(2.0, 1.0), (0.1, 3.0), (10.0, 0.01)] {
            for normal in [[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]] {
                let c = with_rect([0.0, w / 2.0, 1.0], [len, w / 2.0, 1.0], Material::Diffuse, normal, w);
                let value = eval64("rectangle.numeric", &[64, 256], &c);
                let exact = corner(len, w);
                assert!(rel(value, exact) < 1e-12, "{len} {w}: {value} vs {exact}");
            }
        }
    }

    #[test]
    fn rectangle_line_scale_and_orientation() {
        // As W → 0, I_rect/W → |ω⊥·ωb|·I_line/2 (see rectangle_line_fixed.wgsl): the W/2
        // scale is right; Listing 1.11's |ω⊥·ωn| is the complementary factor.
        for material in materials() {
            for (p1, p2) in SEGMENTS.into_iter().take(3) {
                let d = axis_distance(p1, p2);
                for angle in RECT_ANGLES {
                    let normal = rect_normal(p1, p2, angle);
                    let mut gaps = Sci(Vec::new());
                    let mut ratio_published = 0.0;
                    for w in [1e-2, 1e-3, 1e-4] {
                        let c = with_rect(p1, p2, material.clone(), normal, w * d);
                        let numeric = eval64("rectangle.numeric", &[8, 256], &c);
                        gaps.0
                            .push(rel(composite64("rectangle.line_fixed", &c, "line.ltc2017"), numeric));
                        ratio_published = composite64("rectangle.line", &c, "line.ltc2017") / numeric;
                    }
                    assert!(
                        gaps[2] < 1e-3 && gaps[2] < 0.2 * gaps[0],
                        "{material:?} {angle}: {gaps:?}"
                    );
                    // ω⊥·ωn = cos(angle) by construction; ω⊥·ωb = ±sin(angle).
                    let expected = angle.cos() / angle.sin();
                    assert!(
                        (ratio_published - expected).abs() < 1e-3 * expected,
                        "{ratio_published} vs {expected}"
                    );
                    if angle == RECT_ANGLES[0] {
                        eprintln!(
                            "{material:?} {p1:?}: rectangle.line_fixed gaps at W/d = 1e-2..1e-4 {gaps:?}; \
                             rectangle.line/numeric = {ratio_published:.4} = cot {angle}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn rectangle_line_misses_a_strip_facing_the_point() {
        // A 2 cm strip 1 m above the point, facing down: clearly lit, yet ω⊥ = ±y ⟂ ωn = −z
        // and Listing 1.11 returns 0.
        let c = with_rect(
            [-1.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            Material::Diffuse,
            [0.0, 0.0, -1.0],
            0.02,
        );
        let numeric = eval64("rectangle.numeric", &[], &c);
        let fixed = composite64("rectangle.line_fixed", &c, "line.ltc2017");
        assert!(numeric > 1e-3);
        assert_eq!(composite64("rectangle.line", &c, "line.ltc2017"), 0.0);
        assert!(rel(fixed, numeric) < 1e-3, "{fixed} vs {numeric}");
        // Turned edge-on (normal ±y): the target vanishes, the listing gives its maximum.
        let edge = with_rect(
            [-1.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            Material::Diffuse,
            [0.0, 1.0, 0.0],
            0.02,
        );
        assert_eq!(eval64("rectangle.numeric", &[], &edge), 0.0);
        assert!(composite64("rectangle.line_fixed", &edge, "line.ltc2017").abs() < 1e-18);
        let published = composite64("rectangle.line", &edge, "line.ltc2017");
        assert!(rel(published, fixed) < 1e-12, "{published} vs {fixed}");
    }

    #[test]
    fn surface_ports_in_f32_track_f64() {
        // The f32 ports against their own f64: rounding only (a few 1e-6 relative).
        for material in materials() {
            let (p1, p2) = SEGMENTS[0];
            let c = Config {
                radius: Some(0.1),
                rect: Some(Rect {
                    normal: rect_normal(p1, p2, 1.0),
                    width: 0.1,
                }),
                ..config(p1, p2, material.clone())
            };
            for id in [
                "cylinder.numeric_paper",
                "cylinder.numeric",
                "caps.numeric_paper",
                "caps.point",
                "rectangle.numeric",
            ] {
                let (v32, v64) = (evaluate::<f32>(id, &[], &c).unwrap() as f64, eval64(id, &[], &c));
                assert!(
                    rel(v32, v64) < 1e-4 || (v32 - v64).abs() < 1e-9,
                    "{id} {material:?}: {v32} vs {v64}"
                );
            }
        }
    }

    #[test]
    fn composites_have_ports_only_in_evaluate_composite() {
        let c = with_radius(SEGMENTS[0].0, SEGMENTS[0].1, Material::Diffuse, 0.1);
        let nan_line = |_: [f64; 3], _: [f64; 3]| f64::NAN;
        for id in PORTED_COMPOSITE {
            assert!(has_port(id));
            assert_eq!(evaluate::<f64>(id, &[], &c), None, "{id}");
        }
        for id in PORTED {
            assert_eq!(evaluate_composite::<f64>(id, &[], &c, &nan_line), None, "{id}");
        }
        // The inner line integral is what the composite uses.
        let twice = |_: [f64; 3], _: [f64; 3]| 2.0;
        assert_eq!(
            evaluate_composite::<f64>("cylinder.line", &[], &c, &twice),
            Some(0.1 * 2.0)
        );
    }

    /// The kernels' `cyl_angle` / `rect_angle` (Cephes atanf), here in f64 to check its
    /// constants and branches: the CPU ports use atan2 in its place.
    fn kernel_angle(y: f64, x: f64) -> f64 {
        let (mut base, mut z) = (0.0, y / x);
        if x <= 0.0 {
            base = 0.5 * std::f64::consts::PI;
            z = -x / y;
        }
        let mut t = z;
        if z > 2.414213562373095 {
            base += 0.5 * std::f64::consts::PI;
            t = -1.0 / z;
        } else if z > 0.414213562373095 {
            base += 0.25 * std::f64::consts::PI;
            t = (z - 1.0) / (z + 1.0);
        }
        let q = t * t;
        base + ((((0.0805374449538 * q - 0.138776856032) * q + 0.199777106478) * q - 0.333329491539) * q * t + t)
    }

    #[test]
    fn kernel_angle_is_atan2_to_f32_precision() {
        let mut worst = 0.0f64;
        for i in 0..20000 {
            // Angles from 1e-6 to π − 1e-6, evenly in log near 0 and near π.
            let u = i as f64 / 20000.0;
            let angle = if u < 0.5 {
                10f64.powf(-6.0 + 12.0 * u).min(1.5)
            } else {
                std::f64::consts::PI - 10f64.powf(-6.0 + 12.0 * (u - 0.5)).min(1.5)
            };
            let (y, x) = (angle.sin() * 3.7, angle.cos() * 3.7);
            let e = (kernel_angle(y, x) - y.atan2(x)).abs() / y.atan2(x);
            worst = worst.max(e);
        }
        eprintln!("kernel angle vs atan2: worst relative {worst:.1e}");
        assert!(worst < 3e-7, "{worst:e}");
        for text in [
            include_str!("../../kernels/cylinder_numeric.wgsl"),
            include_str!("../../kernels/rectangle_numeric.wgsl"),
        ] {
            for constant in [
                "2.414213562373095",
                "0.414213562373095",
                "(((0.0805374449538 * q - 0.138776856032) * q + 0.199777106478) * q - 0.333329491539) * q * t + t",
            ] {
                assert!(text.contains(constant), "{constant}");
            }
        }
    }

    #[test]
    fn ports_match_the_kernel_files() {
        let kernels = [
            include_str!("../../kernels/line_ltc2017.wgsl"),
            include_str!("../../kernels/line_ltc2017_fwt.wgsl"),
            include_str!("../../kernels/line_ltc2023.wgsl"),
            include_str!("../../kernels/line_ltc2023_full.wgsl"),
            include_str!("../../kernels/line_ltc2023_fix.wgsl"),
            include_str!("../../kernels/line_numeric_paper.wgsl"),
            include_str!("../../kernels/line_numeric.wgsl"),
        ];
        for (id, text) in PORTED.iter().zip(kernels) {
            assert!(text.starts_with(&format!("//! id: {id}\n")), "{id}");
            assert!(has_port(id));
        }
        let params = format!("//! params: SAMPLES={}\n", numeric::DEFAULT_SAMPLES);
        assert!(kernels[6].contains(&params));
        assert!(kernels[6].contains(&format!("override SAMPLES: u32 = {};", numeric::DEFAULT_SAMPLES)));
        assert!(kernels[2].contains(&format!("const INV_PI: f32 = {};", ltc2023::INV_PI)));
        assert!(!has_port("line.user"));
        let c = config(SEGMENTS[0].0, SEGMENTS[0].1, Material::Diffuse);
        assert_eq!(evaluate::<f32>("line.user", &[], &c), None);
    }

    #[test]
    fn surface_ports_match_the_kernel_files() {
        let kernels = [
            (
                "cylinder.numeric_paper",
                include_str!("../../kernels/cylinder_numeric_paper.wgsl"),
            ),
            ("cylinder.numeric", include_str!("../../kernels/cylinder_numeric.wgsl")),
            (
                "caps.numeric_paper",
                include_str!("../../kernels/caps_numeric_paper.wgsl"),
            ),
            ("caps.point", include_str!("../../kernels/caps_point.wgsl")),
            (
                "rectangle.numeric",
                include_str!("../../kernels/rectangle_numeric.wgsl"),
            ),
            ("cylinder.line", include_str!("../../kernels/cylinder_line.wgsl")),
            ("tube.line", include_str!("../../kernels/tube_line.wgsl")),
            ("rectangle.line", include_str!("../../kernels/rectangle_line.wgsl")),
            (
                "rectangle.line_fixed",
                include_str!("../../kernels/rectangle_line_fixed.wgsl"),
            ),
        ];
        for (id, text) in kernels {
            assert!(text.starts_with(&format!("//! id: {id}\n")), "{id}");
            let composite = PORTED_COMPOSITE.contains(&id);
            assert_eq!(text.contains("\n//! uses: line\n"), composite, "{id}");
            assert!(PORTED.contains(&id) != composite, "{id}");
            let target = id.split('.').next().unwrap();
            assert!(text.contains(&format!("\n//! target: {target}\n")), "{id}");
        }
        let (nphi, nw, nl) = (surface::DEFAULT_NPHI, surface::DEFAULT_NW, surface::DEFAULT_NL);
        let cylinder = kernels[1].1;
        assert!(cylinder.contains(&format!("//! params: NPHI={nphi} NL={nl}\n")));
        assert!(cylinder.contains(&format!("override NPHI: u32 = {nphi};")));
        assert!(cylinder.contains(&format!("override NL: u32 = {nl};")));
        let rectangle = kernels[4].1;
        assert!(rectangle.contains(&format!("//! params: NW={nw} NL={nl}\n")));
        assert!(rectangle.contains(&format!("override NW: u32 = {nw};")));
        assert!(rectangle.contains(&format!("override NL: u32 = {nl};")));
        // Parameters in header order, defaults filled in.
        let c = with_radius(SEGMENTS[0].0, SEGMENTS[0].1, ltc(SPARSE[0]), 0.1);
        assert_eq!(
            eval64("cylinder.numeric", &[], &c),
            eval64("cylinder.numeric", &[nphi, nl], &c)
        );
        assert_eq!(
            eval64("cylinder.numeric", &[16], &c),
            eval64("cylinder.numeric", &[16, nl], &c)
        );
        assert_ne!(
            eval64("cylinder.numeric", &[16], &c),
            eval64("cylinder.numeric", &[16, 16], &c)
        );
    }
}
