//! Textured emitters (seed 002's light textures): the factor each emitting point's
//! radiance toward the shading point is multiplied by, as the chord integrals see it.
//!
//! A [`Tint`] is evaluated at a point of a chord (its position `s` from the chord's foot and the
//! unit direction ω from the origin to it) and lists where it has kinks or jumps, so that the
//! quadrature is split there as it is at D's own kinks: positions along the chord (a texel
//! centre along u) and planes through the origin (a cubemap's face edges and texel centres).
//!
//! - cylindrical, on a generator of the tube at angle φ: `T(u, φ/2π)`, u from the position;
//! - cylindrical, on the thin line: the limit of the tube keeps the angular weighting over the
//!   visible half, `W(u) = ½∫ max(0, cos(φ − φ₀)) T(u, φ/2π) dφ` (φ₀ the side facing the origin,
//!   so a constant c gives c); W is piecewise linear in u with the texel columns' W as nodes;
//! - cylindrical, isotropic point emitters: `T(u, φ₀/2π)` (the emission direction's angle);
//! - cubemap: `C(−ω)` in the light's frame, for every target.

use super::quadrature::{integrate, Quad};
use super::vec::{cross, dot, length};
use crate::input::scene::Vec3;
use crate::input::texture::{cube_face, Texture, TextureKind, CUBE_AXES};
use std::f64::consts::{FRAC_PI_2, PI};

/// What multiplies the emitted radiance along one chord.
pub(crate) struct Tint<'a> {
    kind: Kind<'a>,
    /// Where the chord's tint kinks, as positions from its foot.
    pub s_cuts: Vec<f64>,
    /// Planes through the origin where the tint kinks or jumps, each with the cube face it
    /// belongs to (None: a face edge, always cut).
    pub planes: Vec<(Vec3, Option<usize>)>,
    /// The largest |tint| (the texels' largest magnitude): the integrand's |f·T| ≤ |f|·this.
    pub bound: f64,
    /// An absolute bound on the rounding error of one tint value.
    pub rounding: f64,
}

enum Kind<'a> {
    /// A function of u = (s − s0)/L along a texture row or a weight row (nv = 1 or fixed v).
    AlongU {
        texture: &'a Texture,
        v: f64,
        s0: f64,
        len: f64,
        wrap: bool,
    },
    /// The owned 1-row weights W(u) of the thin line.
    Weights { w: Texture, s0: f64, len: f64 },
    /// A cube looked up in direction −ω in the frame (X, Y, Z).
    Cube { texture: &'a Texture, frame: [Vec3; 3] },
}

impl Tint<'_> {
    /// The tint at position `s` of the chord, seen in unit direction `w`.
    pub fn at(&self, s: f64, w: Vec3) -> f64 {
        match &self.kind {
            Kind::AlongU {
                texture,
                v,
                s0,
                len,
                wrap,
            } => {
                let u = (s - s0) / len;
                if *wrap {
                    texture.cylindrical(u, *v)
                } else {
                    texture.bilinear(0, u, *v, false)
                }
            }
            Kind::Weights { w, s0, len } => w.bilinear(0, (s - s0) / len, 0.5, false),
            Kind::Cube { texture, frame } => texture.cube(frame.map(|e| -dot(w, e))),
        }
    }

    /// True when a kink of `plane` found at direction `w` is one: its face is the one `w` looks
    /// up (planes of other faces cross the chord where their face is not used).
    pub fn keeps(&self, face: Option<usize>, w: Vec3) -> bool {
        match (&self.kind, face) {
            (Kind::Cube { frame, .. }, Some(f)) => cube_face(frame.map(|e| -dot(w, e))).0 == f,
            _ => true,
        }
    }
}

fn largest(texture: &Texture) -> f64 {
    texture.texels.iter().fold(0.0, |m, t| m.max(t.abs()))
}

/// Largest difference between neighbouring texels along u and v: a bound on the bilinear
/// interpolant's slope per texel.
fn steps(texture: &Texture) -> (f64, f64) {
    let [nu, nv] = texture.size.map(|n| n as usize);
    let t = &texture.texels;
    let (mut du, mut dv) = (0.0f64, 0.0f64);
    let faces = t.len() / (nu * nv);
    for f in 0..faces {
        for j in 0..nv {
            for i in 0..nu {
                let here = t[f * nu * nv + j * nu + i];
                if i + 1 < nu {
                    du = du.max((t[f * nu * nv + j * nu + i + 1] - here).abs());
                }
                let jn = (j + 1) % nv;
                dv = dv.max((t[f * nu * nv + jn * nu + i] - here).abs());
            }
        }
    }
    (du, dv)
}

/// The light's axis as the tints need it: unit tangent, s0 = p1·ω_t, length, and the unit
/// direction from the axis towards the origin (the side facing it).
pub(crate) struct LightAxis {
    pub dir: Vec3,
    pub s0: f64,
    pub len: f64,
    pub facing: Vec3,
}

impl LightAxis {
    /// The angle φ of a unit vector `n` ⟂ ω_t, from `origin`, right-handed about ω_t.
    fn phi(texture: &Texture, dir: Vec3, n: Vec3) -> f64 {
        let o = texture.origin_for(dir);
        dot(n, cross(dir, o)).atan2(dot(n, o))
    }
}

/// u positions of the texel centres along the light, as chord positions.
fn u_cuts(nu: u32, s0: f64, len: f64) -> Vec<f64> {
    (0..nu)
        .map(|i| s0 + len * (f64::from(i) + 0.5) / f64::from(nu))
        .collect()
}

/// Rounding of u = (s − s0)/L: a few ε of the positions involved, relative to L.
fn u_rounding(s0: f64, len: f64) -> f64 {
    8.0 * f64::EPSILON * (s0.abs() + 2.0 * len) / len
}

/// The cylindrical tint along the tube's generator whose outward normal is `normal`.
pub(crate) fn generator<'a>(texture: &'a Texture, axis: &LightAxis, normal: Vec3) -> Tint<'a> {
    let phi = LightAxis::phi(texture, axis.dir, normal);
    let (du, dv) = steps(texture);
    let nu = f64::from(texture.size[0]);
    let nv = f64::from(texture.size[1]);
    Tint {
        kind: Kind::AlongU {
            texture,
            v: phi / (2.0 * PI),
            s0: axis.s0,
            len: axis.len,
            wrap: true,
        },
        s_cuts: u_cuts(texture.size[0], axis.s0, axis.len),
        planes: Vec::new(),
        bound: largest(texture),
        rounding: du * nu * u_rounding(axis.s0, axis.len) + dv * nv * 8.0 * f64::EPSILON,
    }
}

/// The angles φ (in (−π, π]) of the texel centres around the light: where T kinks in v.
pub(crate) fn v_centres(texture: &Texture) -> Vec<f64> {
    let nv = texture.size[1];
    (0..nv)
        .map(|j| {
            let p = 2.0 * PI * (f64::from(j) + 0.5) / f64::from(nv);
            if p > PI {
                p - 2.0 * PI
            } else {
                p
            }
        })
        .collect()
}

/// The thin line's tint: W(u), each texel column's T weighted by max(0, cos(φ − φ₀)) over
/// the visible half and normalised by 2. Returns the tint and the quadrature's relative error.
pub(crate) fn thin_line<'a>(texture: &'a Texture, axis: &LightAxis) -> Tint<'a> {
    let nu = texture.size[0];
    let phi0 = LightAxis::phi(texture, axis.dir, axis.facing);
    let centres = v_centres(texture);
    let mut cuts = Vec::new();
    for c in &centres {
        for k in [-2.0, 0.0, 2.0] {
            cuts.push(c + k * PI);
        }
    }
    // Panels over the visible half, cut at the texel centres inside it.
    let (lo, hi) = (phi0 - FRAC_PI_2, phi0 + FRAC_PI_2);
    cuts.retain(|&c| c > lo && c < hi);
    cuts.extend([lo, hi]);
    cuts.sort_by(f64::total_cmp);
    cuts.dedup();
    let panels: Vec<(f64, f64)> = cuts.windows(2).map(|w| (w[0], w[1] - w[0])).collect();
    let mut weights = Vec::with_capacity(nu as usize);
    let mut quad_error = 0.0f64;
    for i in 0..nu {
        let u = (f64::from(i) + 0.5) / f64::from(nu);
        let q = integrate(
            |phi| Quad::exact(0.5 * (phi - phi0).cos().max(0.0) * texture.cylindrical(u, phi / (2.0 * PI))),
            &panels,
            1e-15,
            4 * panels.len() + 64,
        );
        weights.push(q.value);
        quad_error = quad_error.max(q.error);
    }
    let w = Texture {
        kind: TextureKind::Cylindrical,
        size: [nu, 1],
        texels: weights,
        origin: None,
    };
    let (du, _) = steps(&w);
    let rounding = du * f64::from(nu) * u_rounding(axis.s0, axis.len) + quad_error;
    Tint {
        bound: largest(texture),
        s_cuts: u_cuts(nu, axis.s0, axis.len),
        planes: Vec::new(),
        rounding,
        kind: Kind::Weights {
            w,
            s0: axis.s0,
            len: axis.len,
        },
    }
}

/// Isotropic point emitters on the axis: each emits toward the origin at φ₀, so T(u, φ₀/2π).
pub(crate) fn isotropic<'a>(texture: &'a Texture, axis: &LightAxis) -> Tint<'a> {
    generator(texture, axis, axis.facing)
}

/// A cubemap tint: C(−ω) in the light's frame. Cuts at the face edges and, per face, at the
/// planes through the texel centres.
pub(crate) fn cube(texture: &Texture, dir: Vec3) -> Tint<'_> {
    let frame = texture.frame(dir);
    let world = |k: [f64; 3]| [0, 1, 2].map(|c| k[0] * frame[0][c] + k[1] * frame[1][c] + k[2] * frame[2][c]);
    let mut planes = Vec::new();
    for (a, b) in [(0, 1), (0, 2), (1, 2)] {
        for sign in [1.0, -1.0] {
            let mut k = [0.0; 3];
            k[a] = 1.0;
            k[b] = sign;
            planes.push((world(k), None));
        }
    }
    let n = texture.size[0];
    for (face, (ka, ks, kt)) in CUBE_AXES.iter().enumerate() {
        for i in 0..n {
            let c = 2.0 * (f64::from(i) + 0.5) / f64::from(n) - 1.0;
            for k in [ks, kt] {
                planes.push((world([0, 1, 2].map(|j| k[j] - c * ka[j])), Some(face)));
            }
        }
    }
    let (du, dv) = steps(texture);
    Tint {
        // A direction rounded by a few ε moves (s, t) by about n·ε texels.
        rounding: (du + dv) * f64::from(n) * 16.0 * f64::EPSILON,
        bound: largest(texture),
        s_cuts: Vec::new(),
        planes,
        kind: Kind::Cube { texture, frame },
    }
}

/// The unit vector from the axis line towards the origin (any ⟂ one when the line passes
/// through it).
pub(crate) fn facing(p1: Vec3, dir: Vec3) -> Vec3 {
    let foot = super::reject(p1, dir);
    let d = length(foot);
    if d > 0.0 {
        foot.map(|x| -x / d)
    } else {
        crate::input::texture::frisvad_b1(dir)
    }
}
