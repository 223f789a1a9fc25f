//! `reference()` on `ggx` materials against a second quadrature written here from docs/conventions.md
//! alone: its own GGX D (normalised half vector, Λ as written), composite Gauss–Legendre on
//! equal panels in the parametrisations of `reference_independent.rs`, and the lobe's peak
//! found by a dense search of the integrand (not from the mirror direction the reference
//! uses), with cuts graded geometrically around it. Lines to 1e-8, surfaces (rectangle,
//! cylinder, caps, tube) to 1e-7, α down to 0.01, isotropic and anisotropic.

use linelight::input::scene::{Config, Material, Rect, Roughness, Vec3};
use linelight::input::target::Target;
use linelight::reference::reference;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::f64::consts::PI;

use crate::common;
use common::independent::*;

/// The argmax of g over [a, b] on a dense grid, and cuts at it and at (b − a)·2⁻ᵏ either side.
fn peak_cuts(g: &dyn Fn(f64) -> f64, a: f64, b: f64) -> Vec<f64> {
    let n = 1500;
    let x = (0..=n)
        .map(|i| a + (b - a) * i as f64 / n as f64)
        .max_by(|x, y| g(*x).total_cmp(&g(*y)))
        .unwrap();
    let mut cuts = vec![x];
    let mut t = (b - a) / 2.0;
    while t > (b - a) * 1e-7 {
        cuts.extend([x - t, x + t]);
        t /= 2.0;
    }
    cuts
}

fn material(c: &Config) -> ([f64; 2], Vec3) {
    match &c.material {
        Material::Ggx { alpha, view, .. } => (alpha.xy(), *view),
        _ => unreachable!(),
    }
}

/// `line` in u with l = l0 + d·sinh u (integrand 2D/(d cosh²u)); cuts at the horizon and
/// graded about the peak.
fn line(c: &Config) -> f64 {
    let (alpha, v) = material(c);
    line_of(c, &|w| ggx_d(alpha, v, w), 2)
}

/// `line_isotropic` in the same variable: dl/‖p‖² = du/(d cosh u), no projected width.
fn line_isotropic(c: &Config) -> f64 {
    let (alpha, v) = material(c);
    line_of(c, &|w| ggx_d(alpha, v, w), 1)
}

fn lambert(w: Vec3) -> f64 {
    w[2].max(0.0) / PI
}

/// ∫ D(ω_p)·(2/cosh u if `power` is 2, else 1)/(d cosh u) du over the segment.
fn line_of(c: &Config, d_of: &dyn Fn(Vec3) -> f64, power: i32) -> f64 {
    let e = sub(c.p2, c.p1);
    let len = norm(e);
    let t = mul(e, 1.0 / len);
    let l0 = -dot(c.p1, t);
    let d = norm(cross(c.p1, t));
    let u = |l: f64| ((l - l0) / d).asinh();
    let width = if power == 2 { 2.0 } else { 1.0 };
    let f = |x: f64| {
        let p = add(c.p1, mul(t, l0 + d * x.sinh()));
        width * d_of(unit(p)) / (d * x.cosh().powi(power))
    };
    let (a, b) = (u(0.0), u(len));
    let mut cuts = peak_cuts(&f, a, b);
    if t[2] != 0.0 {
        cuts.push(u(-c.p1[2] / t[2]));
    }
    composite(&f, a, b, &cuts, 6)
}

/// `rectangle` in (l, s), both sinh-graded about the origin's foot on the plane, with the
/// peak of the integrand along each line graded as well.
fn rectangle(c: &Config) -> f64 {
    let (alpha, v) = material(c);
    let rect = c.rect.as_ref().unwrap();
    let e = sub(c.p2, c.p1);
    let len = norm(e);
    let t = mul(e, 1.0 / len);
    let wb = unit(cross(rect.normal, t));
    let n = cross(t, wb);
    let h = dot(c.p1, n);
    let half = rect.width / 2.0;
    let (lf, sf) = (-dot(c.p1, t), -dot(c.p1, wb));
    let u = |l: f64| ((l - lf) / h.abs()).asinh();
    let inner = |l: f64| {
        let base = add(c.p1, mul(t, l));
        let dl = (h * h + (l - lf).powi(2)).sqrt();
        let vv = |s: f64| ((s - sf) / dl).asinh();
        let f = |x: f64| {
            let s = sf + dl * x.sinh();
            let p = add(base, mul(wb, s));
            let w = unit(p);
            ggx_d(alpha, v, w) * dot(w, n).abs() / dot(p, p) * dl * x.cosh()
        };
        let (a, b) = (vv(-half), vv(half));
        let mut cuts = peak_cuts(&f, a, b);
        if wb[2] != 0.0 {
            cuts.push(vv(-base[2] / wb[2]));
        }
        composite(&f, a, b, &cuts, 2)
    };
    let f = |x: f64| {
        let l = lf + h.abs() * x.sinh();
        inner(l) * h.abs() * x.cosh()
    };
    let (a, b) = (u(0.0), u(len));
    // The outer peak from a coarse look at the inner integral along the segment.
    let coarse = |x: f64| {
        let l = lf + h.abs() * x.sinh();
        let base = add(c.p1, mul(t, l));
        (0..=64)
            .map(|k| {
                let s = -half + rect.width * k as f64 / 64.0;
                ggx_d(alpha, v, unit(add(base, mul(wb, s))))
            })
            .fold(0.0, f64::max)
            * x.cosh()
    };
    let mut cuts = peak_cuts(&coarse, a, b);
    for s in [-half, half] {
        let base = add(c.p1, mul(wb, s));
        if t[2] != 0.0 {
            cuts.push(u(-base[2] / t[2]));
        }
    }
    composite(&f, a, b, &cuts, 2)
}

/// ∫∫ f(x, y) dy dx over x ∈ [a, b], y ∈ [lo(x), hi(x)], each direction cut at `cuts_x` /
/// `cuts_y(x)` and graded about the peak of f (the outer one from a coarse look along y).
fn nested(
    f: &(dyn Fn(f64, f64) -> f64 + Sync),
    (a, b): (f64, f64),
    range_y: &dyn Fn(f64) -> (f64, f64),
    cuts_x: &[f64],
    cuts_y: &dyn Fn(f64) -> Vec<f64>,
) -> f64 {
    let inner = |x: f64| {
        let (lo, hi) = range_y(x);
        if hi.is_nan() || lo.is_nan() || hi <= lo {
            return 0.0;
        }
        let g = |y: f64| f(x, y);
        let mut cuts = peak_cuts(&g, lo, hi);
        cuts.extend(cuts_y(x));
        composite(&g, lo, hi, &cuts, 2)
    };
    let coarse = |x: f64| {
        let (lo, hi) = range_y(x);
        (0..=64)
            .map(|k| f(x, lo + (hi - lo) * k as f64 / 64.0))
            .fold(0.0, f64::max)
    };
    let mut cuts = peak_cuts(&coarse, a, b);
    cuts.extend_from_slice(cuts_x);
    composite(&inner, a, b, &cuts, 2)
}

/// The solutions φ ∈ [−2π, 4π) of a + b cos φ + c sin φ = 0 (every period a caller may use).
fn trig_roots(a: f64, b: f64, c: f64) -> Vec<f64> {
    let r = b.hypot(c);
    if r == 0.0 || a.abs() > r {
        return Vec::new();
    }
    let (g, h) = (c.atan2(b), (-a / r).acos());
    [g - h, g + h]
        .iter()
        .flat_map(|x| [x - 2.0 * PI, *x, x + 2.0 * PI])
        .collect()
}

/// `cylinder` per Eq. 1.2 in (l, φ) over the arc that faces the origin.
fn cylinder(c: &Config) -> f64 {
    let (alpha, v) = material(c);
    let r = c.radius.unwrap();
    let e = sub(c.p2, c.p1);
    let len = norm(e);
    let t = mul(e, 1.0 / len);
    let (e1, e2) = basis(t);
    let wn = |phi: f64| add(mul(e1, phi.cos()), mul(e2, phi.sin()));
    let (a, b) = (dot(c.p1, e1), dot(c.p1, e2));
    let rho = a.hypot(b);
    if rho <= r {
        return 0.0;
    }
    let half = (r / rho).acos();
    let centre = b.atan2(a) + PI;
    let f = |l: f64, phi: f64| {
        let n = wn(phi);
        let p = add(add(c.p1, mul(t, l)), mul(n, r));
        let w = unit(p);
        ggx_d(alpha, v, w) * (-dot(w, n)).max(0.0) / dot(p, p) * r
    };
    // The horizon crosses a generator where p.z = 0.
    let horizon = |phi: f64| -> Vec<f64> {
        let p0 = add(c.p1, mul(wn(phi), r));
        if t[2] != 0.0 {
            vec![-p0[2] / t[2]]
        } else {
            vec![]
        }
    };
    // Outer φ, inner l (the horizon cut is along l); the outer kinks where that cut passes
    // an end of the tube.
    let mut outer = Vec::new();
    for end in [c.p1, c.p2] {
        outer.extend(trig_roots(end[2], r * e1[2], r * e2[2]));
    }
    nested(
        &|phi, l| f(l, phi),
        (centre - half, centre + half),
        &|_| (0.0, len),
        &outer,
        &horizon,
    )
}

/// `caps` per Eq. 1.29 in each disk's polar coordinates (φ outer, r inner), one-sided.
fn caps(c: &Config) -> f64 {
    let (alpha, v) = material(c);
    let radius = c.radius.unwrap();
    let t = unit(sub(c.p2, c.p1));
    let (e1, e2) = basis(t);
    let mut total = 0.0;
    for (centre, normal) in [(c.p1, t), (c.p2, mul(t, -1.0))] {
        if dot(centre, normal) <= 0.0 {
            continue;
        }
        let u = |phi: f64| add(mul(e1, phi.cos()), mul(e2, phi.sin()));
        let f = |phi: f64, rr: f64| {
            let p = add(centre, mul(u(phi), rr));
            let w = unit(p);
            rr * ggx_d(alpha, v, w) * dot(w, normal).max(0.0) / dot(p, p)
        };
        let horizon = |phi: f64| -> Vec<f64> {
            let uz = u(phi)[2];
            if uz != 0.0 {
                vec![-centre[2] / uz]
            } else {
                vec![]
            }
        };
        // The outer kinks where the horizon crosses the rim.
        let outer = trig_roots(centre[2], radius * e1[2], radius * e2[2]);
        total += nested(&f, (0.0, 2.0 * PI), &|_| (0.0, radius), &outer, &horizon);
    }
    total
}

fn ggx(rng: &mut ChaCha8Rng, i: usize) -> Material {
    let a = 10f64.powf(rng.random_range(-2.0..0.0));
    let alpha = if i.is_multiple_of(2) {
        Roughness::Iso(a)
    } else {
        Roughness::Aniso([a, a * 10f64.powf(rng.random_range(-0.6..0.6)).min(1.0 / a)])
    };
    let theta = rng.random_range(0.0..85.0f64).to_radians();
    let phi = rng.random_range(0.0..2.0 * PI);
    let view = [theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()];
    Material::ggx(alpha, view, Some("table"))
        .or_else(|_| Material::ggx(alpha, view, Some("fit")))
        .unwrap()
}

/// A configuration whose segment passes near the mirror direction (every other one), so
/// that the lobe's peak is inside the integral, and a rectangle beside it.
fn config(rng: &mut ChaCha8Rng, i: usize) -> Config {
    loop {
        let material = ggx(rng, i);
        let (_, v) = match &material {
            Material::Ggx { alpha, view, .. } => (alpha.xy(), *view),
            _ => unreachable!(),
        };
        let mirror = [-v[0], -v[1], v[2]];
        let p = |rng: &mut ChaCha8Rng| [0; 3].map(|_| rng.random_range(-1.0..1.0f64));
        let centre = if i % 4 < 2 {
            mul(mirror, 1.5)
        } else {
            add(mul(mirror, 1.5), mul(p(rng), 0.5))
        };
        let t = unit(p(rng));
        let len = rng.random_range(0.2..3.0);
        let shift = rng.random_range(-0.5..0.5) * len;
        let p1 = add(centre, mul(t, shift - 0.5 * len));
        let p2 = add(centre, mul(t, shift + 0.5 * len));
        let b = unit(cross(t, p(rng)));
        let mut c = Config {
            id: format!("g{i}"),
            p1,
            p2,
            radius: None,
            rect: Some(Rect {
                normal: b,
                width: rng.random_range(0.02..1.0),
            }),
            material,
            texture: None,
        };
        // The rectangle must not contain the origin's foot too closely.
        let h = dot(c.p1, cross(t, unit(cross(b, t))));
        if c.validate().is_ok() && c.distance_to_segment() > 0.05 && h.abs() > 0.05 {
            c.radius = None;
            return c;
        }
    }
}

fn check(c: &Config, target: Target, independent: f64, tol: f64) -> f64 {
    let r = reference(c, target).expect("target computable");
    let err = (r.value - independent).abs();
    assert!(
        err <= tol * independent.abs() + 1e-300,
        "{target} {c:?}: reference {r:?}, independent {independent:e}, rel {:e}",
        err / independent.abs()
    );
    assert!(
        r.error <= 1e-7 * r.value.abs().max(1e-300) || r.value == 0.0,
        "{target}: {r:?}"
    );
    independent
}

#[test]
fn ggx_lines_agree_with_an_independent_quadrature() {
    let mut rng = ChaCha8Rng::seed_from_u64(2016);
    let configs: Vec<Config> = (0..20).map(|i| config(&mut rng, i)).collect();
    let lit: usize = configs
        .par_iter()
        .map(|c| {
            let v = check(c, Target::Line, line(c), 1e-8);
            // GGX is 0 below the horizon: the two line targets coincide.
            check(c, Target::LineUpper, v, 1e-8);
            usize::from(v > 0.0)
        })
        .sum();
    assert!(lit >= 13, "only {lit} of 20 see the light");
}

#[test]
fn ggx_isotropic_lines_and_the_summed_targets_agree_with_an_independent_quadrature() {
    let mut rng = ChaCha8Rng::seed_from_u64(2019);
    let configs: Vec<Config> = (0..12).map(|i| config(&mut rng, i)).collect();
    let lit: usize = configs
        .par_iter()
        .map(|c| {
            let iso = check(c, Target::LineIsotropic, line_isotropic(c), 1e-8);
            // The lobe plus a white Lambertian base, both models.
            check(c, Target::LineIsotropicSum, iso + line_of(c, &lambert, 1), 1e-8);
            check(c, Target::LineSum, line(c) + line_of(c, &lambert, 2), 1e-8);
            usize::from(iso > 0.0)
        })
        .sum();
    assert!(lit >= 8, "only {lit} of 12 see the light");
}

#[test]
fn ggx_rectangles_agree_with_an_independent_quadrature() {
    let mut rng = ChaCha8Rng::seed_from_u64(2017);
    let configs: Vec<Config> = (0..6).map(|i| config(&mut rng, i)).collect();
    let lit: usize = configs
        .par_iter()
        .map(|c| usize::from(check(c, Target::Rectangle, rectangle(c), 1e-7) > 0.0))
        .sum();
    assert!(lit >= 4, "only {lit} of 6 see the light");
}

#[test]
fn ggx_tubes_agree_with_an_independent_quadrature() {
    let mut rng = ChaCha8Rng::seed_from_u64(2018);
    let configs: Vec<Config> = (0..6)
        .map(|i| {
            let mut c = config(&mut rng, i);
            // A tube up to half the segment's distance; even i: wide enough to see a cap well.
            c.rect = None;
            // Even i: slide the segment along itself until the cap at p1 faces the origin.
            let e = sub(c.p2, c.p1);
            let t = unit(e);
            let s = dot(c.p1, t);
            if i.is_multiple_of(2) && s <= 0.0 {
                let shift = mul(t, -s + 0.2 * norm(e));
                (c.p1, c.p2) = (add(c.p1, shift), add(c.p2, shift));
            }
            c.radius = Some(c.distance_to_segment() * rng.random_range(0.02..0.5));
            c
        })
        .filter(|c| c.validate().is_ok())
        .collect();
    let lit: [usize; 2] = configs
        .par_iter()
        .map(|c| {
            let side = check(c, Target::Cylinder, cylinder(c), 1e-7);
            let ends = check(c, Target::Caps, caps(c), 1e-7);
            check(c, Target::Tube, side + ends, 1e-7);
            [usize::from(side > 0.0), usize::from(ends > 0.0)]
        })
        .reduce(|| [0; 2], |a, b| [a[0] + b[0], a[1] + b[1]]);
    assert!(lit[0] >= 4 && lit[1] >= 2, "too few see the light: {lit:?}");
}
