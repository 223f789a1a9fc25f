//! The GGX lobe the LTC fits approximate (docs/conventions.md, material `ggx`), in f64, with the sampling
//! the fit's objective uses. Written here for the fitter; the references have their own
//! copy (`reference::lobe`), so a reference never shares code with what it judges.

use crate::input::geometry::dot;
use std::f64::consts::PI;

pub type V3 = [f64; 3];

/// A GGX lobe: roughness per frame axis and a unit view direction with v.z > 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ggx {
    pub ax: f64,
    pub ay: f64,
    pub view: V3,
}

impl Ggx {
    /// Λ(ω) of height-correlated Smith, `(−1 + sqrt(1 + x))/2 = x/(2(1 + sqrt(1 + x)))`
    /// with `x = (ax² ωx² + ay² ωy²)/ωz²` (no cancellation for small x).
    pub fn lambda(&self, w: V3) -> f64 {
        let x = ((self.ax * w[0]).powi(2) + (self.ay * w[1]).powi(2)) / (w[2] * w[2]);
        x / (2.0 * (1.0 + (1.0 + x).sqrt()))
    }

    /// The NDF of the (unnormalised) half vector `h`.
    pub fn ndf(&self, h: V3) -> f64 {
        let hh = dot(h, h);
        let q = (h[0] / self.ax).powi(2) + (h[1] / self.ay).powi(2) + h[2] * h[2];
        hh * hh / (PI * self.ax * self.ay * q * q)
    }

    /// D(ω) = NDF(h)·G2(v, ω)/(4 v.z) for a unit ω above the surface, else 0.
    pub fn eval(&self, w: V3) -> f64 {
        if w[2] <= 0.0 {
            return 0.0;
        }
        let v = self.view;
        let h = [v[0] + w[0], v[1] + w[1], v[2] + w[2]];
        let g2 = 1.0 / (1.0 + self.lambda(v) + self.lambda(w));
        self.ndf(h) * g2 / (4.0 * v[2])
    }

    /// A direction from the distribution of visible normals (Heitz 2018, "Sampling the GGX
    /// Distribution of Visible Normals", written from its description), reflected about the
    /// normal: `(ω, pdf of ω)` with pdf = G1(v)·NDF(h)/(4 v.z), so D/pdf = G2/G1(v) ≤ 1 is
    /// bounded at every view angle. ω may be below the surface (D is 0 there).
    pub fn sample(&self, u1: f64, u2: f64) -> (V3, f64) {
        let v = self.view;
        let vh = {
            let s = [self.ax * v[0], self.ay * v[1], v[2]];
            let n = dot(s, s).sqrt();
            s.map(|x| x / n)
        };
        let lensq = vh[0] * vh[0] + vh[1] * vh[1];
        let t1 = if lensq > 0.0 {
            let l = lensq.sqrt();
            [-vh[1] / l, vh[0] / l, 0.0]
        } else {
            [1.0, 0.0, 0.0]
        };
        let t2 = [
            vh[1] * t1[2] - vh[2] * t1[1],
            vh[2] * t1[0] - vh[0] * t1[2],
            vh[0] * t1[1] - vh[1] * t1[0],
        ];
        let r = u1.sqrt();
        let (sp, cp) = (2.0 * PI * u2).sin_cos();
        let a = r * cp;
        let s = 0.5 * (1.0 + vh[2]);
        let b = (1.0 - s) * (1.0 - a * a).max(0.0).sqrt() + s * r * sp;
        let c = (1.0 - a * a - b * b).max(0.0).sqrt();
        let nh = [0, 1, 2].map(|k| a * t1[k] + b * t2[k] + c * vh[k]);
        let ne = [self.ax * nh[0], self.ay * nh[1], nh[2].max(0.0)];
        let n = dot(ne, ne).sqrt();
        let h = ne.map(|x| x / n);
        let vdh = dot(v, h);
        let w = [0, 1, 2].map(|k| 2.0 * vdh * h[k] - v[k]);
        (w, self.pdf(w))
    }

    /// ∫ D dω (the magnitude with F = 1), ∫ D·(1 − v·h)⁵ dω (the Schlick part), and the
    /// D-weighted mean direction, by visible-normal sampling on an n×n midpoint grid.
    pub fn moments(&self, n: usize) -> (f64, f64, V3) {
        let (mut norm, mut fresnel, mut mean) = (0.0, 0.0, [0.0; 3]);
        for i in 0..n {
            for j in 0..n {
                let (u1, u2) = ((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
                let (w, pdf) = self.sample(u1, u2);
                let d = self.eval(w);
                if d == 0.0 || pdf == 0.0 {
                    continue;
                }
                let v = self.view;
                let h = [v[0] + w[0], v[1] + w[1], v[2] + w[2]];
                let vh = dot(v, h) / dot(h, h).sqrt();
                let weight = d / pdf;
                norm += weight;
                fresnel += weight * (1.0 - vh).powi(5);
                for k in 0..3 {
                    mean[k] += weight * w[k];
                }
            }
        }
        let scale = 1.0 / (n * n) as f64;
        (norm * scale, fresnel * scale, mean)
    }
}

impl Ggx {
    /// The density of [`Ggx::sample`] at ω: G1(v)·NDF(h)/(4 v.z), h = normalize(v + ω)
    /// (0 where v·h ≤ 0 or h is below the surface, which visible normals never are).
    pub fn pdf(&self, w: V3) -> f64 {
        let v = self.view;
        let h = [v[0] + w[0], v[1] + w[1], v[2] + w[2]];
        let n = dot(h, h).sqrt();
        if n == 0.0 {
            return 0.0;
        }
        let h = h.map(|x| x / n);
        if h[2] <= 0.0 || dot(v, h) <= 0.0 {
            return 0.0;
        }
        self.ndf(h) / ((1.0 + self.lambda(v)) * 4.0 * v[2])
    }
}
