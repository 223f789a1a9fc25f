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
mod trig;
mod vec;

use crate::input::scene::{Config, Material, Vec3};
use crate::input::target::Target;
use lobe::Lobe;
use quadrature::Quad;
use std::collections::{BTreeMap, BTreeSet};
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
    Shared::new(config).target(target)
}

/// The references of several `targets` of one configuration (those that apply to it), each
/// the value [`reference`] gives, with what they share integrated once: `tube` is
/// `cylinder + caps` and `line_sum` is `line` plus the Lambertian base, so the parts a sweep
/// also asks for alone are reused; and a `_upper` target is its unclipped part wherever the
/// clip `[ω.z > 0]` cuts nothing (`Shared::clip_cuts_nothing`).
pub fn references(config: &Config, targets: &BTreeSet<Target>) -> BTreeMap<Target, Estimate> {
    let mut shared = Shared::new(config);
    targets
        .iter()
        .filter_map(|&t| shared.target(t).map(|e| (t, e)))
        .collect()
}

/// The integrals a target is summed from: the target's lobe along the line (thin-cylinder or
/// isotropic emitters), the tube's side and caps, the rectangle, and the Lambertian base of
/// the `_sum` targets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Part {
    Line,
    LineIsotropic,
    LineBase,
    LineIsotropicBase,
    Cylinder,
    Caps,
    Rectangle,
}

/// A margin, relative to the light's size and distance, by which every point of a light must
/// clear the surface for the clip to be skipped: rounding moves the horizon's cuts and the
/// nodes' heights by a few ε of those, 10⁹ times less.
const CLEAR_MARGIN: f64 = 1e-6;

/// One configuration's parts, each integrated at most once.
struct Shared<'a> {
    config: &'a Config,
    lobe: Lobe,
    done: Vec<((Part, bool), Option<Estimate>)>,
}

impl<'a> Shared<'a> {
    fn new(config: &'a Config) -> Shared<'a> {
        Shared {
            config,
            lobe: Lobe::new(&config.material),
            done: Vec::new(),
        }
    }

    fn target(&mut self, target: Target) -> Option<Estimate> {
        let upper = target.upper() == Some(target);
        match target {
            Target::Line | Target::LineUpper => self.part(Part::Line, upper),
            Target::LineIsotropic => self.part(Part::LineIsotropic, false),
            // The material's lobe and the Lambertian base integrated apart (each with its own
            // splits and peaks), the values and error estimates summed.
            Target::LineSum => Some(sum(self.part(Part::Line, false)?, self.part(Part::LineBase, false)?)),
            Target::LineIsotropicSum => Some(sum(
                self.part(Part::LineIsotropic, false)?,
                self.part(Part::LineIsotropicBase, false)?,
            )),
            Target::Cylinder | Target::CylinderUpper => self.part(Part::Cylinder, upper),
            Target::Caps | Target::CapsUpper => self.part(Part::Caps, upper),
            Target::Tube | Target::TubeUpper => {
                Some(sum(self.part(Part::Cylinder, upper)?, self.part(Part::Caps, upper)?))
            }
            Target::Rectangle | Target::RectangleUpper => self.part(Part::Rectangle, upper),
        }
    }

    fn part(&mut self, part: Part, upper: bool) -> Option<Estimate> {
        // The diffuse material's base is its own lobe: the same `Lobe`, the same integral.
        let part = match (part, &self.config.material) {
            (Part::LineBase, Material::Diffuse) => Part::Line,
            (Part::LineIsotropicBase, Material::Diffuse) => Part::LineIsotropic,
            _ => part,
        };
        let upper = upper && !self.clip_cuts_nothing(part);
        if let Some(&(_, e)) = self.done.iter().find(|(k, _)| *k == (part, upper)) {
            return e;
        }
        let e = self.integrate(part, upper);
        self.done.push(((part, upper), e));
        e
    }

    fn integrate(&self, part: Part, upper: bool) -> Option<Estimate> {
        let c = self.config;
        let lobe = &self.lobe;
        let (p1, p2, radius) = (c.p1, c.p2, c.radius);
        let tex = c.texture.as_ref();
        let base = || Lobe::new(&Material::Diffuse);
        match part {
            Part::Line => Some(line::line_textured(lobe, p1, p2, upper, tex)),
            Part::LineIsotropic => Some(line::line_isotropic_textured(lobe, p1, p2, tex)),
            Part::LineBase => Some(line::line_textured(&base(), p1, p2, false, tex)),
            Part::LineIsotropicBase => Some(line::line_isotropic_textured(&base(), p1, p2, tex)),
            Part::Cylinder => radius.map(|r| surface::cylinder(lobe, p1, p2, r, upper, tex)),
            Part::Caps => radius.map(|r| surface::caps(lobe, p1, p2, r, upper, tex)),
            Part::Rectangle => c
                .rect
                .as_ref()
                .filter(|_| tex.is_none())
                .map(|rect| surface::rectangle(lobe, p1, p2, rect, upper)),
        }
    }

    /// The clip `[ω.z > 0]` changes nothing in the quadrature of `part`, which then integrates
    /// exactly what its unclipped version does:
    /// - when D's support plane is the horizon (diffuse, GGX, an LTC whose M⁻¹ has the last
    ///   row (0, 0, 1)): the clip adds no cut (the horizon's are the support's, the same
    ///   values), keeps the same panels, and where a node is below the horizon D is already
    ///   0 (the LTC and GGX lobes test the same `sin χ·u.z + cos χ·v.z` the clip does);
    /// - when every point of the light is above the surface by `CLEAR_MARGIN` of its size and
    ///   distance: the horizon's cuts fall outside every panel and every node is above it.
    fn clip_cuts_nothing(&self, part: Part) -> bool {
        if self.lobe.support() == [0.0, 0.0, 1.0] {
            return true;
        }
        let c = self.config;
        let (p1, p2) = (c.p1, c.p2);
        let e = vec::sub(p2, p1);
        let dir = mul(e, 1.0 / vec::length(e));
        // How far the light reaches below its axis, across it.
        let reach = match part {
            Part::Line => 0.0,
            Part::Cylinder | Part::Caps => match c.radius {
                Some(r) => r * (1.0 - dir[2] * dir[2]).max(0.0).sqrt(),
                None => return false,
            },
            Part::Rectangle => match &c.rect {
                Some(rect) => {
                    let across = vec::cross(rect.normal, dir);
                    0.5 * rect.width * across[2].abs() / vec::length(across)
                }
                None => return false,
            },
            Part::LineIsotropic | Part::LineBase | Part::LineIsotropicBase => return false,
        };
        let size = vec::length(p1).max(vec::length(p2)) + reach;
        p1[2].min(p2[2]) - reach > CLEAR_MARGIN * size
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

#[cfg(test)]
mod shared_tests {
    use super::*;
    use crate::input::scene::{Rect, Roughness};
    use rand::Rng;
    use testing::*;

    /// `reference` as it was before the parts were shared: every target integrated alone.
    fn alone(config: &Config, target: Target) -> Option<Estimate> {
        let lobe = Lobe::new(&config.material);
        let (p1, p2, radius) = (config.p1, config.p2, config.radius);
        let tex = config.texture.as_ref();
        let upper = target.upper() == Some(target);
        match target {
            Target::Line | Target::LineUpper => Some(line::line_textured(&lobe, p1, p2, upper, tex)),
            Target::LineIsotropic => Some(line::line_isotropic_textured(&lobe, p1, p2, tex)),
            Target::LineSum => Some(sum(
                line::line_textured(&lobe, p1, p2, false, tex),
                line::line_textured(&Lobe::new(&Material::Diffuse), p1, p2, false, tex),
            )),
            Target::LineIsotropicSum => Some(sum(
                line::line_isotropic_textured(&lobe, p1, p2, tex),
                line::line_isotropic_textured(&Lobe::new(&Material::Diffuse), p1, p2, tex),
            )),
            Target::Cylinder | Target::CylinderUpper => radius.map(|r| surface::cylinder(&lobe, p1, p2, r, upper, tex)),
            Target::Caps | Target::CapsUpper => radius.map(|r| surface::caps(&lobe, p1, p2, r, upper, tex)),
            Target::Tube | Target::TubeUpper => radius.map(|r| {
                sum(
                    surface::cylinder(&lobe, p1, p2, r, upper, tex),
                    surface::caps(&lobe, p1, p2, r, upper, tex),
                )
            }),
            Target::Rectangle | Target::RectangleUpper => config
                .rect
                .as_ref()
                .filter(|_| tex.is_none())
                .map(|rect| surface::rectangle(&lobe, p1, p2, rect, upper)),
        }
    }

    fn material(k: usize, rng: &mut rand_chacha::ChaCha8Rng) -> Material {
        match k % 5 {
            0 => Material::Diffuse,
            1 => sparse_ltc(rng),
            2 => full_ltc(rng),
            // An LTC whose support plane is the horizon, though it is not diffuse.
            3 => {
                let (a, b, c) = (
                    rng.random_range(1.0..10.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(1.0..10.0),
                );
                Material::Ltc {
                    minv: [[a, 0.0, b], [0.0, c, 0.0], [0.0, 0.0, 1.0]],
                }
            }
            _ => {
                let (vx, vy) = (rng.random_range(-0.7..0.7), rng.random_range(-0.7..0.7));
                let vz = (1.0f64 - vx * vx - vy * vy).sqrt();
                let alpha = Roughness::Aniso([rng.random_range(0.05..0.8), rng.random_range(0.05..0.8)]);
                Material::ggx(alpha, [vx, vy, vz], None).unwrap()
            }
        }
    }

    #[test]
    fn shared_parts_give_every_target_bit_for_bit() {
        // Lights above, across and below the surface, of every material kind: each target of
        // `references` has the bits of the target integrated alone, and both shortcuts (the
        // support plane is the horizon; the light clears it) are taken.
        let mut rng = rng(23);
        let all: BTreeSet<Target> = Target::ALL.into_iter().collect();
        let (mut support, mut clear, mut checked) = (0, 0, 0);
        let mut k = 0;
        while checked < 120 {
            k += 1;
            let p1 = [
                rng.random_range(-2.0..2.0),
                rng.random_range(-2.0..2.0),
                rng.random_range(-0.8..2.0),
            ];
            let p2 = [
                rng.random_range(-2.0..2.0),
                rng.random_range(-2.0..2.0),
                rng.random_range(-0.8..2.0),
            ];
            let e = vec::sub(p2, p1);
            let normal = vec::cross(e, point(&mut rng, 1.0));
            let config = Config {
                id: String::new(),
                p1,
                p2,
                radius: Some(rng.random_range(0.01..0.3)),
                rect: Some(Rect {
                    normal: mul(normal, 1.0 / vec::length(normal)),
                    width: rng.random_range(0.01..0.5),
                }),
                material: material(k, &mut rng),
                texture: None,
            };
            if config.validate().is_err() {
                continue;
            }
            checked += 1;
            let shared = references(&config, &all);
            for t in Target::ALL {
                let (a, b) = (shared.get(&t).copied(), alone(&config, t));
                let bits = |e: Option<Estimate>| e.map(|e| (e.value.to_bits(), e.error.to_bits()));
                assert_eq!(bits(a), bits(b), "{t:?} of {config:?}: {a:?} against {b:?}");
            }
            let s = Shared::new(&config);
            if s.lobe.support() == [0.0, 0.0, 1.0] {
                support += 1;
            } else if s.clip_cuts_nothing(Part::Cylinder) {
                clear += 1;
            }
        }
        assert!(
            support >= 30 && clear >= 10,
            "shortcuts taken: support {support}, clear {clear}"
        );
    }
}
