//! Independent double-precision references for the target integrals of docs/conventions.md.
//!
//! Every target is integrated from its definition by adaptive Gauss–Kronrod quadrature; no
//! closed form from the papers is used, so a method and its reference share no algebra. The
//! integrals are written in angles seen from the shading point (see `line`), where the
//! integrands are bounded, and the quadrature is split beforehand at every kink (the support
//! boundary of D, the horizon, the visible part of a surface) and graded around peaks.

mod line;
mod lobe;
mod quadrature;
mod surface;
mod tint;
mod vec;

use crate::input::scene::{Config, Material, Vec3};
use crate::input::target::Target;
use lobe::Lobe;
use quadrature::Quad;
use vec::dot;

/// A reference value with its absolute error estimate (`error >= 0`).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Estimate {
    pub value: f64,
    pub error: f64,
}

/// The reference value of `target` for `config` (already validated), or None when the target
/// needs data the config lacks (`radius` for cylinder, caps and tube; `rect` for rectangle;
/// and the same for their `_upper` variants).
/// A textured configuration (`texture`, src/input/texture.rs) integrates the tinted emitter;
/// a rectangle is never textured (`Config::validate` refuses one with a texture).
pub fn reference(config: &Config, target: Target) -> Option<Estimate> {
    let lobe = Lobe::new(&config.material);
    let (p1, p2, radius) = (config.p1, config.p2, config.radius);
    let tex = config.texture.as_ref();
    match target {
        Target::Line => Some(line::line_textured(&lobe, p1, p2, false, tex)),
        Target::LineUpper => Some(line::line_textured(&lobe, p1, p2, true, tex)),
        Target::LineIsotropic => Some(line::line_isotropic_textured(&lobe, p1, p2, tex)),
        // The material's lobe and the Lambertian base integrated apart (each with its own
        // splits and peaks), the values and error estimates summed.
        Target::LineSum => Some(sum(
            line::line_textured(&lobe, p1, p2, false, tex),
            line::line_textured(&Lobe::new(&Material::Diffuse), p1, p2, false, tex),
        )),
        Target::LineIsotropicSum => Some(sum(
            line::line_isotropic_textured(&lobe, p1, p2, tex),
            line::line_isotropic_textured(&Lobe::new(&Material::Diffuse), p1, p2, tex),
        )),
        Target::Cylinder | Target::CylinderUpper => {
            radius.map(|r| surface::cylinder(&lobe, p1, p2, r, target == Target::CylinderUpper, tex))
        }
        Target::Caps | Target::CapsUpper => {
            radius.map(|r| surface::caps(&lobe, p1, p2, r, target == Target::CapsUpper, tex))
        }
        Target::Tube | Target::TubeUpper => {
            let upper = target == Target::TubeUpper;
            radius.map(|r| {
                sum(
                    surface::cylinder(&lobe, p1, p2, r, upper, tex),
                    surface::caps(&lobe, p1, p2, r, upper, tex),
                )
            })
        }
        Target::Rectangle | Target::RectangleUpper => config
            .rect
            .as_ref()
            .filter(|_| tex.is_none())
            .map(|rect| surface::rectangle(&lobe, p1, p2, rect, target == Target::RectangleUpper)),
    }
}

fn sum(a: Estimate, b: Estimate) -> Estimate {
    Estimate {
        value: a.value + b.value,
        error: a.error + b.error,
    }
}

/// D(ω) in f64 for a unit ω (docs/conventions.md): `max(0, ω.z)/π` for the diffuse material, Listing
/// 1.10 (with |det M⁻¹|) for an LTC, the GGX lobe for `ggx` (not its fed LTC).
pub fn distribution(material: &Material, w: Vec3) -> f64 {
    match material {
        Material::Diffuse => w[2].max(0.0) / std::f64::consts::PI,
        Material::Ltc { .. } | Material::Ggx { .. } => Lobe::new(material).eval(w),
    }
}

/// The estimate of an integral `q` computed from rounded geometry. Coordinates of size `far`
/// carry rounding errors of a few ε·far, which count relative to `near`, the distance that
/// sets the integral's scale (for a line, its distance from the origin); directions rounded
/// by ε move D by up to `lobe.condition()`·ε, relatively.
fn estimate(q: Quad, lobe: &Lobe, far: f64, near: f64) -> Estimate {
    let condition = far / near + lobe.condition();
    Estimate {
        value: q.value,
        error: q.error + 4.0 * f64::EPSILON * condition * q.abs,
    }
}

fn mul(a: Vec3, s: f64) -> Vec3 {
    a.map(|x| x * s)
}

/// The part of `v` perpendicular to the unit vector `u`; the second pass removes what the
/// rounding of the first left along `u`.
fn reject(v: Vec3, u: Vec3) -> Vec3 {
    let once = |v: Vec3| {
        let t = dot(v, u);
        [v[0] - t * u[0], v[1] - t * u[1], v[2] - t * u[2]]
    };
    once(once(v))
}

#[cfg(test)]
pub(crate) mod testing;
