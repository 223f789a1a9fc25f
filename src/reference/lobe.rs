//! The distribution D of DESIGN §1 in f64, every material as an LTC (Eq. 1.24; diffuse is
//! M⁻¹ = I), evaluated as Listing 1.10 does.

use crate::scene::{cross, det3, dot, Mat3, Material, Vec3};
use std::f64::consts::PI;

#[derive(Clone, Copy, Debug)]
pub(crate) struct Lobe {
    minv: Mat3,
    /// |det M⁻¹|/π.
    scale: f64,
}

impl Lobe {
    pub fn new(material: &Material) -> Lobe {
        let minv = material.minv();
        Lobe {
            minv,
            scale: det3(&minv).abs() / PI,
        }
    }

    /// D(ω) > 0 exactly where `support·ω > 0` (ω_o.z > 0): a half-space through the origin,
    /// whose boundary is the kink of D.
    pub fn support(&self) -> Vec3 {
        self.minv[2]
    }

    /// ‖M⁻¹‖_F·‖M‖_F, at most 3× the condition number of M⁻¹. A direction rounded by ε
    /// changes D by up to about that many ε, relatively: the lobe is that much narrower
    /// than a cosine.
    pub fn condition(&self) -> f64 {
        let m = &self.minv;
        let frobenius = |rows: [Vec3; 3]| rows.iter().map(|r| dot(*r, *r)).sum::<f64>().sqrt();
        // The rows of adj(M⁻¹)ᵀ are the cross products of the rows of M⁻¹; M = adj/det.
        let adjugate = [cross(m[1], m[2]), cross(m[2], m[0]), cross(m[0], m[1])];
        frobenius(*m) * frobenius(adjugate) / det3(m).abs()
    }

    fn transform(&self, w: Vec3) -> Vec3 {
        self.minv.map(|row| dot(row, w))
    }

    /// Listing 1.10 for a unit `w`.
    pub fn eval(&self, w: Vec3) -> f64 {
        let wo = self.transform(w);
        let lo = dot(wo, wo).sqrt();
        self.scale * (wo[2] / lo).max(0.0) / (lo * lo * lo)
    }

    /// D along the great circle `ω(χ) = sin χ·u + cos χ·v` (u ⟂ v, unit), with the matrix
    /// product hoisted out of the integrand.
    pub fn circle(&self, u: Vec3, v: Vec3) -> Circle {
        Circle {
            a: self.transform(u),
            b: self.transform(v),
            scale: self.scale,
        }
    }
}

/// See [`Lobe::circle`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct Circle {
    a: Vec3,
    b: Vec3,
    scale: f64,
}

impl Circle {
    /// D(sin χ·u + cos χ·v): with ω unit, Listing 1.10 is `|M⁻¹| max(0, ω_o.z)/(π‖ω_o‖⁴)`.
    #[inline]
    pub fn eval(&self, sin: f64, cos: f64) -> f64 {
        let z = sin * self.a[2] + cos * self.b[2];
        if z <= 0.0 {
            return 0.0;
        }
        let x = sin * self.a[0] + cos * self.b[0];
        let y = sin * self.a[1] + cos * self.b[1];
        let q = x * x + y * y + z * z;
        self.scale * z / (q * q)
    }

    /// Where the lobe is narrowest along the circle: the angle χ* (mod π) that minimises
    /// ‖ω_o‖² = Q(χ) and the angular width `sqrt(Q_min/(Q_max − Q_min))` over which D, which
    /// goes as 1/Q², falls off. None when Q is constant (D is then as smooth as a cosine).
    pub fn peak(&self) -> Option<(f64, f64)> {
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
            let wo = [0, 1, 2].map(|k| s * circle.a[k] + c * circle.b[k]);
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
