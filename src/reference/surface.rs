//! The surface targets: `cylinder` (Eq. 1.2), `caps` (Eq. 1.29 for both end disks) and
//! `rectangle`. Each is a nested integral whose inner integral runs along a straight line
//! (`integrate_chord`), and whose outer variable is chosen so that the integrand is smooth
//! over only the part of the surface that faces the origin.
//!
//! With `upper`, D is replaced by `D(ω)·[ω.z > 0]` (targets `cylinder_upper`, `caps_upper`,
//! `rectangle_upper`): each inner integral stops at the horizon (`integrate_chord`), and the
//! outer one is cut where the horizon crosses the surface's edges, as it is for D's support.

use super::line::{graded, halves, integrate_chord_within, split, split_halves, trig_zeros, Chord};
use super::lobe::Lobe;
use super::quadrature::{integrate, Quad};
use super::tint::{self, LightAxis, Tint};
use super::vec::{cross, dot, length, sub};
use super::{estimate, mul, reject, Estimate};
use crate::input::scene::{Rect, Vec3};
use crate::input::texture::{Texture, TextureKind};
use std::f64::consts::FRAC_PI_2;

/// The inner integrals are 100× tighter so that their noise stays below the outer error.
const OUTER_RTOL: f64 = 1e-10;
const INNER_RTOL: f64 = 1e-12;
const OUTER_MAX_PANELS: usize = 200;
const INNER_MAX_PANELS: usize = 200;
/// An inner integral also stops once its error is below this share of the largest weighted
/// chord value (|weight·inner|) its outer integral has met so far: see [`Inner`].
const INNER_SHARE: f64 = 1e-13;

/// The inner integrals' tolerance, chosen from the outer integral's need. Each
/// chord stops at `INNER_RTOL` of its own value, or once its error is below `INNER_SHARE` of
/// the largest weighted chord value met so far (over its weight): a chord in the tail of the
/// outer integrand, worth 10⁻⁶ of the peak's, is not resolved to 10⁻¹² of itself. The stop
/// loosens nothing unseen: `quadrature::kronrod` adds every node's error, with the rule's
/// weights, to the outer integral's, so what a chord leaves is in the outer estimate (at most
/// `INNER_SHARE·largest` per unit of the outer variable: below `OUTER_RTOL` of the outer
/// value unless its peak is narrower than a thousandth of its interval), and the outer keeps
/// bisecting until the sum is below its own tolerance. The nodes come in a fixed order (a
/// panel's centre first), so the result is deterministic.
struct Inner {
    largest: f64,
}

impl Inner {
    fn new() -> Inner {
        Inner { largest: 0.0 }
    }

    /// `(rtol, atol)` for the chord whose value the outer integrand multiplies by `weight`.
    fn tolerance(&self, weight: f64) -> (f64, f64) {
        let atol = if weight != 0.0 {
            INNER_SHARE * self.largest / weight.abs()
        } else {
            0.0
        };
        (INNER_RTOL, atol)
    }

    /// The chord's integral, weighted, noted for the next chords' tolerance.
    fn weighted(&mut self, inner: Quad, weight: f64) -> Quad {
        let q = inner.scale(weight);
        if q.value.is_finite() {
            self.largest = self.largest.max(q.value.abs());
        }
        q
    }
}

/// The segment's axis: unit tangent, length, and the foot of the origin on its line
/// (relative to which `s0 = p1·ω_t`).
struct Axis {
    dir: Vec3,
    len: f64,
    s0: f64,
    foot: Vec3,
    far: f64,
}

impl Axis {
    fn new(p1: Vec3, p2: Vec3) -> Axis {
        let e = sub(p2, p1);
        let len = length(e);
        let dir = mul(e, 1.0 / len);
        Axis {
            dir,
            len,
            s0: dot(p1, dir),
            foot: reject(p1, dir),
            far: length(p1).max(length(p2)),
        }
    }

    /// Unit x towards the foot (any perpendicular if the line hits the origin), y = dir × x.
    fn frame(&self) -> (Vec3, Vec3) {
        let d = length(self.foot);
        let x = if d > 0.0 {
            mul(self.foot, 1.0 / d)
        } else {
            let axis = if self.dir[0].abs() < 0.5 {
                [1.0, 0.0, 0.0]
            } else {
                [0.0, 1.0, 0.0]
            };
            let r = reject(axis, self.dir);
            mul(r, 1.0 / length(r))
        };
        (x, cross(self.dir, x))
    }
}

/// Eq. 1.2 with `max(0, −ω_p·ω_n)`. With x towards the foot (distance d) and
/// `ω_n(δ) = −cos δ·x + sin δ·y`, the side faces the origin where
/// `−p·ω_n = d cos δ − R > 0`, i.e. |δ| < acos(R/d), for every l. Along each generator
/// line (fixed δ), `∫ D max(0, −ω_p·ω_n)/‖p‖² R dl = R(d cos δ − R)·∫ D/‖p‖³ dl`.
pub(crate) fn cylinder(
    lobe: &Lobe,
    p1: Vec3,
    p2: Vec3,
    radius: f64,
    upper: bool,
    texture: Option<&Texture>,
) -> Estimate {
    let axis = Axis::new(p1, p2);
    let d = length(axis.foot);
    let gap = d - radius;
    if gap <= 0.0 {
        // The origin is within R of the axis line (beyond an end): no side faces it.
        return Estimate { value: 0.0, error: 0.0 };
    }
    let (x, y) = axis.frame();
    let beta = (radius / d).acos();
    let mut cuts = Vec::new();
    // R·(d cos δ − R)/‖q‖² is a peak of width gap/sqrt(dR) at δ = 0 when the origin is
    // close to the side.
    graded(0.0, gap / (d * radius).sqrt(), &mut cuts);
    // Where the support plane of D (or, for `upper`, the horizon) passes through a rim
    // (l = 0 or L) the generator's inner integral has a kink.
    for plane in planes(lobe, upper) {
        for end in [p1, p2] {
            cuts.extend(trig_zeros(
                dot(plane, end),
                -radius * dot(plane, x),
                radius * dot(plane, y),
            ));
        }
    }
    // A sharp GGX lobe lights the generators its mirror direction reaches: in the
    // cross-section, where the ray (r·x, r·y) meets the circle of centre (d, 0), or the
    // circle's point nearest the ray; an angle w seen from the origin spans d·w/R there.
    if let Some((r, w)) = lobe.mirror() {
        let (kx, ky) = (dot(r, x), dot(r, y));
        let k = kx.hypot(ky);
        if k > 0.0 {
            let (kx, ky) = (kx / k, ky / k);
            let s = d * kx;
            let (cx, cy) = (s * kx - d, s * ky);
            let miss = cx.hypot(cy);
            let (px, py) = if miss < radius {
                let t = s - (radius * radius - miss * miss).sqrt();
                (t * kx, t * ky)
            } else {
                (d + radius * cx / miss, radius * cy / miss)
            };
            graded(py.atan2(d - px), d * w / radius, &mut cuts);
        }
    }
    // A cylindrical texture kinks in δ where a generator passes a texel centre around the
    // axis: its angle φ_j seen as δ = atan2(ω·y, −ω·x).
    if let Some(t) = texture.filter(|t| t.kind == TextureKind::Cylindrical) {
        let o = t.origin_for(axis.dir);
        let b = cross(axis.dir, o);
        for phi in tint::v_centres(t) {
            let w = [0, 1, 2].map(|k| phi.cos() * o[k] + phi.sin() * b[k]);
            cuts.push(dot(w, y).atan2(-dot(w, x)));
        }
    }
    let light = LightAxis {
        dir: axis.dir,
        s0: axis.s0,
        len: axis.len,
        facing: mul(x, -1.0),
    };
    let cube = texture
        .filter(|t| t.kind == TextureKind::Cubemap)
        .map(|t| tint::cube(t, axis.dir));
    let panels = split(-beta, beta, cuts);
    let mut chords = Inner::new();
    let q = integrate(
        |delta| {
            // 1 − cos δ without cancellation, for the side close to the origin:
            // q = (d − R cos δ)·x + R sin δ·y is the generator's foot.
            let versine = 2.0 * (0.5 * delta).sin().powi(2);
            let facing = gap - d * versine;
            let sin = radius * delta.sin();
            let foot = [0, 1, 2].map(|k| (gap + radius * versine) * x[k] + sin * y[k]);
            let chord = Chord {
                foot,
                dir: axis.dir,
                s0: axis.s0,
                len: axis.len,
            };
            let side = texture.filter(|t| t.kind == TextureKind::Cylindrical).map(|t| {
                let (s, c) = delta.sin_cos();
                tint::generator(t, &light, [0, 1, 2].map(|k| -c * x[k] + s * y[k]))
            });
            let tint = side.as_ref().or(cube.as_ref());
            let weight = radius * facing / dot(foot, foot);
            let inner = integrate_chord_within(lobe, &chord, upper, tint, chords.tolerance(weight), INNER_MAX_PANELS);
            chords.weighted(inner, weight)
        },
        &panels,
        OUTER_RTOL,
        OUTER_MAX_PANELS,
    );
    estimate(q, lobe, axis.far + radius, gap)
}

/// Eq. 1.29 for both end disks, one-sided as in Listing 1.8: the disk at p1 (outward normal
/// −ω_t) weighs `max(0, ω_p·ω_t)`, the one at p2 `max(0, −ω_p·ω_t)`.
pub(crate) fn caps(lobe: &Lobe, p1: Vec3, p2: Vec3, radius: f64, upper: bool, texture: Option<&Texture>) -> Estimate {
    let axis = Axis::new(p1, p2);
    // A cylindrical texture leaves the caps untextured; a cubemap tints them.
    let cube = texture
        .filter(|t| t.kind == TextureKind::Cubemap)
        .map(|t| tint::cube(t, axis.dir));
    let mut q = Quad::default();
    let mut near = f64::INFINITY;
    for (height, centre) in [(axis.s0, p1), (-(axis.s0 + axis.len), p2)] {
        if height > 0.0 {
            q += disk(lobe, &axis, centre, height, radius, upper, cube.as_ref());
            near = near.min(height);
        }
    }
    estimate(q, lobe, axis.far + radius, near)
}

/// `∫ D(ω_p) h/‖p‖³ dA` over the disk of radius R at `centre`, in the plane at distance
/// `h > 0` from the origin (normal ω_t). The disk is cut into chords along y: with the
/// origin's foot on the plane as 0 and the centre at X = d along x, the chord at
/// `X = d + R sin t` spans `Y ∈ [−R cos t, R cos t]`, so `dA = R cos t dt dY` has no square
/// root at the rim, and each chord is an `integrate_chord` at distance sqrt(h² + X²).
fn disk(lobe: &Lobe, axis: &Axis, centre: Vec3, height: f64, radius: f64, upper: bool, tint: Option<&Tint>) -> Quad {
    let (x, y) = axis.frame();
    let d = length(axis.foot);
    let plane_foot = mul(axis.dir, dot(centre, axis.dir));
    // h/(h² + X²) peaks where the chord passes the foot (X = 0, or the nearest chord if the
    // foot is outside the disk); the peak is as wide as the t over which h² + X² doubles.
    let t_of = |xx: f64| ((xx - d) / radius).clamp(-1.0, 1.0).asin();
    let nearest = (d - radius).max(0.0);
    let reach = (height * height + 2.0 * nearest * nearest).sqrt();
    let mut cuts = Vec::new();
    graded(t_of(0.0), 0.5 * (t_of(reach) - t_of(-reach)), &mut cuts);
    // Where the support plane of D (or, for `upper`, the horizon) crosses the rim at angle θ
    // (from x), the chord at t = π/2 − |θ| has a kink.
    for plane in planes(lobe, upper) {
        for theta in trig_zeros(dot(plane, centre), radius * dot(plane, x), radius * dot(plane, y)) {
            cuts.push(FRAC_PI_2 - theta.abs());
        }
    }
    // A sharp GGX lobe: the chord through the point its mirror direction hits, the angle w
    // spanning ‖q‖·w/|r·ω_t| across the chords there.
    if let Some((r, w)) = lobe.mirror() {
        let along = dot(plane_foot, axis.dir);
        let rn = dot(r, axis.dir);
        if rn * along > 0.0 {
            let q = mul(r, along / rn);
            let xx = dot(q, x);
            let spread = length(q) * w / rn.abs();
            let t = t_of(xx);
            graded(t, spread / (radius * t.cos().max(1e-3)), &mut cuts);
        }
    }
    let panels = split(-FRAC_PI_2, FRAC_PI_2, cuts);
    let mut chords = Inner::new();
    integrate(
        |t| {
            let (sin, cos) = t.sin_cos();
            let xx = d + radius * sin;
            let chord = Chord {
                foot: [0, 1, 2].map(|k| plane_foot[k] + xx * x[k]),
                dir: y,
                s0: -radius * cos,
                len: 2.0 * radius * cos,
            };
            let weight = radius * cos * height / (height * height + xx * xx);
            let inner = integrate_chord_within(lobe, &chord, upper, tint, chords.tolerance(weight), INNER_MAX_PANELS);
            chords.weighted(inner, weight)
        },
        &panels,
        OUTER_RTOL,
        OUTER_MAX_PANELS,
    )
}

/// The thin two-sided rectangle: `∫∫ D(ω_p)|ω_p·ω_n|/‖p‖² ds dl` with
/// `p = p1 + l ω_t + s ω_b`. Its plane is at signed distance h along `ω_n = ω_t × ω_b`
/// (which is `rect.normal` up to `validate`'s tolerance), so `|ω_p·ω_n| = |h|/‖p‖`. Along
/// ω_t, x = ±|h| cot ψ from the origin's foot turns `|h| dx/(h² + x²)` into dψ, and each
/// line along ω_b is an `integrate_chord` at distance sqrt(h² + x²) = |h|/sin ψ:
/// the integral is `∫ integrate_chord dψ`.
pub(crate) fn rectangle(lobe: &Lobe, p1: Vec3, p2: Vec3, rect: &Rect, upper: bool) -> Estimate {
    let axis = Axis::new(p1, p2);
    let across = cross(rect.normal, axis.dir);
    let across = mul(across, 1.0 / length(across));
    let normal = cross(axis.dir, across);
    let h = dot(p1, normal);
    let dist = h.abs();
    let far = axis.far + rect.width;
    if dist == 0.0 {
        // In the rectangle's plane (validate() excludes the rectangle itself): ω_p·ω_n = 0.
        return Estimate { value: 0.0, error: 0.0 };
    }
    let plane_foot = mul(normal, h);
    let y0 = dot(p1, across) - 0.5 * rect.width;
    let planes = planes(lobe, upper);
    let panels = split_halves(
        halves(dist, axis.s0, axis.len),
        |half, cuts| {
            // Where the support plane of D leaves the rectangle through a long edge, the
            // chord across it has a kink.
            // A sharp GGX lobe: the chord through the point its mirror direction hits.
            if let Some((r, w)) = lobe.mirror() {
                let rn = dot(r, normal);
                if rn * h > 0.0 {
                    let xx = dot(mul(r, h / rn), axis.dir);
                    if xx * half.side > 0.0 {
                        graded(dist.atan2(xx.abs()), w, cuts);
                    }
                }
            }
            for &plane in &planes {
                let along = dot(plane, axis.dir);
                if along == 0.0 {
                    continue;
                }
                for y in [y0, y0 + rect.width] {
                    let xx = -(dot(plane, plane_foot) + y * dot(plane, across)) / along;
                    if xx * half.side > 0.0 {
                        cuts.push(dist.atan2(xx.abs()));
                    }
                }
            }
        },
        |_| true,
    );
    let mut chords = Inner::new();
    let q = integrate(
        |v| {
            let (sin, cos) = v.abs().sin_cos();
            let xx = v.signum() * dist * cos / sin;
            let chord = Chord {
                foot: [0, 1, 2].map(|k| plane_foot[k] + xx * axis.dir[k]),
                dir: across,
                s0: y0,
                len: rect.width,
            };
            let inner = integrate_chord_within(lobe, &chord, upper, None, chords.tolerance(1.0), INNER_MAX_PANELS);
            chords.weighted(inner, 1.0)
        },
        &panels,
        OUTER_RTOL,
        OUTER_MAX_PANELS,
    );
    estimate(q, lobe, far, dist)
}

/// The planes through the origin where the integrand has a kink: D's support plane and, for
/// `upper`, the horizon z = 0.
fn planes(lobe: &Lobe, upper: bool) -> Vec<Vec3> {
    let mut planes = vec![lobe.support()];
    if upper && lobe.support() != [0.0, 0.0, 1.0] {
        planes.push([0.0, 0.0, 1.0]);
    }
    planes
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::scene::Material;
    use crate::reference::line::line;
    use crate::reference::testing::*;
    use std::f64::consts::PI;

    fn diffuse() -> Lobe {
        Lobe::new(&Material::Diffuse)
    }

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs()
    }

    #[test]
    fn thin_cylinder_tends_to_radius_times_line() {
        let mut rng = rng(11);
        for material in [Material::Diffuse, sparse_ltc(&mut rng), full_ltc(&mut rng)] {
            let lobe = Lobe::new(&material);
            let (p1, p2) = segment_through_lobe(&material, 1.0, 1.5, 0.3, &mut rng);
            let i_line = line(&lobe, p1, p2, false).value;
            assert!(i_line > 0.0);
            let mut last = f64::INFINITY;
            for r in [1e-2, 1e-3, 1e-4] {
                let est = cylinder(&lobe, p1, p2, r, false, None);
                let gap = rel(est.value / r, i_line);
                assert!(gap < last, "{material:?} R={r}: {gap:e}");
                assert!(est.error <= 1e-9 * est.value, "{est:?}");
                last = gap;
            }
            assert!(last < 1e-3, "{material:?}: {last:e}");
        }
    }

    #[test]
    fn inner_tolerance_follows_the_largest_weighted_chord() {
        let mut chords = Inner::new();
        // Before any chord, and for a chord the outer integrand multiplies by 0: rtol alone.
        assert_eq!(chords.tolerance(2.0), (INNER_RTOL, 0.0));
        let q = chords.weighted(Quad::exact(3.0), 2.0);
        assert_eq!(q.value, 6.0);
        assert_eq!(chords.tolerance(0.0), (INNER_RTOL, 0.0));
        // A chord weighted 1e-3 may leave 1e-13·6/1e-3 of itself: 1e-13·6 once weighted.
        let (_, atol) = chords.tolerance(1e-3);
        assert!((atol * 1e-3 - INNER_SHARE * 6.0).abs() < 1e-28, "{atol}");
        // A smaller chord leaves the largest as it was; a non-finite one is not noted.
        chords.weighted(Quad::exact(1.0), 1.0);
        chords.weighted(Quad::exact(f64::NAN), 1.0);
        assert_eq!(chords.largest, 6.0);
    }

    #[test]
    fn long_cylinder_above_the_point() {
        // An infinite cylinder parallel to the surface, its axis at height h above the point,
        // spans |φ| < asin(R/h) in the cross-section, so by the 2D crossed-strings form factor
        // E = (sin φ₂ − sin φ₁)/2 = R/h. Ends at ±10⁴h change that by O((h/L)³).
        for r in [0.1, 0.5, 0.9] {
            let est = cylinder(&diffuse(), [-1e4, 0.0, 1.0], [1e4, 0.0, 1.0], r, false, None);
            assert!(rel(est.value, r) < 1e-10, "R={r}: {est:?}");
            assert!(est.error < 1e-9 * r, "R={r}: {est:?}");
        }
    }

    #[test]
    fn small_caps_tend_to_point_disks() {
        // Eq. 1.32 as the limit of the definition: I_disk ≈ πR² D(ω_p) max(0, ±ω_p·ω_t)/‖p‖².
        let lobe = Lobe::new(&Material::Ltc {
            minv: [[3.0, 0.0, 0.5], [0.0, 2.5, 0.0], [-0.2, 0.0, 1.0]],
        });
        // Only one end can face the origin; try each.
        for (p1, p2) in [([0.2, 0.1, 1.0], [0.5, 0.3, 2.0]), ([0.5, 0.3, 2.0], [0.2, 0.1, 1.0])] {
            let t = mul(sub(p2, p1), 1.0 / length(sub(p2, p1)));
            let point = |p: Vec3, sign: f64| {
                let r = length(p);
                let w = mul(p, 1.0 / r);
                lobe.eval(w) * (sign * dot(w, t)).max(0.0) / (r * r)
            };
            let limit = point(p1, 1.0) + point(p2, -1.0);
            assert!(limit > 0.0);
            let r = 1e-3;
            let est = caps(&lobe, p1, p2, r, false, None);
            assert!(rel(est.value / (PI * r * r), limit) < 1e-4, "{est:?} {limit}");
        }
    }

    #[test]
    fn disk_seen_head_on() {
        // E = (1/π)∫ cos θ dω over a cone of half-angle θm = sin²θm = R²/(h² + R²).
        for (h, r) in [(1.0, 1.0), (2.0, 0.01), (0.01, 3.0), (1.0, 1e-4)] {
            let exact = r * r / (h * h + r * r);
            let est = caps(&diffuse(), [0.0, 0.0, h], [0.0, 0.0, h + 1.0], r, false, None);
            assert!(rel(est.value, exact) < 1e-10, "h={h} R={r}: {est:?} vs {exact}");
            assert!((est.value - exact).abs() <= est.error, "{est:?} vs {exact}");
        }
        // Off axis but with the foot inside the disk, and seen from beside the tube.
        let est = caps(&diffuse(), [0.3, 0.0, 0.5], [0.3, 0.0, 1.5], 1.0, false, None);
        assert!(est.value > 0.0 && est.value < 1.0);
        let side = cylinder(&diffuse(), [0.3, 0.0, 0.5], [0.3, 0.0, 1.5], 1.0, false, None);
        assert_eq!(side.value, 0.0);
    }

    #[test]
    fn rectangle_parallel_to_the_surface() {
        // Form factor from a point to a parallel rectangle with a corner above it, sides
        // a·h and b·h: F = (1/2π)[A atan(b·A) + B atan(a·B)], A = 1/√(1+a²)·a… written out:
        let corner = |a: f64, b: f64| {
            let (sa, sb) = ((1.0 + a * a).sqrt(), (1.0 + b * b).sqrt());
            (a / sa * (b / sa).atan() + b / sb * (a / sb).atan()) / (2.0 * PI)
        };
        for (h, len, w) in [(1.0, 2.0, 1.0), (0.5, 0.1, 3.0), (3.0, 10.0, 0.01)] {
            for normal in [[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]] {
                let rect = Rect { normal, width: w };
                // Centred above the origin: four corner rectangles.
                let est = rectangle(&diffuse(), [-len / 2.0, 0.0, h], [len / 2.0, 0.0, h], &rect, false);
                let exact = 4.0 * corner(len / 2.0 / h, w / 2.0 / h);
                assert!(rel(est.value, exact) < 1e-10, "{h} {len} {w}: {est:?} vs {exact}");
                // A corner above the origin.
                let est = rectangle(&diffuse(), [0.0, w / 2.0, h], [len, w / 2.0, h], &rect, false);
                let exact = corner(len / h, w / h);
                assert!(rel(est.value, exact) < 1e-10, "{h} {len} {w}: {est:?} vs {exact}");
                assert!((est.value - exact).abs() <= est.error, "{est:?} vs {exact}");
            }
        }
    }

    #[test]
    fn surfaces_are_scale_invariant() {
        let mut rng = rng(12);
        let lobe = Lobe::new(&full_ltc(&mut rng));
        let (p1, p2) = ([0.3, -0.2, 1.0], [0.9, 0.4, 1.6]);
        let normal = {
            let n = cross(sub(p2, p1), [0.0, 0.0, 1.0]);
            mul(n, 1.0 / length(n))
        };
        let all = |s: f64| {
            let (a, b) = (mul(p1, s), mul(p2, s));
            let rect = Rect { normal, width: 0.2 * s };
            [
                cylinder(&lobe, a, b, 0.1 * s, false, None).value,
                caps(&lobe, a, b, 0.1 * s, false, None).value,
                rectangle(&lobe, a, b, &rect, false).value,
            ]
        };
        let base = all(1.0);
        for s in [1e-3, 7.0, 1e4] {
            for (v, b) in all(s).iter().zip(base) {
                assert!((v - b).abs() <= 1e-10 * b.abs().max(1e-6), "s={s}: {v} {b}");
            }
        }
    }
}
