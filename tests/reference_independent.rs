//! `reference()` against a second quadrature written here from docs/conventions.md alone: composite
//! Gauss–Legendre on many equal panels, in parametrisations the reference does not use
//! (l = l0 + d·sinh u for the line; the surfaces in their own area coordinates), with its
//! own D (Listing 1.10) and its own kink location.

use linelight::input::scene::{Config, Material, Rect, Vec3};
use linelight::input::target::Target;
use linelight::reference::reference;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::f64::consts::PI;

use crate::common;
use common::independent::*;
use common::segment;

/// ∫ f over [a, b], cut at `cuts`, with `panels` equal panels spread over the pieces in
/// proportion to their length (at least 50 each).
fn composite(f: &dyn Fn(f64) -> f64, a: f64, b: f64, cuts: &[f64], panels: usize) -> f64 {
    let rule = gauss16();
    let mut sum = 0.0;
    for w in pieces(a, b, cuts).windows(2) {
        let n = ((panels as f64 * (w[1] - w[0]) / (b - a)).ceil() as usize).max(4);
        let h = (w[1] - w[0]) / n as f64;
        for i in 0..n {
            let c = w[0] + (i as f64 + 0.5) * h;
            sum += rule.iter().map(|&(x, wt)| wt * f(c + 0.5 * h * x)).sum::<f64>() * 0.5 * h;
        }
    }
    sum
}

/// The solutions φ ∈ [0, 2π) of a + b cos φ + c sin φ = 0.
fn trig_roots(a: f64, b: f64, c: f64) -> Vec<f64> {
    let r = b.hypot(c);
    if r == 0.0 || a.abs() > r {
        return Vec::new();
    }
    let (g, h) = (c.atan2(b), (-a / r).acos());
    [g - h, g + h].iter().map(|x| x.rem_euclid(2.0 * PI)).collect()
}

/// The solution l of a + b·l = 0, if any.
fn linear_root(a: f64, b: f64) -> Option<f64> {
    (b != 0.0).then(|| -a / b)
}

/// `line` (or `line_upper`) in u with l = l0 + d·sinh u: dl = d cosh u du, ‖p‖ = d cosh u,
/// so the integrand 2d·D/‖p‖³ dl is 2D/(d cosh²u) du.
fn line(c: &Config, upper: bool) -> f64 {
    let minv = c.material.minv();
    let e = sub(c.p2, c.p1);
    let len = norm(e);
    let t = mul(e, 1.0 / len);
    let l0 = -dot(c.p1, t);
    let d = norm(cross(c.p1, t));
    let u = |l: f64| ((l - l0) / d).asinh();
    let f = |x: f64| {
        let p = add(c.p1, mul(t, l0 + d * x.sinh()));
        let w = unit(p);
        if upper && w[2] <= 0.0 {
            return 0.0;
        }
        2.0 * ltc_d(&minv, w) / (d * x.cosh().powi(2))
    };
    // The support plane of D and the horizon cross the line where their normal·p(l) = 0.
    let cuts: Vec<f64> = [minv[2], [0.0, 0.0, 1.0]]
        .iter()
        .filter(|n| dot(**n, t) != 0.0)
        .map(|n| u(-dot(*n, c.p1) / dot(*n, t)))
        .collect();
    composite(&f, u(0.0), u(len), &cuts, 4000)
}

/// `line_isotropic` in the same u: the integrand D/‖p‖² dl is D/(d cosh u) du.
fn line_isotropic(c: &Config) -> f64 {
    let minv = c.material.minv();
    let e = sub(c.p2, c.p1);
    let len = norm(e);
    let t = mul(e, 1.0 / len);
    let l0 = -dot(c.p1, t);
    let d = norm(cross(c.p1, t));
    let u = |l: f64| ((l - l0) / d).asinh();
    let f = |x: f64| {
        let p = add(c.p1, mul(t, l0 + d * x.sinh()));
        ltc_d(&minv, unit(p)) / (d * x.cosh())
    };
    let sigma = minv[2];
    let cuts: Vec<f64> = (dot(sigma, t) != 0.0)
        .then(|| u(-dot(sigma, c.p1) / dot(sigma, t)))
        .into_iter()
        .collect();
    composite(&f, u(0.0), u(len), &cuts, 4000)
}

fn material(rng: &mut ChaCha8Rng, i: usize) -> Material {
    let (a, c) = (rng.random_range(1.0..30.0), rng.random_range(1.0..30.0));
    let (b, d) = (rng.random_range(-2.0..2.0), rng.random_range(-0.8..0.8));
    let sparse = [[a, 0.0, b], [0.0, c, 0.0], [d, 0.0, 1.0]];
    match i % 3 {
        0 => Material::Diffuse,
        1 => Material::Ltc { minv: sparse },
        _ => Material::Ltc {
            minv: sparse.map(|r| r.map(|x| x + rng.random_range(-0.5..0.5))),
        },
    }
}

/// A configuration with segment distance at least 0.05; every third one crosses the horizon.
fn config(rng: &mut ChaCha8Rng, i: usize) -> Config {
    loop {
        let mut p = || [0; 3].map(|_| rng.random_range(-2.0..2.0f64));
        let (mut p1, mut p2) = (p(), p());
        if i.is_multiple_of(3) {
            p1[2] = -p1[2].abs();
            p2[2] = p2[2].abs();
        }
        let c = segment(format!("c{i}"), p1, p2, material(rng, i));
        if c.validate().is_ok() && c.distance_to_segment() > 0.05 {
            return c;
        }
    }
}

fn check(c: &Config, target: Target, independent: f64, tol: f64) {
    let r = reference(c, target).expect("target computable");
    let err = (r.value - independent).abs();
    assert!(
        err <= tol * independent.abs() + 1e-300,
        "{target} {c:?}: reference {r:?}, independent {independent:e}, rel {:e}",
        err / independent.abs()
    );
}

#[test]
fn line_and_line_upper_agree_with_sinh_quadrature() {
    let mut rng = ChaCha8Rng::seed_from_u64(20240601);
    let mut nonzero = 0;
    for i in 0..60 {
        let c = config(&mut rng, i);
        let (all, upper) = (line(&c, false), line(&c, true));
        nonzero += (upper > 0.0) as usize;
        check(&c, Target::Line, all, 1e-8);
        check(&c, Target::LineUpper, upper, 1e-8);
    }
    assert!(nonzero >= 30, "only {nonzero} of 60 configurations see the light");
}

#[test]
fn line_isotropic_agrees_with_sinh_quadrature() {
    let mut rng = ChaCha8Rng::seed_from_u64(20240611);
    let mut nonzero = 0;
    for i in 0..60 {
        let c = config(&mut rng, i);
        let v = line_isotropic(&c);
        nonzero += (v > 0.0) as usize;
        check(&c, Target::LineIsotropic, v, 1e-8);
    }
    assert!(nonzero >= 30, "only {nonzero} of 60 configurations see the light");
}

/// The planes through the origin where an integrand has a kink or a jump: D's support plane
/// and, for the `_upper` targets, the horizon z = 0.
fn planes(minv: &[[f64; 3]; 3], upper: bool) -> Vec<Vec3> {
    let mut planes = vec![minv[2]];
    if upper {
        planes.push([0.0, 0.0, 1.0]);
    }
    planes
}

/// D, or `D·[ω.z > 0]` for the `_upper` targets.
fn d_clipped(minv: &[[f64; 3]; 3], w: Vec3, upper: bool) -> f64 {
    if upper && w[2] <= 0.0 {
        0.0
    } else {
        ltc_d(minv, w)
    }
}

/// `cylinder` (or `cylinder_upper`) per Eq. 1.2 in (l, φ): outer l = l0 + d·sinh u, inner φ
/// over the visible arc (where −p1·ω_n(φ) > R, the same for every l) cut where D's support
/// plane (and the horizon) crosses it.
fn cylinder(c: &Config, upper: bool) -> f64 {
    let r = c.radius.unwrap();
    let minv = c.material.minv();
    let planes = planes(&minv, upper);
    let e = sub(c.p2, c.p1);
    let len = norm(e);
    let t = mul(e, 1.0 / len);
    let (e1, e2) = basis(t);
    let wn = |phi: f64| add(mul(e1, phi.cos()), mul(e2, phi.sin()));
    // −p·ω_n − R·0 = −(A cos φ + B sin φ) − R: the arc where this is positive.
    let (a, b) = (dot(c.p1, e1), dot(c.p1, e2));
    let rho = a.hypot(b);
    if rho <= r {
        return 0.0;
    }
    let half = (r / rho).acos();
    let centre = b.atan2(a) + PI;
    let (lo, hi) = (centre - half, centre + half);
    let inner = |l: f64| {
        let base = add(c.p1, mul(t, l));
        let f = |phi: f64| {
            let n = wn(phi);
            let p = add(base, mul(n, r));
            let w = unit(p);
            d_clipped(&minv, w, upper) * (-dot(w, n)).max(0.0) / dot(p, p) * r
        };
        let cuts: Vec<f64> = planes
            .iter()
            .flat_map(|&sigma| trig_roots(dot(sigma, base), r * dot(sigma, e1), r * dot(sigma, e2)))
            .flat_map(|x| [x - 2.0 * PI, x, x + 2.0 * PI])
            .collect();
        composite(&f, lo, hi, &cuts, 16)
    };
    let l0 = -dot(c.p1, t);
    let d = norm(cross(c.p1, t));
    let u = |l: f64| ((l - l0) / d).asinh();
    // Kinks of the inner integral in l: the support's zeros reach an arc end, or appear.
    let mut cuts = Vec::new();
    for &sigma in &planes {
        let support = |l: f64, phi: f64| dot(sigma, add(add(c.p1, mul(t, l)), mul(wn(phi), r)));
        for phi in [lo, hi] {
            cuts.extend(linear_root(support(0.0, phi), dot(sigma, t)).map(u));
        }
        let s_perp = r * (dot(sigma, e1)).hypot(dot(sigma, e2));
        for sign in [-1.0, 1.0] {
            cuts.extend(linear_root(dot(sigma, c.p1) + sign * s_perp, dot(sigma, t)).map(u));
        }
    }
    let f = |x: f64| {
        let l = l0 + d * x.sinh();
        inner(l) * d * x.cosh()
    };
    composite(&f, u(0.0), u(len), &cuts, 60)
}

/// `cylinder` (or `cylinder_upper`) per Eq. 1.2 along the generators: outer φ over the visible
/// arc, inner l = l0 + d(φ)·sinh u along the generator at φ. The horizon makes the integrand
/// jump; along a generator that is a cut at its crossing, and across the generators the inner
/// integral then only has kinks where the crossing reaches an end (l = 0 or L), cut too. (In
/// (l, φ) the clipped arc grows like a square root where the horizon touches the cross-section,
/// which equal panels resolve slowly.) `−ω_p·ω_n = −(p1·ω_n + R)/‖p‖` is the same along a
/// generator.
fn cylinder_generators(c: &Config, upper: bool) -> f64 {
    let r = c.radius.unwrap();
    let minv = c.material.minv();
    let planes = planes(&minv, upper);
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
    let (lo, hi) = (centre - half, centre + half);
    let l0 = -dot(c.p1, t);
    let inner = |phi: f64| {
        let n = wn(phi);
        let facing = -dot(c.p1, n) - r;
        let base = add(c.p1, mul(n, r));
        let d = norm(sub(base, mul(t, dot(base, t))));
        let u = |l: f64| ((l - l0) / d).asinh();
        let f = |x: f64| {
            let p = add(base, mul(t, l0 + d * x.sinh()));
            d_clipped(&minv, unit(p), upper) / x.cosh().powi(2)
        };
        let cuts: Vec<f64> = planes
            .iter()
            .filter_map(|&sigma| linear_root(dot(sigma, base), dot(sigma, t)).map(u))
            .collect();
        facing * r / (d * d) * composite(&f, u(0.0), u(len), &cuts, 40)
    };
    let mut cuts = Vec::new();
    for &sigma in &planes {
        for end in [c.p1, c.p2] {
            cuts.extend(
                trig_roots(dot(sigma, end), r * dot(sigma, e1), r * dot(sigma, e2))
                    .into_iter()
                    .flat_map(|x| [x - 2.0 * PI, x, x + 2.0 * PI]),
            );
        }
    }
    composite(&inner, lo, hi, &cuts, 200)
}

/// `caps` (or `caps_upper`) per Eq. 1.29 in the disks' polar coordinates (φ outer, r inner),
/// one-sided as in Listing 1.8.
fn caps(c: &Config, upper: bool) -> f64 {
    let r = c.radius.unwrap();
    let minv = c.material.minv();
    let planes = planes(&minv, upper);
    let t = unit(sub(c.p2, c.p1));
    let (e1, e2) = basis(t);
    let mut total = 0.0;
    for (centre, normal) in [(c.p1, t), (c.p2, mul(t, -1.0))] {
        if dot(centre, normal) <= 0.0 {
            continue;
        }
        let u = |phi: f64| add(mul(e1, phi.cos()), mul(e2, phi.sin()));
        let inner = |phi: f64| {
            let f = |rr: f64| {
                let p = add(centre, mul(u(phi), rr));
                let w = unit(p);
                rr * d_clipped(&minv, w, upper) * dot(w, normal).max(0.0) / dot(p, p)
            };
            let cut: Vec<f64> = planes
                .iter()
                .filter_map(|&sigma| linear_root(dot(sigma, centre), dot(sigma, u(phi))))
                .collect();
            composite(&f, 0.0, r, &cut, 12)
        };
        let cuts: Vec<f64> = planes
            .iter()
            .flat_map(|&sigma| trig_roots(dot(sigma, centre), r * dot(sigma, e1), r * dot(sigma, e2)))
            .collect();
        total += composite(&inner, 0.0, 2.0 * PI, &cuts, 30);
    }
    total
}

/// `rectangle` (or `rectangle_upper`) in (l, s) with both sinh-graded about the origin's foot
/// on the plane.
fn rectangle(c: &Config, upper: bool) -> f64 {
    let rect = c.rect.as_ref().unwrap();
    let minv = c.material.minv();
    let planes = planes(&minv, upper);
    let e = sub(c.p2, c.p1);
    let len = norm(e);
    let t = mul(e, 1.0 / len);
    let wb = unit(cross(rect.normal, t));
    let n = cross(t, wb);
    let h = dot(c.p1, n);
    let half = rect.width / 2.0;
    // The foot of the origin on the plane is at l = lf, s = sf.
    let (lf, sf) = (-dot(c.p1, t), -dot(c.p1, wb));
    let scale = h.abs().max(1e-3 * rect.width);
    let u = |l: f64| ((l - lf) / scale).asinh();
    let inner = |l: f64| {
        let base = add(c.p1, mul(t, l));
        let dl = (h * h + (l - lf).powi(2)).sqrt();
        let v = |s: f64| ((s - sf) / dl).asinh();
        let f = |x: f64| {
            let s = sf + dl * x.sinh();
            let p = add(base, mul(wb, s));
            let w = unit(p);
            d_clipped(&minv, w, upper) * dot(w, n).abs() / dot(p, p) * dl * x.cosh()
        };
        let cut: Vec<f64> = planes
            .iter()
            .filter_map(|&sigma| linear_root(dot(sigma, base), dot(sigma, wb)).map(v))
            .collect();
        composite(&f, v(-half), v(half), &cut, 12)
    };
    let mut cuts = Vec::new();
    for &sigma in &planes {
        for s in [-half, half] {
            let a = dot(sigma, add(c.p1, mul(wb, s)));
            cuts.extend(linear_root(a, dot(sigma, t)).map(u));
        }
    }
    let f = |x: f64| {
        let l = lf + scale * x.sinh();
        inner(l) * scale * x.cosh()
    };
    composite(&f, u(0.0), u(len), &cuts, 40)
}

/// The direction D's LTC maps to its pole, M·z = (row0 × row1)/det M⁻¹: near the peak.
fn pole(material: &Material) -> Vec3 {
    let m = material.minv();
    let c = cross(m[0], m[1]);
    unit(mul(c, dot(c, m[2]).signum()))
}

/// A configuration looking at D's lobe, with a tube (radius up to half the segment's
/// distance; for even i the cap at p1 faces the origin) and a rectangle (normal ⟂ ω_t,
/// width up to the segment's distance).
fn surface_config(rng: &mut ChaCha8Rng, i: usize) -> Config {
    loop {
        let material = material(rng, i);
        let mut p = || [0; 3].map(|_| rng.random_range(-1.0..1.0f64));
        let p1 = add(mul(pole(&material), 1.5), mul(p(), 0.7));
        let mut t = unit(p());
        if i.is_multiple_of(2) && dot(t, p1) < 0.0 {
            t = mul(t, -1.0);
        }
        let p2 = add(p1, mul(t, rng.random_range(0.1..3.0)));
        let mut c = segment(format!("s{i}"), p1, p2, material);
        let dist = c.distance_to_segment();
        let (e1, e2) = basis(t);
        let a = rng.random_range(0.0..2.0 * PI);
        c.radius = Some(dist * rng.random_range(0.02..0.5));
        c.rect = Some(Rect {
            normal: add(mul(e1, a.cos()), mul(e2, a.sin())),
            width: dist * rng.random_range(0.02..1.0),
        });
        if c.validate().is_ok() && dist > 0.05 {
            return c;
        }
    }
}

#[test]
fn surfaces_agree_with_area_quadrature() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let configs: Vec<Config> = (0..50).map(|i| surface_config(&mut rng, i)).collect();
    let nonzero = configs
        .par_iter()
        .map(|c| {
            let (side, ends, flat) = (cylinder(c, false), caps(c, false), rectangle(c, false));
            check(c, Target::Cylinder, side, 1e-7);
            check(c, Target::Caps, ends, 1e-7);
            check(c, Target::Tube, side + ends, 1e-7);
            check(c, Target::Rectangle, flat, 1e-7);
            [side > 0.0, ends > 0.0, flat > 0.0].map(usize::from)
        })
        .reduce(|| [0; 3], |a, b| [a[0] + b[0], a[1] + b[1], a[2] + b[2]]);
    assert!(nonzero.iter().all(|&n| n >= 15), "too few see the light: {nonzero:?}");
}

/// The committed `reports/line_fwt/disagreements.jsonl` holds configurations where the 2017
/// Fwt is at least 30× less accurate in f32 than the 2023 one, and others where the reverse
/// holds: replayed with `linelight eval` and judged against this file's own quadrature.
#[test]
fn committed_fwt_disagreements_hold_against_an_independent_reference() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("reports/line_fwt/disagreements.jsonl");
    let text = std::fs::read_to_string(&path).expect("committed disagreements");
    let dir = tempfile::tempdir().unwrap();
    let (input, output) = (dir.path().join("in.jsonl"), dir.path().join("out.jsonl"));
    let prefixes = [
        "disagree-line.ltc2017-worse-than-line.ltc2017_fwt-",
        "disagree-line.ltc2017_fwt-worse-than-line.ltc2017-",
    ];
    let lines: Vec<&str> = text
        .lines()
        .filter(|l| prefixes.iter().any(|p| l.contains(&format!("\"id\":\"{p}"))))
        .collect();
    std::fs::write(&input, lines.join("\n")).unwrap();
    let o = common::eval(&input, &output, &["--methods", "line.ltc2017,line.ltc2017_fwt"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut best = [0.0f64; 2];
    for (row, line) in std::fs::read_to_string(&output).unwrap().lines().zip(&lines) {
        let r: serde_json::Value = serde_json::from_str(row).unwrap();
        let c: Config = serde_json::from_str(line).unwrap();
        let independent = self::line(&c, false);
        check(&c, Target::Line, independent, 1e-8);
        let err = |m: &str| {
            let v = r["methods"][m]["f32"].as_f64().unwrap_or(f64::INFINITY);
            (v - independent).abs() / independent.abs()
        };
        let (e17, e23) = (err("line.ltc2017"), err("line.ltc2017_fwt"));
        let eps = f32::EPSILON as f64;
        let k = if c.id.starts_with(prefixes[0]) { 0 } else { 1 };
        let ratio = if k == 0 { e17 / e23.max(eps) } else { e23 / e17.max(eps) };
        best[k] = best[k].max(ratio);
    }
    assert!(best[0] >= 30.0, "2017 Fwt at most {}× worse", best[0]);
    assert!(best[1] >= 30.0, "2023 Fwt at most {}× worse", best[1]);
}

#[test]
fn line_isotropic_on_ggx_agrees_with_sinh_quadrature() {
    let mut rng = ChaCha8Rng::seed_from_u64(20240612);
    let mut lit = 0;
    for i in 0..30 {
        let base = config(&mut rng, i);
        // Isotropic roughness (the feed of an anisotropic one is an exact LTC fit per
        // configuration, seconds each; the reference does not depend on the feed), and two
        // anisotropic.
        let a = rng.random_range(0.1..1.0);
        let alpha = if i % 15 == 14 {
            [a, rng.random_range(0.1..1.0)]
        } else {
            [a, a]
        };
        let (th, ph) = (
            rng.random_range(0.0..1.3f64),
            rng.random_range(0.0..std::f64::consts::TAU),
        );
        let view = [th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()];
        let json = serde_json::json!({"id": base.id, "p1": base.p1, "p2": base.p2,
            "material": {"kind": "ggx", "alpha": alpha, "view": view}});
        let c: Config = serde_json::from_value(json).expect("a ggx configuration");
        let e = sub(c.p2, c.p1);
        let len = norm(e);
        let t = mul(e, 1.0 / len);
        let l0 = -dot(c.p1, t);
        let d = norm(cross(c.p1, t));
        let u = |l: f64| ((l - l0) / d).asinh();
        let f = |x: f64| {
            let p = add(c.p1, mul(t, l0 + d * x.sinh()));
            ggx_d(alpha, view, unit(p)) / (d * x.cosh())
        };
        let cuts: Vec<f64> = (t[2] != 0.0).then(|| u(-c.p1[2] / t[2])).into_iter().collect();
        let v = composite(&f, u(0.0), u(len), &cuts, 8000);
        lit += (v > 0.0) as usize;
        check(&c, Target::LineIsotropic, v, 1e-7);
    }
    assert!(lit >= 10, "{lit}");
}

/// Configurations the samplers never draw: a tube or rectangle whose light straddles the
/// horizon (p1 below, p2 above, at tilts the cases do not use), and one wholly below the
/// surface (both end points and the whole shape at z <= 0), with the lobe leaking below.
fn straddling_config(rng: &mut ChaCha8Rng, i: usize) -> Config {
    loop {
        let material = match i % 3 {
            0 => Material::Diffuse,
            // A lobe tilted towards the horizon, so that `D` reaches below it (the leak).
            _ => Material::Ltc {
                minv: [
                    [rng.random_range(1.0..6.0), 0.0, rng.random_range(0.5..2.0)],
                    [0.0, rng.random_range(1.0..6.0), 0.0],
                    [rng.random_range(-0.9..-0.3), 0.0, 1.0],
                ],
            },
        };
        let below = i % 5 == 4;
        let mut p = || [0; 3].map(|_| rng.random_range(-1.5..1.5f64));
        let (mut p1, mut p2) = (p(), p());
        let radius = rng.random_range(0.01..0.3);
        if below {
            p1[2] = -p1[2].abs() - radius;
            p2[2] = -p2[2].abs() - radius;
        } else {
            p1[2] = -p1[2].abs() * 0.5;
            p2[2] = p2[2].abs() * 0.5 + 0.05;
        }
        let t = unit(sub(p2, p1));
        let (e1, e2) = basis(t);
        let a = rng.random_range(0.0..2.0 * PI);
        let mut c = Config {
            id: format!("straddle{i}"),
            p1,
            p2,
            radius: Some(radius),
            rect: Some(Rect {
                normal: add(mul(e1, a.cos()), mul(e2, a.sin())),
                // The rectangle's half-width stays within the radius, so "wholly below" holds
                // for it too.
                width: 2.0 * radius,
            }),
            material,
            texture: None,
        };
        c.orthonormalize_rect();
        if c.validate().is_ok() && c.distance_to_segment() > 2.0 * radius + 0.05 {
            return c;
        }
    }
}

/// `cylinder_upper`, `caps_upper`, `tube_upper` and `rectangle_upper` against this file's own
/// quadrature with the integrand clipped at the horizon, on lights straddling the horizon and
/// wholly below it (where every one of them is 0, while the unclipped leak is not).
#[test]
fn upper_surfaces_agree_with_clipped_area_quadrature() {
    let mut rng = ChaCha8Rng::seed_from_u64(18);
    let configs: Vec<Config> = (0..40).map(|i| straddling_config(&mut rng, i)).collect();
    let counts = configs
        .par_iter()
        .map(|c| {
            let (side, ends, flat) = (cylinder_generators(c, true), caps(c, true), rectangle(c, true));
            let below = c.p1[2] <= 0.0 && c.p2[2] <= 0.0;
            if below {
                for t in [
                    Target::CylinderUpper,
                    Target::CapsUpper,
                    Target::TubeUpper,
                    Target::RectangleUpper,
                ] {
                    assert_eq!(reference(c, t).unwrap().value, 0.0, "{t} {c:?}");
                }
                assert_eq!(side + ends + flat, 0.0, "{c:?}");
            } else {
                check(c, Target::CylinderUpper, side, 1e-7);
                check(c, Target::CapsUpper, ends, 1e-7);
                check(c, Target::TubeUpper, side + ends, 1e-7);
                check(c, Target::RectangleUpper, flat, 1e-7);
            }
            // The clipped target never exceeds the unclipped one, and is below it somewhere
            // for a leaking lobe.
            let leak = [
                (Target::Cylinder, side),
                (Target::Caps, ends),
                (Target::Rectangle, flat),
            ]
            .map(|(t, upper)| {
                let all = reference(c, t).unwrap().value;
                assert!(upper <= all * (1.0 + 1e-9) + 1e-300, "{t} {c:?}: {upper} > {all}");
                upper < all * (1.0 - 1e-6)
            });
            [
                usize::from(below),
                usize::from(!below && side > 0.0 && flat > 0.0),
                usize::from(leak.iter().any(|&l| l)),
            ]
        })
        .reduce(|| [0; 3], |a, b| [a[0] + b[0], a[1] + b[1], a[2] + b[2]]);
    let [below, lit, leaking] = counts;
    assert!(below >= 6, "{counts:?}");
    assert!(lit >= 15, "{counts:?}");
    assert!(leaking >= 15, "{counts:?}");
}
