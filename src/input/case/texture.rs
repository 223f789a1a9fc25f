//! A family's light texture as a case distribution: `[materials.texture]` names the
//! kind, the size and a pattern whose parameters are drawn per configuration like every other
//! parameter of the case; the texels are made here from the drawn values (docs/textures.md,
//! "Texture content in a case").
//!
//! ```toml
//! [materials.texture]
//! kind = "cylindrical"          # or "cubemap"
//! size = [64, 8]                # [nu, nv]; a cubemap's face [n, n]
//! pattern = { shape = "stripes", direction = "along",
//!             frequency = { dist = "log_uniform", min = 0.5, max = 16.0 },
//!             contrast = { dist = "uniform", min = 0.2, max = 0.8 } }
//! ```
//!
//! Every texel is `1 + contrast·w` with the pattern's profile w ∈ [−1, 1] at the texel's centre,
//! so the texture's values lie in [1 − contrast, 1 + contrast]:
//! - `stripes`: a square wave, w = +1 where sin(2π(f·x + phase)) ≥ 0, else −1: `frequency` f
//!   periods (one bright and one dark band) per unit of x;
//! - `gradient`: along, w = 2x − 1 (a ramp from one end to the other); around,
//!   w = cos(2π(x − phase)) (one side bright, the other dark);
//! - `step`: a logo-like box, w = +1 inside, −1 outside;
//! - `constant`: every texel 1 (the control: a tint method is then its inner method).
//!
//! x is the texel centre's position in the pattern's direction: cylindrical along, u = l/L (per
//! light length); around, v = φ/2π (per turn). Cubemap (in the light's frame X = origin,
//! Y = ω_t × origin, Z = ω_t, the texel centre's direction ω): along, x = θ/π with θ the angle
//! from +Z (per half turn, from the direction beyond p2 to the one beyond p1); around,
//! x = atan2(ω_y, ω_x)/2π (per turn). A cylindrical step's box is u ∈ [u0, u0 + wu],
//! v ∈ [v0, v0 + wv] (wrapping), with u0, v0 uniform in [0, 1) and wu, wv in [0.1, 0.5]; a
//! cubemap's step is a cap of directions within 15° to 60° of a uniformly drawn direction.

use crate::input::case::Dist;
use crate::input::texture::{Texture, TextureKind, CUBE_AXES, MAX_TEXELS, MAX_TEXTURE_SIDE};
use serde::Deserialize;

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TextureSpec {
    pub kind: TextureKind,
    /// [nu, nv] (cylindrical) or [n, n] (cubemap: each face n×n).
    pub size: [u32; 2],
    pub pattern: Pattern,
}

#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Shape {
    Stripes,
    Gradient,
    Step,
    Constant,
}

#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Direction {
    Along,
    Around,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pattern {
    pub shape: Shape,
    /// `stripes` and `gradient`: which way the texture varies.
    #[serde(default)]
    pub direction: Option<Direction>,
    /// `stripes`: periods per light length (along) or per turn (around; cubemap along: per
    /// half turn), drawn per configuration.
    #[serde(default)]
    pub frequency: Option<Dist>,
    /// Every shape but `constant`: the texels lie in [1 − contrast, 1 + contrast]; in [0, 1].
    #[serde(default)]
    pub contrast: Option<Dist>,
}

/// The values one configuration's texture was made from (the bin axes `frequency` and
/// `texture_contrast`; NaN where the pattern has none).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Drawn {
    pub frequency: f64,
    pub contrast: f64,
    pub phase: f64,
    /// `step`: u0, v0, wu, wv (cylindrical) or the cap's centre and radius (cubemap).
    pub step: [f64; 4],
}

impl TextureSpec {
    /// How many texels each configuration's texture holds.
    pub fn texel_count(&self) -> u64 {
        let [nu, nv] = self.size.map(u64::from);
        match self.kind {
            TextureKind::Cylindrical => nu.saturating_mul(nv),
            TextureKind::Cubemap => nu.saturating_mul(nv).saturating_mul(6),
        }
    }

    /// The keys' values beyond their types; `at` names the table (`materials[0].texture`).
    pub fn check(&self, at: &str) -> Result<(), String> {
        let [nu, nv] = self.size;
        if nu == 0 || nv == 0 || nu > MAX_TEXTURE_SIDE || nv > MAX_TEXTURE_SIDE {
            return Err(format!(
                "`{at}.size` = {:?}: each side must be 1 to {MAX_TEXTURE_SIDE} texels",
                self.size
            ));
        }
        if self.kind == TextureKind::Cubemap && nu != nv {
            return Err(format!(
                "`{at}.size` = {:?}: a cubemap's faces are square ([n, n])",
                self.size
            ));
        }
        if self.texel_count() > MAX_TEXELS {
            return Err(format!(
                "`{at}.size` = {:?}: {} texels per configuration, more than the {MAX_TEXELS} allowed",
                self.size,
                self.texel_count()
            ));
        }
        let p = &self.pattern;
        let key = |k: &str| format!("`{at}.pattern.{k}`");
        let shape = format!("{:?}", p.shape).to_lowercase();
        let (wants_direction, wants_frequency, wants_contrast) = match p.shape {
            Shape::Stripes => (true, true, true),
            Shape::Gradient => (true, false, true),
            Shape::Step => (false, false, true),
            Shape::Constant => (false, false, false),
        };
        for (name, given, wanted) in [
            ("direction", p.direction.is_some(), wants_direction),
            ("frequency", p.frequency.is_some(), wants_frequency),
            ("contrast", p.contrast.is_some(), wants_contrast),
        ] {
            if given && !wanted {
                return Err(format!("{}: a `{shape}` pattern takes no {name}", key(name)));
            }
            if !given && wanted {
                return Err(format!("{}: a `{shape}` pattern needs one", key(name)));
            }
        }
        if let Some(c) = &p.contrast {
            c.check(&key("contrast"))?;
            let (lo, hi) = c.bounds();
            if !(lo >= 0.0 && hi <= 1.0) {
                return Err(format!(
                    "{} draws [{lo}, {hi}]: a contrast is in [0, 1] (texels in [1 − contrast, 1 + contrast] stay ≥ 0)",
                    key("contrast")
                ));
            }
        }
        if let Some(f) = &p.frequency {
            f.check(&key("frequency"))?;
            let (lo, hi) = f.bounds();
            if !(lo > 0.0) {
                return Err(format!(
                    "{} draws [{lo}, {hi}]: periods per light length or turn must be > 0",
                    key("frequency")
                ));
            }
            // Texels across the stripes: at least one per band (two per period), or the texels
            // would not hold the frequency drawn (aliasing).
            let across = match (self.kind, p.direction) {
                (TextureKind::Cylindrical, Some(Direction::Along)) => nu,
                (TextureKind::Cylindrical, _) => nv,
                // A face spans 90°: n texels per quarter turn (around) and about 2n per half
                // turn (along), but its texels span up to 1.6 times the mean angle, and the
                // poles' turns are shorter: ask for n ≥ 2 per period in both.
                (TextureKind::Cubemap, _) => nu,
            };
            if f64::from(across) < 2.0 * hi {
                return Err(format!(
                    "{} draws up to {hi} periods, but `{at}.size` = {:?} holds at most {} (at least two texels per \
                     period across the stripes{}): make the texture larger or the frequency smaller",
                    key("frequency"),
                    self.size,
                    f64::from(across) / 2.0,
                    if self.kind == TextureKind::Cubemap {
                        ", a cubemap's face n ≥ 2 per period"
                    } else {
                        ""
                    }
                ));
            }
        }
        Ok(())
    }

    /// The texels of one configuration's texture, from the drawn values.
    pub fn texture(&self, d: &Drawn) -> Texture {
        let [nu, nv] = self.size.map(|n| n as usize);
        let texels = match self.kind {
            TextureKind::Cylindrical => {
                let mut t = Vec::with_capacity(nu * nv);
                for j in 0..nv {
                    for i in 0..nu {
                        let u = (i as f64 + 0.5) / nu as f64;
                        let v = (j as f64 + 0.5) / nv as f64;
                        t.push(self.value(d, u, v, None));
                    }
                }
                t
            }
            TextureKind::Cubemap => {
                let n = nu;
                let mut t = Vec::with_capacity(6 * n * n);
                for (ka, ks, kt) in CUBE_AXES {
                    for j in 0..n {
                        for i in 0..n {
                            let sc = 2.0 * (i as f64 + 0.5) / n as f64 - 1.0;
                            let tc = 2.0 * (j as f64 + 0.5) / n as f64 - 1.0;
                            let w: [f64; 3] = std::array::from_fn(|k| ka[k] + sc * ks[k] + tc * kt[k]);
                            let len = libm::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
                            let w = w.map(|x| x / len);
                            let along = libm::acos(w[2].clamp(-1.0, 1.0)) / std::f64::consts::PI;
                            let around = libm::atan2(w[1], w[0]) / (2.0 * std::f64::consts::PI);
                            t.push(self.value(d, along, around.rem_euclid(1.0), Some(w)));
                        }
                    }
                }
                t
            }
        };
        Texture {
            kind: self.kind,
            size: self.size,
            texels,
            origin: None,
        }
    }

    /// One texel: `along` and `around` the texel centre's x in either direction (module doc);
    /// `w` a cubemap texel's unit direction.
    fn value(&self, d: &Drawn, along: f64, around: f64, w: Option<[f64; 3]>) -> f64 {
        use std::f64::consts::PI;
        let p = &self.pattern;
        let x = match p.direction {
            Some(Direction::Around) => around,
            _ => along,
        };
        let profile = match p.shape {
            Shape::Constant => return 1.0,
            Shape::Stripes => {
                if libm::sin(2.0 * PI * (d.frequency * x + d.phase)) >= 0.0 {
                    1.0
                } else {
                    -1.0
                }
            }
            Shape::Gradient => match p.direction {
                Some(Direction::Around) => libm::cos(2.0 * PI * (x - d.phase)),
                _ => 2.0 * x - 1.0,
            },
            Shape::Step => {
                let [a, b, c, e] = d.step;
                let inside = match w {
                    None => {
                        // Along the light u clamps, so the box stays on it: its start is
                        // uniform in [0, 1 − wu] (around the light v wraps).
                        let u0 = a * (1.0 - c);
                        let in_u = along >= u0 && along <= u0 + c;
                        let in_v = (around - b).rem_euclid(1.0) <= e;
                        in_u && in_v
                    }
                    Some(w) => {
                        // The cap: centre from (a, b) uniform on the sphere, radius 15°–60° from c.
                        let z = 2.0 * a - 1.0;
                        let r = libm::sqrt((1.0 - z * z).max(0.0));
                        let centre = [r * libm::cos(2.0 * PI * b), r * libm::sin(2.0 * PI * b), z];
                        let radius = (15.0 + 45.0 * (c - 0.1) / 0.4).to_radians();
                        let cos = w[0] * centre[0] + w[1] * centre[1] + w[2] * centre[2];
                        cos >= libm::cos(radius)
                    }
                };
                if inside {
                    1.0
                } else {
                    -1.0
                }
            }
        };
        1.0 + d.contrast * profile
    }
}
