//! The distribution D of docs/conventions.md in f64: every LTC material as Listing 1.10 evaluates it
//! (Eq. 1.24; diffuse is M⁻¹ = I), and the GGX lobe of the `ggx` material (written here from
//! docs/conventions.md, independently of the fitter's copy in `ltc::ggx`). The integrators see a lobe
//! only through this interface: `eval`, `circle` (D along a great circle, with its peak),
//! `support` (the half-space D lives in), `mirror` (the direction a sharp lobe peaks at) and
//! `condition`.

use super::vec::{cross, det3, dot};
use crate::input::scene::{Mat3, Material, Vec3};
use std::f64::consts::PI;

#[derive(Clone, Copy, Debug)]
pub(crate) enum Lobe {
    Ltc(LtcLobe),
    Ggx(GgxLobe),
}

#[derive(Clone, Copy, Debug)]
pub(crate) struct LtcLobe {
    minv: Mat3,
    /// |det M⁻¹|/π.
    scale: f64,
}

/// D(ω) = NDF(h)·G2(v, ω)·F(v·h)/(4 v.z) for ω.z > 0 (docs/conventions.md, `ggx`), with
/// Schlick's F = f0 + (1 − f0)(1 − v·h)⁵ (f0 = 1: F = 1).
#[derive(Clone, Copy, Debug)]
pub(crate) struct GgxLobe {
    ax: f64,
    ay: f64,
    view: Vec3,
    f0: f64,
    /// 1 + Λ(v).
    one_lambda_v: f64,
    /// 1/(4π ax ay v.z).
    scale: f64,
}

impl GgxLobe {
    fn new(alpha: [f64; 2], view: Vec3, f0: f64) -> GgxLobe {
        let mut g = GgxLobe {
            ax: alpha[0],
            ay: alpha[1],
            view,
            f0,
            one_lambda_v: 1.0,
            scale: 1.0 / (4.0 * PI * alpha[0] * alpha[1] * view[2]),
        };
        g.one_lambda_v = 1.0 + g.lambda(view);
        g
    }

    /// Λ(ω) = (−1 + sqrt(1 + x))/2 = x/(2(1 + sqrt(1 + x))), x = (ax²ωx² + ay²ωy²)/ωz².
    fn lambda(&self, w: Vec3) -> f64 {
        let x = ((self.ax * w[0]).powi(2) + (self.ay * w[1]).powi(2)) / (w[2] * w[2]);
        x / (2.0 * (1.0 + (1.0 + x).sqrt()))
    }

    /// D for a unit ω. With H = v + ω unnormalised, NDF(h) = |H|⁴/(π ax ay q²),
    /// q = (Hx/ax)² + (Hy/ay)² + Hz².
    fn eval(&self, w: Vec3) -> f64 {
        if !(w[2] > 0.0) {
            return 0.0;
        }
        let v = self.view;
        let h = [v[0] + w[0], v[1] + w[1], v[2] + w[2]];
        let hh = dot(h, h);
        let q = (h[0] / self.ax).powi(2) + (h[1] / self.ay).powi(2) + h[2] * h[2];
        let d = self.scale * (hh / q) * (hh / q) / (self.one_lambda_v + self.lambda(w));
        if self.f0 == 1.0 {
            return d;
        }
        d * self.schlick(w)
    }

    /// Schlick's F at h = normalize(v + ω) for unit v, ω: with c = v·ω, v·h = sqrt((1 + c)/2),
    /// and 1 − v·h = (1 − c)/(2(1 + v·h)) with 1 − c = |v − ω|²/2, free of the cancellation of
    /// 1 − v·h near the retro-reflection direction.
    fn schlick(&self, w: Vec3) -> f64 {
        let v = self.view;
        let c = dot(v, w);
        let vh = (0.5 * (1.0 + c)).max(0.0).sqrt();
        let e = [v[0] - w[0], v[1] - w[1], v[2] - w[2]];
        let x = 0.25 * dot(e, e) / (1.0 + vh);
        let x2 = x * x;
        self.f0 + (1.0 - self.f0) * (x2 * x2 * x)
    }

    /// The mirror direction of the view, where the lobe peaks (its peak is there, or close to
    /// it towards the normal at grazing views).
    fn mirror(&self) -> Vec3 {
        [-self.view[0], -self.view[1], self.view[2]]
    }

    /// The lobe's narrowest angular width: ω turns by 2·(v·h) per radian of h across the
    /// plane of reflection, and h spreads over α.
    /// How many ε a direction rounded by ε moves F by, relatively: v·h = cos(∠(v, ω)/2) turns
    /// at most ½ per radian, so |d ln F| ≤ 2.5(1 − f0)x⁴/(f0 + (1 − f0)x⁵) with x = 1 − v·h,
    /// largest at x⁵ = 4f0/(1 − f0) (or x = 1). f0 is floored at 1e-6: below it F ≈ x⁵ is
    /// unbounded in relative terms only where F itself, and its share of the integral, vanishes.
    fn fresnel_condition(&self) -> f64 {
        if self.f0 == 1.0 {
            return 0.0;
        }
        let f0 = self.f0.max(1e-6);
        let x = (4.0 * f0 / (1.0 - f0)).powf(0.2).min(1.0);
        2.5 * (1.0 - f0) * x.powi(4) / (f0 + (1.0 - f0) * x.powi(5))
    }

    fn width(&self) -> f64 {
        (2.0 * self.ax.min(self.ay) * self.view[2]).max(1e-6)
    }
}

impl Lobe {
    pub fn new(material: &Material) -> Lobe {
        match material {
            Material::Ggx { alpha, view, f0, .. } => Lobe::Ggx(GgxLobe::new(alpha.xy(), *view, f0.unwrap_or(1.0))),
            _ => {
                let minv = material.minv();
                Lobe::Ltc(LtcLobe {
                    minv,
                    scale: det3(&minv).abs() / PI,
                })
            }
        }
    }

    /// D(ω) > 0 only where `support·ω > 0`: a half-space through the origin, whose boundary
    /// is the kink of D (ω_o.z = 0 for an LTC, the horizon for GGX).
    pub fn support(&self) -> Vec3 {
        match self {
            Lobe::Ltc(l) => l.minv[2],
            Lobe::Ggx(_) => [0.0, 0.0, 1.0],
        }
    }

    /// How many ε a direction rounded by ε moves D by, relatively. For an LTC
    /// ‖M⁻¹‖_F·‖M‖_F, at most 3× the condition number of M⁻¹: the lobe is that much narrower
    /// than a cosine. For GGX, D falls as 1/(1 + θ²/w²)², whose log-slope is at most 2/w
    /// for a lobe of width w; 4/w + 3 covers the rest of the formula, and Schlick's F adds
    /// its own log-slope (`GgxLobe::fresnel_condition`).
    pub fn condition(&self) -> f64 {
        match self {
            Lobe::Ltc(l) => {
                let m = &l.minv;
                let frobenius = |rows: [Vec3; 3]| rows.iter().map(|r| dot(*r, *r)).sum::<f64>().sqrt();
                // The rows of adj(M⁻¹)ᵀ are the cross products of the rows of M⁻¹; M = adj/det.
                let adjugate = [cross(m[1], m[2]), cross(m[2], m[0]), cross(m[0], m[1])];
                frobenius(*m) * frobenius(adjugate) / det3(m).abs()
            }
            Lobe::Ggx(g) => 4.0 / g.width() + 3.0 + g.fresnel_condition(),
        }
    }

    /// For a GGX lobe, where it peaks and how wide it is (the integrators grade their
    /// outer panels there); None for an LTC (its integrators handle it through `circle`).
    pub fn mirror(&self) -> Option<(Vec3, f64)> {
        match self {
            Lobe::Ltc(_) => None,
            Lobe::Ggx(g) => Some((g.mirror(), g.width())),
        }
    }

    /// D for a unit `w` (Listing 1.10 for an LTC).
    pub fn eval(&self, w: Vec3) -> f64 {
        match self {
            Lobe::Ltc(l) => {
                let wo = l.minv.map(|row| dot(row, w));
                let lo = dot(wo, wo).sqrt();
                l.scale * (wo[2] / lo).max(0.0) / (lo * lo * lo)
            }
            Lobe::Ggx(g) => g.eval(w),
        }
    }

    /// D along the great circle `ω(χ) = sin χ·u + cos χ·v` (u ⟂ v, unit), with what can be
    /// hoisted out of the integrand.
    pub fn circle(&self, u: Vec3, v: Vec3) -> Circle {
        match self {
            Lobe::Ltc(l) => Circle::Ltc(LtcCircle {
                a: l.minv.map(|row| dot(row, u)),
                b: l.minv.map(|row| dot(row, v)),
                scale: l.scale,
            }),
            Lobe::Ggx(g) => Circle::Ggx { lobe: *g, u, v },
        }
    }
}

/// See [`Lobe::circle`].
#[derive(Clone, Copy, Debug)]
pub(crate) enum Circle {
    Ltc(LtcCircle),
    Ggx { lobe: GgxLobe, u: Vec3, v: Vec3 },
}

#[derive(Clone, Copy, Debug)]
pub(crate) struct LtcCircle {
    a: Vec3,
    b: Vec3,
    scale: f64,
}

impl Circle {
    #[inline]
    pub fn eval(&self, sin: f64, cos: f64) -> f64 {
        match self {
            Circle::Ltc(c) => c.eval(sin, cos),
            Circle::Ggx { lobe, u, v } => lobe.eval([0, 1, 2].map(|k| sin * u[k] + cos * v[k])),
        }
    }

    /// `eval` at each (sin, cos) pair, the variant matched once for the batch.
    #[inline]
    #[allow(clippy::needless_range_loop)]
    pub fn eval_batch<const N: usize>(&self, sin: &[f64; N], cos: &[f64; N], out: &mut [f64; N]) {
        match self {
            Circle::Ltc(c) => {
                for i in 0..N {
                    out[i] = c.eval(sin[i], cos[i]);
                }
            }
            Circle::Ggx { lobe, u, v } => {
                for i in 0..N {
                    out[i] = lobe.eval([0, 1, 2].map(|k| sin[i] * u[k] + cos[i] * v[k]));
                }
            }
        }
    }

    /// Where D peaks along the circle, as an angle χ* (mod π: the caller grades χ* and
    /// χ* + π), and the angular width over which it falls off; None when D is as smooth as a
    /// cosine. For GGX: the circle's point nearest the mirror direction, and the lobe's width
    /// widened by the circle's angular distance from the mirror direction.
    pub fn peak(&self) -> Option<(f64, f64)> {
        match self {
            Circle::Ltc(c) => c.peak(),
            Circle::Ggx { lobe, u, v } => {
                let r = lobe.mirror();
                let (ru, rv) = (dot(r, *u), dot(r, *v));
                let off = (1.0 - (ru * ru + rv * rv)).max(0.0).sqrt().asin();
                Some((ru.atan2(rv), lobe.width().hypot(off)))
            }
        }
    }
}

impl LtcCircle {
    /// D(sin χ·u + cos χ·v): with ω unit, Listing 1.10 is `|M⁻¹| max(0, ω_o.z)/(π‖ω_o‖⁴)`.
    #[inline]
    fn eval(&self, sin: f64, cos: f64) -> f64 {
        let z = sin * self.a[2] + cos * self.b[2];
        if z <= 0.0 {
            return 0.0;
        }
        let x = sin * self.a[0] + cos * self.b[0];
        let y = sin * self.a[1] + cos * self.b[1];
        let q = x * x + y * y + z * z;
        self.scale * z / (q * q)
    }

    /// The angle χ* (mod π) that minimises ‖ω_o‖² = Q(χ) and the angular width
    /// `sqrt(Q_min/(Q_max − Q_min))` over which D, which goes as 1/Q², falls off. None when
    /// Q is constant.
    fn peak(&self) -> Option<(f64, f64)> {
        let (qa, qb, qc) = (dot(self.a, self.a), dot(self.a, self.b), dot(self.b, self.b));
        // Q = (qa+qc)/2 + (qc−qa)/2·cos 2χ + qb·sin 2χ.
        let amp = (0.5 * (qc - qa)).hypot(qb);
        let q_max = 0.5 * (qa + qc) + amp;
        // Q_min·Q_max = qa·qc − qb² = ‖a×b‖², without the cancellation of (qa+qc)/2 − amp.
        let c = cross(self.a, self.b);
        let q_min = dot(c, c) / q_max;
        if q_max <= q_min {
            return None;
        }
        let centre = 0.5 * (-qb).atan2(0.5 * (qa - qc));
        Some((centre, (q_min / (q_max - q_min)).sqrt()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn circle_matches_listing() {
        let m = Material::Ltc {
            minv: [[2.0, 0.3, -0.4], [0.1, 1.5, 0.2], [0.5, -0.2, 0.9]],
        };
        let lobe = Lobe::new(&m);
        let (u, v) = ([0.6, 0.0, 0.8], [0.0, 1.0, 0.0]);
        let circle = lobe.circle(u, v);
        for i in 0..50 {
            let x = -3.0 + 0.12 * i as f64;
            let (s, c) = x.sin_cos();
            let w = [s * u[0] + c * v[0], s * u[1] + c * v[1], s * u[2] + c * v[2]];
            let (a, b) = (circle.eval(s, c), lobe.eval(w));
            assert!((a - b).abs() <= 1e-14 * b.max(1e-300), "{x}: {a} {b}");
        }
    }

    #[test]
    fn peak_is_the_minimum_of_the_norm() {
        let m = Material::Ltc {
            minv: [[30.0, 0.0, 4.0], [0.0, 25.0, 0.0], [-3.0, 0.0, 1.0]],
        };
        let circle = Lobe::new(&m).circle([0.0, 0.0, 1.0], [0.6, 0.8, 0.0]);
        let (centre, width) = circle.peak().unwrap();
        let q = |x: f64| {
            let (s, c) = x.sin_cos();
            let Circle::Ltc(lc) = circle else { unreachable!() };
            let wo = [0, 1, 2].map(|k| s * lc.a[k] + c * lc.b[k]);
            dot(wo, wo)
        };
        for dx in [1e-3, -1e-3, 0.3, 1.0] {
            assert!(q(centre) < q(centre + dx), "{dx}");
        }
        assert!(width > 0.1 && width < 0.2, "{width}");
        assert!(Lobe::new(&Material::Diffuse)
            .circle([1.0, 0.0, 0.0], [0.0, 0.0, 1.0])
            .peak()
            .is_none());
    }

    #[test]
    fn condition_of_a_diagonal_lobe() {
        let lobe = |a: f64| {
            Lobe::new(&Material::Ltc {
                minv: [[a, 0.0, 0.0], [0.0, a, 0.0], [0.0, 0.0, 1.0]],
            })
        };
        assert!((lobe(1.0).condition() - 3.0).abs() < 1e-15);
        // ‖diag(a,a,1)‖·‖diag(1/a,1/a,1)‖ = sqrt((2a²+1)(2/a²+1)).
        assert!((lobe(100.0).condition() - (20001.0f64 * 1.0002).sqrt()).abs() < 1e-9);
    }
}
