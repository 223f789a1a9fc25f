//! Integrals along a straight line seen from the origin, in angles, and the `line` targets.
//!
//! A line `p(s) = foot + s·dir` (foot ⟂ dir, d = ‖foot‖) is cut at its foot point into two
//! halves. On each, χ is the angle between ω_p and the half's far direction ±dir, so that
//! `s = ±d·cot χ`, `‖p‖ = d/sin χ`, `ds/‖p‖² = dχ/d`, and
//!
//! `∫ D(ω_p)/‖p‖³ ds = (1/d²) ∫ D(sin χ·n ± cos χ·dir) sin χ dχ`,   n = foot/d,
//!
//! a bounded integrand however close the line passes (a peak of width d in s is an interval
//! of O(1) in χ). Measuring χ from the far direction rather than from the foot keeps the
//! angles relatively accurate when the line nearly passes through the origin, and the span
//! of a short, distant segment is computed directly rather than as a difference of angles.
//! Both halves are one integration variable x = ±χ (the sign is the side), so one adaptive
//! run controls the error of their sum.

use super::lobe::{Circle, Lobe};
use super::quadrature::{integrate_batch, integrate_batch_within, Quad, NODES};
use super::tint::{self, LightAxis, Tint};
use super::trig;
use super::vec::{dot, length, sub};
use super::{estimate, mul, reject, Estimate};
use crate::input::scene::Vec3;
use crate::input::texture::{Texture, TextureKind};
use std::f64::consts::PI;

/// `foot + s·dir`, `s ∈ [s0, s0 + len]`, with `foot ⟂ dir` and `dir` unit.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Chord {
    pub foot: Vec3,
    pub dir: Vec3,
    pub s0: f64,
    pub len: f64,
}

/// One side of the foot point: χ ∈ [far, far + span]; `side` = +1 towards +dir.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Half {
    pub side: f64,
    pub far: f64,
    pub span: f64,
}

/// The halves of the interval `s ∈ [s0, s0 + len]` of a line at distance `d > 0`.
/// (At most two, in a fixed array: no allocation per chord.)
pub(crate) fn halves(d: f64, s0: f64, len: f64) -> impl Iterator<Item = Half> {
    let s1 = s0 + len;
    // (side, distance of the near end from the foot, extent)
    let plus = (s1 > 0.0).then_some(if s0 >= 0.0 { (1.0, s0, len) } else { (1.0, 0.0, s1) });
    let minus = (s0 < 0.0).then_some(if s1 <= 0.0 { (-1.0, -s1, len) } else { (-1.0, 0.0, -s0) });
    [plus, minus].into_iter().flatten().map(move |(side, near, ext)| Half {
        side,
        far: d.atan2(near + ext),
        // atan(d/near) − atan(d/(near + ext)) without cancellation.
        span: (d * ext).atan2(d * d + near * (near + ext)),
    })
}

/// Panels `(start, len)` in x = side·χ: each half cut at the angles `cuts(half, out)` pushes
/// to `out` (those outside it are ignored), keeping the pieces whose midpoint passes `keep(x)`.
/// One buffer serves both halves.
pub(crate) fn split_halves(
    halves: impl IntoIterator<Item = Half>,
    cuts: impl Fn(&Half, &mut Vec<f64>),
    keep: impl Fn(f64) -> bool,
) -> Vec<(f64, f64)> {
    let mut panels = Vec::with_capacity(16);
    let mut offsets = Vec::with_capacity(64);
    for h in halves {
        offsets.clear();
        cuts(&h, &mut offsets);
        for c in offsets.iter_mut() {
            *c -= h.far;
        }
        bounds(0.0, h.span, &mut offsets);
        for w in offsets.windows(2) {
            let (lo, len) = (w[0], w[1] - w[0]);
            if keep(h.side * (h.far + lo + 0.5 * len)) {
                let start = if h.side > 0.0 { h.far + lo } else { -(h.far + lo + len) };
                panels.push((start, len));
            }
        }
    }
    panels
}

/// The zeros of `a + b·cos x + c·sin x` in (−π, π] (none or two).
pub(crate) fn trig_zeros(a: f64, b: f64, c: f64) -> impl Iterator<Item = f64> {
    let rho = b.hypot(c);
    if rho < a.abs() || rho == 0.0 {
        return None.into_iter().flatten();
    }
    let (centre, offset) = (c.atan2(b), (-a / rho).acos());
    let wrap = |x: f64| {
        if x > PI {
            x - 2.0 * PI
        } else if x <= -PI {
            x + 2.0 * PI
        } else {
            x
        }
    };
    Some([wrap(centre - offset), wrap(centre + offset)])
        .into_iter()
        .flatten()
}

/// Panels `(start, len)` covering [a, b], cut at the `cuts` inside it.
pub(crate) fn split(a: f64, b: f64, mut cuts: Vec<f64>) -> Vec<(f64, f64)> {
    bounds(a, b, &mut cuts);
    cuts.windows(2).map(|w| (w[0], w[1] - w[0])).collect()
}

/// `cuts` becomes the sorted, distinct panel bounds of [`split`]: a, the cuts inside, b.
fn bounds(a: f64, b: f64, cuts: &mut Vec<f64>) {
    cuts.retain(|&c| c > a && c < b);
    cuts.extend([a, b]);
    cuts.sort_by(f64::total_cmp);
    cuts.dedup();
}

/// Below this angular width a peak gets graded cuts (wider ones are cheap to resolve).
const GRADE_BELOW: f64 = 0.1;

/// Cuts at `centre` and `centre ± width·4^k` (up to π away), so that the panels around a
/// peak of that width grow geometrically and each is resolved by a few rules.
pub(crate) fn graded(centre: f64, width: f64, cuts: &mut Vec<f64>) {
    cuts.push(centre);
    if width >= GRADE_BELOW {
        return;
    }
    // A width that underflowed to 0 (or a subnormal) would never grow past π: start the
    // grading at the smallest normal width, a few hundred cuts at most.
    let mut t = width.max(f64::MIN_POSITIVE);
    while t < PI {
        cuts.extend([centre - t, centre + t]);
        t *= 4.0;
    }
}

/// How a line's emission varies with the direction it is seen from, which sets the weight
/// of `∫ D(ω(χ))·w(χ) dχ` in the angle χ.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Emitter {
    /// A thin Lambertian cylinder: projected width ∝ ‖ω_p × ω_t‖ = sin χ (target `line`).
    Cylinder,
    /// Isotropic point emitters: the same intensity every way, weight 1 (`line_isotropic`).
    Isotropic,
}

/// `∫ D(ω(χ)) sin χ dχ` over the chord's directions, `= d²·∫ D(ω_p)/‖p‖³ ds`, with D
/// replaced by `D·[ω.z > 0]` if `upper`. Zero when the chord passes through the origin.
/// (The references call [`integrate_chord_within`] and [`integrate_segment`]; the tests hold
/// this plain form to brute force.)
#[cfg_attr(not(test), allow(dead_code))]
pub(crate) fn integrate_chord(
    lobe: &Lobe,
    chord: &Chord,
    upper: bool,
    tint: Option<&Tint>,
    rtol: f64,
    max_panels: usize,
) -> Quad {
    integrate_chord_weighted(lobe, chord, upper, Emitter::Cylinder, tint, rtol, max_panels)
}

/// [`integrate_chord`] that also stops once its error is below `atol` (absolute; see
/// `quadrature::integrate_batch_within`): for the inner integrals of `surface.rs`.
pub(crate) fn integrate_chord_within(
    lobe: &Lobe,
    chord: &Chord,
    upper: bool,
    tint: Option<&Tint>,
    (rtol, atol): (f64, f64),
    max_panels: usize,
) -> Quad {
    chord_weighted(lobe, chord, upper, Emitter::Cylinder, tint, (rtol, atol), max_panels)
}

/// [`integrate_chord`] with the weight of `emitter`: for `Isotropic`, `∫ D(ω(χ)) dχ`
/// `= d·∫ D(ω_p)/‖p‖² ds`. With a `tint` (a textured emitter, src/reference/tint.rs) the
/// integrand is multiplied by it, the quadrature is also cut at its kinks, and its rounding
/// (an absolute bound per value, times ∫|f|) is added to the error.
#[cfg_attr(not(test), allow(dead_code))]
pub(crate) fn integrate_chord_weighted(
    lobe: &Lobe,
    chord: &Chord,
    upper: bool,
    emitter: Emitter,
    tint: Option<&Tint>,
    rtol: f64,
    max_panels: usize,
) -> Quad {
    chord_weighted(lobe, chord, upper, emitter, tint, (rtol, 0.0), max_panels)
}

/// [`integrate_chord_weighted`] with the tolerances `(rtol, atol)` of `integrate_chord_within`.
fn chord_weighted(
    lobe: &Lobe,
    chord: &Chord,
    upper: bool,
    emitter: Emitter,
    tint: Option<&Tint>,
    tolerances: (f64, f64),
    max_panels: usize,
) -> Quad {
    let ends = [chord.s0, chord.s0 + chord.len].map(|s| [0, 1, 2].map(|k| chord.foot[k] + s * chord.dir[k]));
    integrate_segment(lobe, chord, ends, upper, emitter, tint, tolerances, max_panels)
}

/// [`integrate_chord_weighted`] with the chord's end points (at `s0` and `s0 + len`) given
/// as exactly as the caller knows them: a segment's own `p1` and `p2` for the `line` targets,
/// whose heights above the surface are then exact inputs (`Crossing`); with the tolerances
/// `(rtol, atol)` of `integrate_chord_within` (a sliver's arc takes `rtol` alone, which is
/// stricter).
#[allow(clippy::too_many_arguments)]
pub(crate) fn integrate_segment(
    lobe: &Lobe,
    chord: &Chord,
    ends: [Vec3; 2],
    upper: bool,
    emitter: Emitter,
    tint: Option<&Tint>,
    (rtol, atol): (f64, f64),
    max_panels: usize,
) -> Quad {
    let d = length(chord.foot);
    if d == 0.0 {
        return Quad::default();
    }
    // Where the integrand is 0 below the horizon (the clip, or D's support is the horizon)
    // and the segment crosses it, the part above it is bounded by an end and the horizon.
    let horizon_zero = upper || lobe.support() == [0.0, 0.0, 1.0];
    let crossing = if horizon_zero {
        Crossing::new(chord, d, ends)
    } else {
        None
    };
    if let Some(c) = crossing.as_ref().filter(|c| c.sliver) {
        return c.integrate(lobe, chord, d, upper, emitter, tint, rtol, max_panels);
    }
    let (n, dir) = (mul(chord.foot, 1.0 / d), chord.dir);
    let circle = lobe.circle(n, dir);
    let support = lobe.support();
    let (sn, sd) = (dot(support, n), dot(support, dir));
    let above = |s: f64, c: f64| !upper || s * n[2] + c * dir[2] > 0.0;
    let panels = split_halves(
        halves(d, chord.s0, chord.len),
        |h, cuts| {
            // The kink of D and, for `upper`, the horizon, where the integrand jumps.
            cuts.extend(trig_zeros(0.0, h.side * sd, sn));
            if upper {
                cuts.extend(trig_zeros(0.0, h.side * dir[2], n[2]));
            }
            // The peak is at χ* or at its antipode χ* + π (χ* ∈ (−π/2, π/2]).
            if let Some((centre, width)) = lobe.circle(n, mul(dir, h.side)).peak() {
                graded(centre, width, cuts);
                graded(centre + PI, width, cuts);
            }
            if let Some(t) = tint {
                // Position s on this side: χ = atan2(d, side·s).
                cuts.extend(
                    t.s_cuts
                        .iter()
                        .filter(|&&s| s * h.side > 0.0)
                        .map(|&s| d.atan2(s * h.side)),
                );
                for &(k, face) in &t.planes {
                    for chi in trig_zeros(0.0, h.side * dot(k, dir), dot(k, n)) {
                        let (s, c) = chi.sin_cos();
                        let w = [0, 1, 2].map(|j| s * n[j] + c * h.side * dir[j]);
                        if chi > 0.0 && t.keeps(face, w) {
                            cuts.push(chi);
                        }
                    }
                }
            }
        },
        |x| {
            let (s, c) = trig::sin_cos(x.abs());
            let c = c * x.signum();
            s * sn + c * sd > 0.0 && above(s, c)
        },
    );
    let integrand = ChordIntegrand {
        circle,
        n,
        dir,
        d,
        upper,
        sin_weight: emitter == Emitter::Cylinder,
        tint,
    };
    let q = integrate_batch_within(&mut |x, out| integrand.batch(x, out), &panels, rtol, atol, max_panels);
    let q = match crossing.as_ref().filter(|c| c.crosses) {
        Some(c) => Quad {
            error: q.error + c.end_terms(lobe, emitter, tint),
            ..q
        },
        None => q,
    };
    with_tint_rounding(q, tint)
}

/// A textured chord's integral with the tint's rounding (an absolute bound per value, times
/// ∫|f|) added to its error.
fn with_tint_rounding(q: Quad, tint: Option<&Tint>) -> Quad {
    match tint {
        Some(t) if t.bound > 0.0 => Quad {
            error: q.error + t.rounding * q.abs / t.bound,
            ..q
        },
        _ => q,
    }
}

/// A segment wholly above the horizon but near it is integrated from its lower end
/// ([`Crossing::integrate`]) when its arc is below this angle (and its lower end below
/// `NEAR_HORIZON`); a crossing is, whatever its width, as long as it is within half of ψ_E.
/// The few crossings left to the halves' panels get their bounds' rounding in the estimate
/// (`Crossing::end_terms`).
const SLIVER_BELOW: f64 = 0.1;

/// A segment wholly above the horizon whose lower end's direction is within this height of it
/// (and whose arc is below `SLIVER_BELOW`) is integrated from that end too: in the halves'
/// frame the integrand's height `sin χ·n.z + cos χ·dir.z` has an absolute rounding of a few
/// ε, ~ε/height of itself (3.7e-12 relative at a height of 4e-5 in the stability case's
/// `short` family, 60× its estimate).
const NEAR_HORIZON: f64 = 0.1;

/// A segment that crosses the horizon where the integrand vanishes below it: the part above
/// is the arc of directions from the end E above the horizon to the crossing X.
///
/// Why: seen in the halves' angle χ, that part is `[χ_X, χ_E]`, an interval between two
/// computed angles, each O(1) with an absolute rounding of a few ε (χ_E from `atan2`, χ_X from
/// `trig_zeros` in a frame whose foot direction carries ~ε·far/d), while the integrand, ∝ the
/// height of ω above the horizon, is itself computed as `sin χ·n.z + cos χ·dir.z`, a difference
/// of O(1) terms. When E is just above the horizon the interval is a sliver of width
/// w ≈ ζ_E/|dω.z/dχ| (ζ_E = E.z/‖E‖), and both roundings, ~ε/w relative, swamp the
/// integral: 5e-8 relative in the stability case's `endpoint_on_horizon` family, against
/// estimates of 3e-11 (docs/references.md). Measured from E the arc is instead
/// `ω(y) = cos y·ω_E + sin y·τ`, y ∈ [0, w], with ω_E = E/‖E‖ (E.z an exact input for the
/// `line` targets) and τ the unit tangent towards X: its height `cos y·ζ_E + sin y·τ.z` is
/// relatively accurate, and `w = atan2(ζ_E, −τ.z)` is the zero of that same computed height,
/// so the bound and the integrand agree to a relative few ε of w.
///
/// A short segment wholly above the horizon but close to it (its lower end's direction within
/// `NEAR_HORIZON`, its arc below `SLIVER_BELOW`) is the same arc, from its lower end to its
/// other end, without the crossing.
#[derive(Clone, Copy, Debug)]
struct Crossing {
    /// ω_E, the unit direction of the end above the horizon.
    omega: Vec3,
    /// τ: the unit tangent of the chord's great circle at ω_E, towards the segment's inside.
    tau: Vec3,
    /// sin ψ_E and cos ψ_E, ψ_E the angle between ω_E and the direction into the segment
    /// (ψ = ψ_E − y along the arc; sin ψ is the `Cylinder` weight sin χ).
    sin_e: f64,
    cos_e: f64,
    /// ‖E‖ and E's position from the foot along `dir`.
    r: f64,
    s_e: f64,
    /// ±1: `dir` or `−dir` points from E into the segment.
    inward: f64,
    /// w: the arc's angle from ω_E to the horizon.
    width: f64,
    /// A bound on w's relative rounding (see `new`).
    width_rel_error: f64,
    /// far/d of the chord, for the frame's rounding in `end_terms`.
    far_over_d: f64,
    /// The segment crosses the horizon (else it is wholly above, and w is its own arc).
    crosses: bool,
    /// Integrated from E ([`Crossing::integrate`]); else by the halves, with `end_terms`.
    sliver: bool,
}

impl Crossing {
    /// The crossing of a segment with one end strictly above the horizon and the other on or
    /// below it, or (`crosses` false) a segment wholly above it, measured from its lower end;
    /// None for one wholly on or below it.
    fn new(chord: &Chord, d: f64, ends: [Vec3; 2]) -> Option<Crossing> {
        let (z0, z1) = (ends[0][2], ends[1][2]);
        let (e, inward, crosses) = if z0 > 0.0 && z1 <= 0.0 {
            (0, 1.0, true)
        } else if z1 > 0.0 && z0 <= 0.0 {
            (1, -1.0, true)
        } else if z0 > 0.0 && z1 > 0.0 {
            // Wholly above: only an arc near the horizon and narrow (its angle is at least its
            // sine len·d/(‖E0‖‖E1‖)) is taken from its lower end; checked first, as cheaply.
            let (r0, r1) = (length(ends[0]), length(ends[1]));
            if z0.min(z1) >= NEAR_HORIZON * r0.max(r1) || chord.len * d >= SLIVER_BELOW * r0 * r1 {
                return None;
            }
            if z0 * r1 <= z1 * r0 {
                (0, 1.0, false)
            } else {
                (1, -1.0, false)
            }
        } else {
            return None;
        };
        let p = ends[e];
        let dir_in = mul(chord.dir, inward);
        let r = length(p);
        let omega = mul(p, 1.0 / r);
        if !crosses && omega[2] >= NEAR_HORIZON {
            return None;
        }
        let t = reject(dir_in, omega);
        let t_len = length(t);
        if !(t_len > 0.0) || (crosses && !(dir_in[2] < 0.0)) {
            return None;
        }
        let tau = mul(t, 1.0 / t_len);
        if crosses && !(tau[2] < 0.0) {
            return None;
        }
        let (sin_e, cos_e) = (d / r, dot(omega, dir_in));
        // Rounding of w = atan2(ζ, −τ.z): ζ = E.z/‖E‖ is relatively exact but for ‖E‖ (≤ 2ε)
        // and the division (ε). τ = t/‖t‖ with t = dir_in − (dir_in·ω)ω (twice): its z is
        // dir_in.z (relatively good to 3ε: p2.z − p1.z and the length) less (dir_in·ω)·ζ
        // (absolute 3ε·ζ), rounded to ε of those, and ‖t‖ = sin ψ_E = d/‖E‖ carries ~3ε/sin ψ_E
        // relatively: |δτ.z| ≤ 8ε·(‖E‖/d)·(|dir_in.z| + ζ + |τ.z|), small in absolute terms when
        // the chord runs close to the horizon. atan2 adds 1 ulp, and with R = hypot(ζ, τ.z)
        // (the height's slope along the arc at X) and w ≥ sin w = ζ/R,
        // |δw|/w ≤ (|τ.z|/R)·|δζ/ζ| + |δτ.z|/R ≤ 4ε + |δτ.z|/R.
        // Wholly above: the arc is the segment's, from E to the point ℓ = len along dir_in,
        // atan2(ℓ sin ψ_E, ‖E‖ + ℓ cos ψ_E), whose arguments carry d's relative ~4ε·‖E‖/d
        // and a few ε more.
        let eps = f64::EPSILON;
        let (width, width_rel_error) = if crosses {
            let slope = omega[2].hypot(tau[2]);
            let heights = -dir_in[2] + omega[2] - tau[2];
            (
                omega[2].atan2(-tau[2]),
                4.0 * eps + 8.0 * eps * (r / d) * heights / slope,
            )
        } else {
            let l = chord.len;
            ((l * sin_e).atan2(r + l * cos_e), 8.0 * eps + 4.0 * eps * (r / d))
        };
        // Integrated from E: a crossing, or a wholly-above arc narrower than `SLIVER_BELOW`,
        // within half of ψ_E (so that the weight sin(ψ_E − y) does not cancel).
        let sliver = (crosses || width < SLIVER_BELOW) && width <= 0.5 * sin_e.atan2(cos_e);
        if !crosses && !sliver {
            return None;
        }
        Some(Crossing {
            omega,
            tau,
            sin_e,
            cos_e,
            r,
            s_e: if e == 0 { chord.s0 } else { chord.s0 + chord.len },
            inward,
            width,
            width_rel_error,
            far_over_d: length(ends[0]).max(length(ends[1])) / d,
            crosses,
            sliver,
        })
    }

    /// ω(y), sin ψ(y) for the arc's angle y from ω_E (from y's sine and cosine).
    #[inline(always)]
    fn at(&self, s: f64, c: f64) -> (Vec3, f64) {
        let w = [0, 1, 2].map(|k| c * self.omega[k] + s * self.tau[k]);
        (w, self.sin_e * c - self.cos_e * s)
    }

    /// The chord integral (`integrate_chord_weighted`) over the arc from ω_E to the horizon,
    /// which is all of it: beyond the crossing the segment stays below the horizon.
    /// Its error adds w's relative rounding times ∫|f| (the integral is ∝ w to first order,
    /// whether f vanishes at X, ∫ ≈ ζ_E·w/2·…, or jumps there, ∫ ≈ f(X)·w).
    #[allow(clippy::too_many_arguments)]
    fn integrate(
        &self,
        lobe: &Lobe,
        chord: &Chord,
        d: f64,
        upper: bool,
        emitter: Emitter,
        tint: Option<&Tint>,
        rtol: f64,
        max_panels: usize,
    ) -> Quad {
        let circle = lobe.circle(self.tau, self.omega);
        let support = lobe.support();
        let mut cuts = Vec::with_capacity(16);
        // D's kink, when it is not the horizon (that one is w), and the peak (mod π, as for
        // the halves).
        if support != [0.0, 0.0, 1.0] {
            cuts.extend(trig_zeros(0.0, dot(support, self.omega), dot(support, self.tau)));
        }
        if let Some((centre, width)) = circle.peak() {
            for c in [centre - PI, centre, centre + PI] {
                graded(c, width, &mut cuts);
            }
        }
        if let Some(t) = tint {
            // The arc's angle to the chord's point at s: atan2(ℓ sin ψ_E, ‖E‖ + ℓ cos ψ_E),
            // ℓ = |s − s_E| into the segment.
            for &s in &t.s_cuts {
                let l = (s - self.s_e) * self.inward;
                if l > 0.0 {
                    cuts.push((l * self.sin_e).atan2(self.r + l * self.cos_e));
                }
            }
            for &(k, face) in &t.planes {
                for y in trig_zeros(0.0, dot(k, self.omega), dot(k, self.tau)) {
                    let (s, c) = y.sin_cos();
                    if y > 0.0 && y < self.width && t.keeps(face, self.at(s, c).0) {
                        cuts.push(y);
                    }
                }
            }
        }
        let panels = split(0.0, self.width, cuts);
        let sin_weight = emitter == Emitter::Cylinder;
        let q = integrate_batch(
            &mut |y: &[f64; NODES], out: &mut [Quad; NODES]| {
                let (mut s, mut c) = ([0.0; NODES], [0.0; NODES]);
                trig::sin_cos_batch(y, &mut s, &mut c);
                let mut f = [0.0; NODES];
                circle.eval_batch(&s, &c, &mut f);
                for i in 0..NODES {
                    let (w, sin_psi) = self.at(s[i], c[i]);
                    let v = if sin_weight { f[i] * sin_psi } else { f[i] };
                    let v = if !upper || w[2] > 0.0 { v } else { 0.0 };
                    out[i] = match tint {
                        None => Quad::exact(v),
                        Some(_) if v == 0.0 => Quad::default(),
                        Some(t) => Quad {
                            value: v * t.at(d * dot(w, chord.dir) / sin_psi, w),
                            error: 0.0,
                            abs: v.abs() * t.bound,
                        },
                    };
                }
            },
            &panels,
            rtol,
            max_panels,
        );
        let q = Quad {
            error: q.error + self.width_rel_error * q.abs,
            ..q
        };
        with_tint_rounding(q, tint)
    }

    /// For a part above the horizon too wide for [`Crossing::integrate`], taken by the halves'
    /// panels: the rounding of its bounds, |f(b)|·δb at E and at X. Elsewhere a bound's
    /// rounding moves the integral by f there times a few ulps, which the relative terms of
    /// `estimate` cover; here E's panel reaches to the horizon, so E's position relative to
    /// the integrand's zero is what sets the integral. δb: χ_E (`atan2` of d and the end's
    /// position, ≤ 1 ulp on arguments good to ~3ε) and χ_X (`trig_zeros`: `atan2`, `acos`, a
    /// sum and a wrap by 2π, ~4 ulp of π) plus their offsets and panel starts (≤ 3 ulp of
    /// π): ≤ 32ε in all; and the frame: n carries ~4ε·far/d (the foot's rounding), which
    /// moves the horizon's zero along the arc by that over the height's slope there,
    /// |dω.z/dy| at X = R = hypot(ζ_E, τ.z) (the height is R·sin(w − y) along the arc):
    /// 8ε·(far/d)/R with a factor 2 to spare. f at X is D there without the clip (0 when
    /// D's support is the horizon; the jump of the clip otherwise).
    fn end_terms(&self, lobe: &Lobe, emitter: Emitter, tint: Option<&Tint>) -> f64 {
        let eps = f64::EPSILON;
        let delta = 32.0 * eps + 8.0 * eps * self.far_over_d / self.omega[2].hypot(self.tau[2]);
        let (s, c) = self.width.sin_cos();
        let (x, sin_x) = self.at(s, c);
        let weight = |sin_psi: f64| if emitter == Emitter::Cylinder { sin_psi } else { 1.0 };
        let f_e = lobe.eval(self.omega) * weight(self.sin_e);
        let f_x = lobe.eval(x) * weight(sin_x.max(0.0));
        let bound = tint.map_or(1.0, |t| t.bound);
        (f_e.abs() + f_x.abs()) * bound * delta
    }
}

/// The integrand of [`integrate_chord_weighted`] in x = side·χ: `D(ω(χ))·w(χ)`, times the
/// tint if any, 0 below the horizon for `upper`.
struct ChordIntegrand<'a> {
    circle: Circle,
    n: Vec3,
    dir: Vec3,
    d: f64,
    upper: bool,
    /// The `Cylinder` weight sin χ (else the `Isotropic` weight 1).
    sin_weight: bool,
    tint: Option<&'a Tint<'a>>,
}

impl ChordIntegrand<'_> {
    /// The value at x from its χ's sine and (signed) cosine.
    #[inline(always)]
    fn finish(&self, f: f64, s: f64, c: f64) -> Quad {
        let f = if self.sin_weight { f * s } else { f };
        let f = if !self.upper || s * self.n[2] + c * self.dir[2] > 0.0 {
            f
        } else {
            0.0
        };
        match self.tint {
            None => Quad::exact(f),
            Some(_) if f == 0.0 => Quad::default(),
            Some(t) => {
                let w = [0, 1, 2].map(|k| s * self.n[k] + c * self.dir[k]);
                // |f·T| ≤ |f|·bound: `abs` stays an upper bound, and ∫|f| = abs/bound.
                Quad {
                    value: f * t.at(self.d * c / s, w),
                    error: 0.0,
                    abs: f.abs() * t.bound,
                }
            }
        }
    }

    /// One node (the batch below is this, node by node; a unit test holds them equal).
    #[cfg_attr(not(test), allow(dead_code))]
    fn at(&self, x: f64) -> Quad {
        let (s, c) = trig::sin_cos(x.abs());
        let c = c * x.signum();
        self.finish(self.circle.eval(s, c), s, c)
    }

    /// A panel's 21 nodes: sin and cos as one straight-line batch, D with its variant
    /// matched once.
    #[allow(clippy::needless_range_loop)]
    fn batch(&self, x: &[f64; NODES], out: &mut [Quad; NODES]) {
        let ax = x.map(f64::abs);
        let (mut s, mut c) = ([0.0; NODES], [0.0; NODES]);
        trig::sin_cos_batch(&ax, &mut s, &mut c);
        for i in 0..NODES {
            c[i] *= x[i].signum();
        }
        let mut f = [0.0; NODES];
        self.circle.eval_batch(&s, &c, &mut f);
        for i in 0..NODES {
            out[i] = self.finish(f[i], s[i], c[i]);
        }
    }
}

const LINE_RTOL: f64 = 1e-13;
const LINE_MAX_PANELS: usize = 400;

/// Targets `line` and `line_upper`: `∫₀ᴸ D(ω_p)·2‖ω_p × ω_t‖/‖p‖² dl`, where
/// `‖ω_p × ω_t‖ = d/‖p‖`, so the integral is `(2/d)·integrate_chord`.
#[cfg_attr(not(test), allow(dead_code))]
pub(crate) fn line(lobe: &Lobe, p1: Vec3, p2: Vec3, upper: bool) -> Estimate {
    line_textured(lobe, p1, p2, upper, None)
}

/// The light's axis for a tint: its tangent, p1·ω_t, length and the side facing the origin.
fn light_axis(p1: Vec3, dir: Vec3, len: f64) -> LightAxis {
    LightAxis {
        dir,
        s0: dot(p1, dir),
        len,
        facing: tint::facing(p1, dir),
    }
}

/// [`line`] of a textured emitter: the thin-line limit of the textured tube (src/reference/tint.rs).
pub(crate) fn line_textured(lobe: &Lobe, p1: Vec3, p2: Vec3, upper: bool, texture: Option<&Texture>) -> Estimate {
    let e = sub(p2, p1);
    let len = length(e);
    let dir = mul(e, 1.0 / len);
    let foot = reject(p1, dir);
    let d = length(foot);
    let far = length(p1).max(length(p2));
    // The foot carries a rounding error of a few ε·‖p‖ (see `estimate`): a d within it may be
    // 0, and the chord's angles are then rounding noise (quadrature over them never settles).
    let foot_error = 4.0 * f64::EPSILON * far;
    if d <= foot_error {
        // Every ω_p is the same and ‖ω_p × ω_t‖ = 0 up to the foot's error, so the true d is
        // below foot_error and I ≤ 2·foot_error·D(ω_p)·∫ds/s³ ≤ foot_error·D(ω_p)/s_near².
        let near = if length(p1) < length(p2) { p1 } else { p2 };
        let r = length(near);
        let most = texture.map_or(1.0, |t| t.texels.iter().fold(0.0f64, |m, x| m.max(x.abs())));
        let bound = most * foot_error * lobe.eval(mul(near, 1.0 / r)) / (r * r);
        return Estimate {
            value: 0.0,
            error: bound,
        };
    }
    let chord = Chord {
        foot,
        dir,
        s0: dot(p1, dir),
        len,
    };
    let axis = light_axis(p1, dir, len);
    let tint = texture.map(|t| match t.kind {
        TextureKind::Cylindrical => tint::thin_line(t, &axis),
        TextureKind::Cubemap => tint::cube(t, dir),
    });
    let q = integrate_segment(
        lobe,
        &chord,
        [p1, p2],
        upper,
        Emitter::Cylinder,
        tint.as_ref(),
        (LINE_RTOL, 0.0),
        LINE_MAX_PANELS,
    )
    .scale(2.0 / d);
    estimate(q, lobe, far, d)
}

/// Target `line_isotropic`: `∫₀ᴸ D(ω_p)/‖p‖² dl`, a line of isotropic point emitters of unit
/// intensity per unit length. With `ds/‖p‖² = dχ/d` it is `(1/d)·∫ D(ω(χ)) dχ`. Unlike
/// `line` it does not vanish when the line runs through the origin: every ω_p is then the
/// same and the integral is `D(ω_p)·(1/‖p_near‖ − 1/‖p_far‖)`.
pub(crate) fn line_isotropic(lobe: &Lobe, p1: Vec3, p2: Vec3) -> Estimate {
    line_isotropic_textured(lobe, p1, p2, None)
}

/// [`line_isotropic`] of a textured emitter: each point emits toward the origin with the
/// texture's value in that direction (cylindrical: T(u, φ₀/2π); cubemap: C(−ω_p)).
pub(crate) fn line_isotropic_textured(lobe: &Lobe, p1: Vec3, p2: Vec3, texture: Option<&Texture>) -> Estimate {
    let e = sub(p2, p1);
    let len = length(e);
    let dir = mul(e, 1.0 / len);
    let foot = reject(p1, dir);
    let d = length(foot);
    let (r1, r2) = (length(p1), length(p2));
    let far = r1.max(r2);
    // As in `line`: a d within the foot's rounding error may be 0.
    if d <= 4.0 * f64::EPSILON * far && texture.is_none() {
        let near = if r1 < r2 { p1 } else { p2 };
        let value = lobe.eval(mul(near, 1.0 / r1.min(r2))) * len / (r1 * r2);
        // A foot rounded to 0 from a few ε·far moves ω_p by that much relative to the
        // near distance, and D by `condition` times it.
        let tilt = 4.0 * f64::EPSILON * far / r1.min(r2);
        return Estimate {
            value,
            error: value * (lobe.condition() * tilt + 4.0 * f64::EPSILON),
        };
    }
    let chord = Chord {
        foot,
        dir,
        s0: dot(p1, dir),
        len,
    };
    if d <= 4.0 * f64::EPSILON * far {
        // Textured and through the origin: not modelled (the emission direction's angle
        // around the axis is undefined there); an error as large as the untextured value.
        let plain = line_isotropic(lobe, p1, p2);
        let most = texture.map_or(1.0, |t| t.texels.iter().fold(0.0f64, |m, x| m.max(x.abs())));
        return Estimate {
            value: 0.0,
            error: most * (plain.value.abs() + plain.error),
        };
    }
    let axis = light_axis(p1, dir, len);
    let tint = texture.map(|t| match t.kind {
        TextureKind::Cylindrical => tint::isotropic(t, &axis),
        TextureKind::Cubemap => tint::cube(t, dir),
    });
    let q = integrate_segment(
        lobe,
        &chord,
        [p1, p2],
        false,
        Emitter::Isotropic,
        tint.as_ref(),
        (LINE_RTOL, 0.0),
        LINE_MAX_PANELS,
    )
    .scale(1.0 / d);
    estimate(q, lobe, far, d)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::scene::Material;
    use crate::reference::distribution;
    use crate::reference::testing::*;
    use crate::reference::vec::cross;
    use rand::Rng;

    fn diffuse() -> Lobe {
        Lobe::new(&Material::Diffuse)
    }

    #[test]
    fn a_peak_whose_width_underflowed_gets_a_bounded_number_of_cuts() {
        // M⁻¹ = diag(1e-160, 1e-160, 1) squares to a width of 0: the grading once looped
        // forever, pushing cuts until memory ran out (found by an audit of eval lines).
        for width in [0.0, 1e-320, f64::MIN_POSITIVE] {
            let mut cuts = Vec::new();
            graded(0.3, width, &mut cuts);
            assert!(cuts.len() < 2 * 600, "width {width}: {} cuts", cuts.len());
            assert!(cuts.iter().all(|c| c.is_finite()));
        }
    }

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs()
    }

    /// The batch integrand is the node-by-node one, bit for bit (all its variants), and an
    /// integral with it agrees with the integrand on std's sin and cos within the estimates.
    #[test]
    #[allow(clippy::needless_range_loop)]
    fn batch_integrand_equals_node_by_node_and_std_trig_within_the_estimates() {
        let mut rng = rng(21);
        let ggx = Material::ggx_fresnel(
            crate::input::scene::Roughness::Iso(0.05),
            [0.6, 0.0, 0.8],
            Some(0.04),
            None,
        )
        .unwrap();
        for i in 0..60 {
            let material = match i % 4 {
                0 => Material::Diffuse,
                1 => sparse_ltc(&mut rng),
                2 => full_ltc(&mut rng),
                _ => ggx.clone(),
            };
            let lobe = Lobe::new(&material);
            let (p1, p2) = (point(&mut rng, 2.0), point(&mut rng, 2.0));
            let e = sub(p2, p1);
            let len = length(e);
            let dir = mul(e, 1.0 / len);
            let foot = reject(p1, dir);
            let d = length(foot);
            let n = mul(foot, 1.0 / d);
            for (upper, sin_weight) in [(false, true), (true, true), (false, false)] {
                let f = ChordIntegrand {
                    circle: lobe.circle(n, dir),
                    n,
                    dir,
                    d,
                    upper,
                    sin_weight,
                    tint: None,
                };
                let x: [f64; NODES] = std::array::from_fn(|_| rng.random_range(-PI..PI));
                let mut out = [Quad::default(); NODES];
                f.batch(&x, &mut out);
                for k in 0..NODES {
                    let one = f.at(x[k]);
                    assert!(
                        one.value.to_bits() == out[k].value.to_bits() && one.abs.to_bits() == out[k].abs.to_bits(),
                        "{i} {k}: {one:?} {:?}",
                        out[k]
                    );
                }
            }
            // The whole chord integral against one on std's sin_cos, node by node.
            let chord = Chord {
                foot,
                dir,
                s0: dot(p1, dir),
                len,
            };
            for upper in [false, true] {
                let fast = integrate_chord(&lobe, &chord, upper, None, 1e-13, 400);
                let circle = lobe.circle(n, dir);
                let panels = split_halves(
                    halves(d, chord.s0, len),
                    |_, cuts| {
                        cuts.extend(trig_zeros(0.0, dot(lobe.support(), dir), dot(lobe.support(), n)));
                        cuts.extend(trig_zeros(0.0, -dot(lobe.support(), dir), dot(lobe.support(), n)));
                        cuts.extend(trig_zeros(0.0, dir[2], n[2]));
                        cuts.extend(trig_zeros(0.0, -dir[2], n[2]));
                    },
                    |_| true,
                );
                let slow = crate::reference::quadrature::integrate(
                    |x| {
                        let (s, c) = x.abs().sin_cos();
                        let c = c * x.signum();
                        let above = !upper || s * n[2] + c * dir[2] > 0.0;
                        Quad::exact(if above { circle.eval(s, c) * s } else { 0.0 })
                    },
                    &panels,
                    1e-13,
                    4000,
                );
                let gap = (fast.value - slow.value).abs();
                assert!(gap <= fast.error + slow.error, "{i} {upper}: {fast:?} {slow:?}");
            }
        }
    }

    /// The segment in its own frame: distance d of the line, foot height c, ω_t.z = t, and the
    /// signed interval [a, b] from the foot that lies above the horizon (None when none does).
    fn above_horizon(p1: Vec3, p2: Vec3) -> Option<(f64, f64, f64, f64, f64)> {
        let e = sub(p2, p1);
        let len = length(e);
        let dir = mul(e, 1.0 / len);
        let foot = reject(p1, dir);
        let (d, c, t) = (length(foot), foot[2], dir[2]);
        let (mut a, mut b) = (dot(p1, dir), dot(p1, dir) + len);
        if t != 0.0 {
            let root = -c / t;
            if t > 0.0 {
                a = a.max(root);
            } else {
                b = b.min(root);
            }
        } else if c <= 0.0 {
            return None;
        }
        (a < b).then_some((d, c, t, a, b))
    }

    /// Diffuse `line` from an antiderivative derived by hand: with u the signed distance
    /// from the foot, D = p.z/(π‖p‖) and ‖ω_p × ω_t‖ = d/‖p‖, so
    /// I = (2d/π)∫ (c + t·u)/(d² + u²)² du over the part with c + t·u > 0 (c = foot.z,
    /// t = ω_t.z), and ∫ (c + t u)/(d²+u²)² du = c·[u/(2d²(d²+u²)) + atan(u/d)/(2d³)] − t/(2(d²+u²)).
    fn diffuse_closed_form(p1: Vec3, p2: Vec3) -> f64 {
        let Some((d, c, t, a, b)) = above_horizon(p1, p2) else {
            return 0.0;
        };
        let f = |u: f64| {
            let q = d * d + u * u;
            c * (u / (2.0 * d * d * q) + (u / d).atan() / (2.0 * d * d * d)) - t / (2.0 * q)
        };
        2.0 * d / PI * (f(b) - f(a))
    }

    /// Diffuse `line_isotropic` by hand: I = (1/π)∫ (c + t·u)/(d² + u²)^{3/2} du over the
    /// part above the horizon, with ∫ = c·u/(d²·sqrt(d²+u²)) − t/sqrt(d²+u²).
    fn diffuse_isotropic_closed_form(p1: Vec3, p2: Vec3) -> f64 {
        let Some((d, c, t, a, b)) = above_horizon(p1, p2) else {
            return 0.0;
        };
        let f = |u: f64| {
            let r = (d * d + u * u).sqrt();
            c * u / (d * d * r) - t / r
        };
        (f(b) - f(a)) / PI
    }

    #[test]
    fn isotropic_diffuse_matches_closed_form_and_is_honest() {
        let mut rng = rng(11);
        for _ in 0..200 {
            let (p1, p2) = (point(&mut rng, 2.0), point(&mut rng, 2.0));
            let exact = diffuse_isotropic_closed_form(p1, p2);
            let est = line_isotropic(&diffuse(), p1, p2);
            let err = (est.value - exact).abs();
            // The closed form itself cancels at c·u/(d²r) − t/r: a few ε of its terms.
            let slack = 1e-13 * exact.abs().max(1e-3);
            assert!(err < slack, "{p1:?} {p2:?}: {est:?} vs {exact}");
            assert!(est.error <= 1e-12 * exact.abs().max(1e-300), "{p1:?} {p2:?}: {est:?}");
        }
        // A point source in the limit: a short segment far away is D(ω)·L/r².
        let est = line_isotropic(&diffuse(), [0.0, 3.0, 4.0], [0.0, 3.0, 4.0 + 1e-6]);
        let point = 0.8 / PI * 1e-6 / 25.0;
        assert!(rel(est.value, point) < 1e-6, "{est:?} {point}");
        // Through the origin (outside the segment): D(ω)(1/r1 − 1/r2), not 0 as for `line`.
        let est = line_isotropic(&diffuse(), [0.0, 0.0, 1.0], [0.0, 0.0, 2.0]);
        assert!(rel(est.value, 0.5 / PI) < 1e-15, "{est:?}");
        assert!(est.error > 0.0 && est.error < 1e-14);
    }

    /// A line through the shading point whose foot rounds to a few ε instead of 0 (p2 = 2·p1 in
    /// floating point): the chord's angles are rounding noise. This once never returned and
    /// grew memory without bound; now it is the exact-0 case, within the foot's error.
    #[test]
    fn a_line_through_the_origin_with_a_rounded_foot_returns_its_limit() {
        let (p1, p2) = ([0.5, 0.25, 1.0], [1.0, 0.5, 2.0]);
        let r1 = length(p1);
        for upper in [false, true] {
            let est = line(&diffuse(), p1, p2, upper);
            assert_eq!(est.value, 0.0, "{est:?}");
            assert!(est.error < 1e-14, "{est:?}");
        }
        // Isotropic: D(ω)(1/r1 − 1/r2) with r2 = 2·r1 and D = cosθ/π.
        let exact = (1.0 / r1) / PI * (1.0 / r1 - 1.0 / (2.0 * r1));
        let est = line_isotropic(&diffuse(), p1, p2);
        assert!(rel(est.value, exact) < 1e-14, "{est:?} {exact}");
        // Just off the origin (d ≈ 1e-9 of the distance) the quadrature still settles.
        let est = line(&diffuse(), p1, [1.0, 0.5, 2.0 + 1e-9], false);
        assert!(
            est.value.is_finite() && est.value >= 0.0 && est.error.is_finite(),
            "{est:?}"
        );
    }

    /// Segments from the stability case (`cases/stability.toml`) with an end just above the
    /// horizon (`endpoint_on_horizon`) or wholly just above it (`short`), diffuse. The truths
    /// are the closed forms of `diffuse_closed_form` and `diffuse_isotropic_closed_form`
    /// evaluated with mpmath at 120 digits from the inputs' exact binary values (agreeing with
    /// 80 digits to < 1e-63; the script is scripts/line_truth.py), rounded to 17 digits here.
    /// On main (848facd) the first three were off by 2.5e-9, 4.6e-7 and 1.1e-7 relative, with
    /// estimates of 3.5e-11, 2.4e-9 and 8.9e-11; the last by 7.1e-13 (estimate 1.1e-13).
    #[test]
    #[allow(clippy::excessive_precision)]
    fn an_end_just_above_the_horizon_matches_high_precision_truth_within_its_estimate() {
        let cases: [(Vec3, Vec3, f64, f64); 4] = [
            (
                [-0.996931885944408, -0.3367132912829677, -0.22157935907725967],
                [-0.9557194294797973, -0.14188389877299717, 7.484663726321696e-08],
                2.5849991199566719e-15,
                1.3290377906691851e-15,
            ),
            (
                [-0.873198341594313, -2.0061220729188, -1.255821781236077],
                [-0.47817777931821975, -1.5337061181470903, 3.108897816518799e-09],
                7.5504375777872285e-19,
                4.1320403896904640e-19,
            ),
            (
                [-0.7348632971998834, 2.0842722437140533, -2.614397095767448],
                [0.2949038652174697, 0.32243596559426224, 1.3143529092824607e-08],
                8.2208548031741091e-16,
                4.1805929864694711e-16,
            ),
            (
                [-1.8201488912485209, -0.6822242006857253, 7.482831313587734e-05],
                [-1.8201512393004207, -0.6822268210606428, 7.574741345506286e-05],
                1.2209088511118370e-11,
                1.1866043720952629e-11,
            ),
        ];
        for (p1, p2, truth, iso_truth) in cases {
            // Both orders of the end points, and `line_upper` (the same integral for diffuse).
            for (a, b) in [(p1, p2), (p2, p1)] {
                for upper in [false, true] {
                    let est = line(&diffuse(), a, b, upper);
                    let err = (est.value - truth).abs();
                    assert!(err <= est.error, "{a:?} {b:?} {upper}: {est:?} vs {truth:e}");
                    assert!(est.error <= 1e-13 * truth, "{a:?} {b:?}: {est:?}");
                }
                let est = line_isotropic(&diffuse(), a, b);
                let err = (est.value - iso_truth).abs();
                assert!(err <= est.error, "{a:?} {b:?}: {est:?} vs {iso_truth:e}");
                assert!(est.error <= 1e-13 * iso_truth, "{a:?} {b:?}: {est:?}");
            }
        }
    }

    /// An end at heights from 1e-3 down to 1e-150 above the horizon, the other below: the part
    /// above is a sliver (`Crossing`) whose diffuse integral goes as the end's height squared.
    /// That scaling needs no truth: halving the height quarters `line` (main's halves lost it
    /// below heights of ~1e-8, where their bounds' rounding is ε/w of the sliver's width w).
    #[test]
    fn a_sliver_above_the_horizon_scales_as_its_height_squared() {
        let (p1, dir) = ([0.3, -0.4, -0.5], [0.2, 0.5, 0.6]);
        // (ζ_E² must stay a normal f64: h down to 1e-150.)
        for h in [1e-3, 1e-6, 1e-9, 1e-12, 1e-60, 1e-150] {
            // p2 on the line from p1 towards dir, lifted to height h exactly.
            let t = (h - p1[2]) / dir[2];
            let p2 = [p1[0] + t * dir[0], p1[1] + t * dir[1], h];
            let lower = [
                p1[0] + (t - 0.5 * h / dir[2]) * dir[0],
                p1[1] + (t - 0.5 * h / dir[2]) * dir[1],
                0.5 * h,
            ];
            let (a, b) = (line(&diffuse(), p1, p2, false), line(&diffuse(), p1, lower, false));
            assert!(a.value > 0.0 && b.value > 0.0, "{h}: {a:?} {b:?}");
            let ratio = a.value / b.value;
            // Exactly 4 as h → 0; the ends' distance, ψ_E and the slope move by O(h) relatively,
            // and the two segments' lines differ by the rounding of lower's x, y (~ε).
            assert!((ratio - 4.0).abs() < 200.0 * h + 1e-8, "{h}: {ratio} {a:?} {b:?}");
            assert!(a.error <= 1e-12 * a.value, "{h}: {a:?}");
        }
    }

    #[test]
    fn isotropic_ltc_is_rotation_consistent_and_scales_as_one_over_s() {
        let mut rng = rng(12);
        for _ in 0..30 {
            let (p1, p2) = (point(&mut rng, 2.0), point(&mut rng, 2.0));
            let r = rotation(&mut rng);
            let rotated = line_isotropic(&Lobe::new(&Material::Ltc { minv: r }), p1, p2).value;
            let moved = line_isotropic(&diffuse(), mat_vec(&r, p1), mat_vec(&r, p2)).value;
            assert!(
                (rotated - moved).abs() < 1e-12 * moved.abs().max(1e-3),
                "{rotated} {moved}"
            );
            let s = rng.random_range(0.01..100.0);
            let scaled = line_isotropic(&diffuse(), mul(p1, s), mul(p2, s)).value;
            let base = line_isotropic(&diffuse(), p1, p2).value;
            assert!((scaled * s - base).abs() < 1e-12 * base.max(1e-3), "{scaled} {base}");
        }
    }

    #[test]
    fn diffuse_parallel_segment_matches_closed_form() {
        for (h, a) in [(1.0f64, 1.0f64), (0.3, 5.0), (2.0, 0.01), (1e-3, 10.0)] {
            let exact = 2.0 / PI * (a / (h * h + a * a) + (a / h).atan() / h);
            for upper in [false, true] {
                let est = line(&diffuse(), [-a, 0.0, h], [a, 0.0, h], upper);
                assert!(rel(est.value, exact) < 1e-12, "h={h} a={a}: {est:?} vs {exact}");
                assert!(est.error >= (est.value - exact).abs(), "{est:?} vs {exact}");
            }
        }
    }

    #[test]
    fn diffuse_random_segments_match_closed_form() {
        let mut rng = rng(1);
        for _ in 0..200 {
            let (p1, p2) = (point(&mut rng, 2.0), point(&mut rng, 2.0));
            let exact = diffuse_closed_form(p1, p2);
            let est = line(&diffuse(), p1, p2, false);
            let tol = 1e-12 * exact.abs().max(1e-3);
            assert!((est.value - exact).abs() < tol, "{p1:?} {p2:?}: {est:?} vs {exact}");
        }
    }

    #[test]
    fn nearly_through_origin_and_short_distant_segments() {
        // A vertical segment at distance d from the z axis: I = (d/π)(1/(d²+z1²) − 1/(d²+z2²)).
        let exact = |d: f64, z1: f64, z2: f64| d / PI * (z2 - z1) * (z2 + z1) / ((d * d + z1 * z1) * (d * d + z2 * z2));
        for d in [1.0, 1e-3, 1e-6, 1e-9, 1e-12] {
            let est = line(&diffuse(), [d, 0.0, 1.0], [d, 0.0, 2.0], true);
            assert!(rel(est.value, exact(d, 1.0, 2.0)) < 1e-12, "d={d}: {est:?}");
        }
        for len in [1e-2, 1e-5, 1e-8] {
            let est = line(&diffuse(), [1.0, 0.0, 30.0], [1.0, 0.0, 30.0 + len], false);
            assert!(
                rel(est.value, exact(1.0, 30.0, 30.0 + len)) < 1e-12,
                "len={len}: {est:?}"
            );
        }
        // Exactly through the origin (outside the segment): ‖ω_p × ω_t‖ = 0.
        let est = line(&diffuse(), [0.0, 0.0, 1.0], [0.0, 0.0, 2.0], false);
        assert_eq!(est.value, 0.0);
        assert!(est.error < 1e-15);
    }

    #[test]
    fn scaled_ltc_is_diffuse_and_rotated_ltc_rotates_the_segment() {
        let mut rng = rng(2);
        for _ in 0..50 {
            let (p1, p2) = (point(&mut rng, 2.0), point(&mut rng, 2.0));
            let base = line(&diffuse(), p1, p2, false).value;
            let s = rng.random_range(0.1..10.0);
            let scaled = Lobe::new(&Material::Ltc {
                minv: [[s, 0.0, 0.0], [0.0, s, 0.0], [0.0, 0.0, s]],
            });
            let v = line(&scaled, p1, p2, false).value;
            assert!((v - base).abs() < 1e-12 * base.max(1e-3), "{v} {base}");
            // D_ltc(ω) = D_diffuse(Rω) and the line integral is rotation invariant.
            let r = rotation(&mut rng);
            let rotated = line(&Lobe::new(&Material::Ltc { minv: r }), p1, p2, false).value;
            let moved = line(&diffuse(), mat_vec(&r, p1), mat_vec(&r, p2), false).value;
            assert!(
                (rotated - moved).abs() < 1e-12 * moved.abs().max(1e-3),
                "{rotated} {moved}"
            );
            // A rotation about z leaves the diffuse lobe as it is.
            let (c, s) = rng.random_range(0.0..6.0f64).sin_cos();
            let about_z = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]];
            let spun = line(&Lobe::new(&Material::Ltc { minv: about_z }), p1, p2, false).value;
            assert!((spun - base).abs() < 1e-12 * base.abs().max(1e-3), "{spun} {base}");
        }
    }

    #[test]
    fn upper_equals_line_for_diffuse_and_cuts_the_leak() {
        let mut rng = rng(3);
        for _ in 0..50 {
            let (p1, p2) = (point(&mut rng, 2.0), point(&mut rng, 2.0));
            let (a, b) = (line(&diffuse(), p1, p2, false), line(&diffuse(), p1, p2, true));
            assert_eq!(a.value, b.value);
        }
        // ω_o.z = 0.8x + z: the lobe reaches below the horizon towards +x.
        let leaky = Lobe::new(&Material::Ltc {
            minv: [[2.0, 0.0, -0.5], [0.0, 2.0, 0.0], [0.8, 0.0, 1.0]],
        });
        let (p1, p2) = ([1.0, 0.2, -0.5], [1.0, -0.1, 1.0]);
        let (all, upper) = (line(&leaky, p1, p2, false), line(&leaky, p1, p2, true));
        assert!(upper.value > 0.0 && upper.value < all.value * 0.99, "{upper:?} {all:?}");
        // Entirely below the horizon: only the leak.
        let below = ([1.0, 0.2, -0.5], [2.0, -0.1, -0.2]);
        assert!(line(&leaky, below.0, below.1, false).value > 0.0);
        assert_eq!(line(&leaky, below.0, below.1, true).value, 0.0);
    }

    #[test]
    fn scales_as_one_over_s() {
        let lobe = Lobe::new(&Material::Ltc {
            minv: [[8.0, 0.3, -1.0], [0.2, 6.0, 0.1], [-0.3, 0.1, 1.0]],
        });
        let (p1, p2) = ([0.3, -0.2, 1.0], [0.9, 0.4, 1.6]);
        let base = line(&lobe, p1, p2, false).value;
        assert!(base > 0.01, "{base}");
        for s in [1e-3, 0.5, 7.0, 1e4] {
            let v = line(&lobe, mul(p1, s), mul(p2, s), false).value;
            assert!(rel(v * s, base) < 1e-12, "s={s}: {v}");
        }
    }

    /// The target by brute force in θ = atan((l − l0)/d) (one angle across the foot, unlike
    /// the halves of `line`), kinks located by bisection, `distribution` for D.
    fn brute_line(material: &Material, p1: Vec3, p2: Vec3, upper: bool, panels: usize) -> f64 {
        let e = sub(p2, p1);
        let len = length(e);
        let t = mul(e, 1.0 / len);
        let c = cross(p1, t);
        let d = length(c);
        let n = cross(t, c).map(|x| x / d);
        let l0 = dot(p1, t);
        let omega = |th: f64| [0, 1, 2].map(|k| th.cos() * n[k] + th.sin() * t[k]);
        let f = |th: f64| {
            let w = omega(th);
            let dd = if upper && w[2] <= 0.0 {
                0.0
            } else {
                distribution(material, w)
            };
            2.0 / d * dd * th.cos()
        };
        let (a, b) = ((l0 / d).atan(), ((l0 + len) / d).atan());
        let minv = material.minv();
        let mut cuts = sign_changes(|th| dot(minv[2], omega(th)), a, b, 4000);
        cuts.extend(sign_changes(|th| omega(th)[2], a, b, 4000));
        brute(f, a, b, &cuts, panels)
    }

    /// `line_isotropic` by brute force in θ = atan((l − l0)/d): dl/‖p‖² = dθ/d.
    fn brute_isotropic(material: &Material, p1: Vec3, p2: Vec3, panels: usize) -> f64 {
        let e = sub(p2, p1);
        let len = length(e);
        let t = mul(e, 1.0 / len);
        let c = cross(p1, t);
        let d = length(c);
        let n = cross(t, c).map(|x| x / d);
        let l0 = dot(p1, t);
        let omega = |th: f64| [0, 1, 2].map(|k| th.cos() * n[k] + th.sin() * t[k]);
        let f = |th: f64| distribution(material, omega(th)) / d;
        let (a, b) = ((l0 / d).atan(), ((l0 + len) / d).atan());
        let minv = material.minv();
        let cuts = sign_changes(|th| dot(minv[2], omega(th)), a, b, 4000);
        brute(f, a, b, &cuts, panels)
    }

    #[test]
    fn isotropic_error_estimate_is_honest_on_sharp_lobes() {
        let mut rng = rng(13);
        for i in 0..24 {
            let (material, p1, p2) = if i % 2 == 0 {
                let m = if i % 4 == 0 {
                    sparse_ltc(&mut rng)
                } else {
                    full_ltc(&mut rng)
                };
                (m, point(&mut rng, 2.0), point(&mut rng, 2.0))
            } else {
                let a = 10f64.powf(rng.random_range(2.0..3.0));
                let minv = [[a, 0.0, 0.2 * a], [0.0, 0.7 * a, 0.0], [0.3, 0.0, 1.0]];
                let m = Material::Ltc { minv };
                let len = 10f64.powf(rng.random_range(-2.0..1.0));
                let (p1, p2) = segment_through_lobe(&m, 1.0, len, 0.1 * len, &mut rng);
                (m, p1, p2)
            };
            let est = line_isotropic(&Lobe::new(&material), p1, p2);
            let exact = brute_isotropic(&material, p1, p2, 40000);
            let err = (est.value - exact).abs();
            assert!(err <= est.error + 1e-15 * exact, "{i}: {est:?} vs {exact}");
            assert!(est.error <= 1e-11 * exact.max(1e-300), "{i}: {est:?}");
        }
    }

    #[test]
    fn error_estimate_is_honest() {
        let mut rng = rng(5);
        for i in 0..24 {
            let material = match i % 3 {
                0 => Material::Diffuse,
                1 => sparse_ltc(&mut rng),
                _ => full_ltc(&mut rng),
            };
            let (p1, p2) = (point(&mut rng, 2.0), point(&mut rng, 2.0));
            let lobe = Lobe::new(&material);
            for upper in [false, true] {
                let est = line(&lobe, p1, p2, upper);
                let exact = brute_line(&material, p1, p2, upper, 2000);
                let err = (est.value - exact).abs();
                // 1e-15·|I| is what the brute sum itself can be off by.
                assert!(
                    err <= est.error + 1e-15 * exact,
                    "{i} {material:?} {p1:?} {p2:?}: {est:?} vs {exact}"
                );
                assert!(est.error <= 1e-12 * exact.max(1e-300), "{i}: {est:?}");
            }
        }
    }

    #[test]
    fn sharp_lobes_through_the_peak() {
        let mut rng = rng(6);
        for i in 0..12 {
            let a = 10f64.powf(rng.random_range(2.0..3.0));
            let minv = [
                [a, 0.0, rng.random_range(-0.3..0.3) * a],
                [0.0, a * rng.random_range(0.5..1.0), 0.0],
                [rng.random_range(-0.5..0.5), 0.0, 1.0],
            ];
            let material = Material::Ltc { minv };
            let len = 10f64.powf(rng.random_range(-2.0..1.0));
            let shift = rng.random_range(-0.6..0.6) * len;
            let (p1, p2) = segment_through_lobe(&material, 1.0, len, shift, &mut rng);
            let est = line(&Lobe::new(&material), p1, p2, true);
            let exact = brute_line(&material, p1, p2, true, 40000);
            let err = (est.value - exact).abs();
            assert!(
                exact > 0.0 && err <= est.error + 1e-15 * exact,
                "{i}: {est:?} vs {exact}"
            );
            // The conditioning term, ~4ε·‖M⁻¹‖‖M‖, is about 1e-12 here.
            assert!(est.error <= 1e-11 * exact, "{i}: {est:?}");
        }
    }
}
