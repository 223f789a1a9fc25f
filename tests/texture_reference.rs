//! The textured references: with a cylindrical texture that varies
//! along (and around) the light, `reference()` for `line` and `cylinder` agrees with a brute
//! force written here from the texture definitions alone (its own bilinear lookup, its own
//! angular weighting, composite Gauss–Legendre in parametrisations the reference does not use)
//! to 1e-7; and a constant texture c gives c × the untextured reference within the error
//! estimates and 1e-12.

use linelight::input::scene::{Config, Material, Vec3};
use linelight::input::target::Target;
use linelight::input::texture::{Texture, TextureKind};
use linelight::reference::reference;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

use crate::common;
use common::independent::*;

/// The lookup, written again: texel (i, j) at j·nu + i, centres at ((i+½)/nu, (j+½)/nv),
/// clamped in u, wrapping in v.
fn lookup(nu: usize, nv: usize, texels: &[f64], u: f64, v: f64) -> f64 {
    let x = (u * nu as f64 - 0.5).max(0.0).min((nu - 1) as f64);
    let i = (x as usize).min(nu.saturating_sub(2));
    let a = x - i as f64;
    let i1 = (i + 1).min(nu - 1);
    let y = v.rem_euclid(1.0) * nv as f64 - 0.5;
    let jf = y.floor();
    let b = y - jf;
    let j0 = (jf as i64).rem_euclid(nv as i64) as usize;
    let j1 = (j0 + 1) % nv;
    let t = |i: usize, j: usize| texels[j * nu + i];
    (1.0 - b) * ((1.0 - a) * t(i, j0) + a * t(i1, j0)) + b * ((1.0 - a) * t(i, j1) + a * t(i1, j1))
}

/// Stripes along the light, a gradient around it, and a step.
fn texture(rng: &mut ChaCha8Rng, origin: Option<Vec3>) -> Texture {
    let (nu, nv) = (rng.random_range(2..9), rng.random_range(1..6));
    let texels = (0..nu * nv)
        .map(|k| {
            let (i, j) = (k % nu, k / nu);
            0.3 + (i % 2) as f64 + 0.2 * j as f64 + if i > nu / 2 { rng.random_range(0.0..0.5) } else { 0.0 }
        })
        .collect();
    Texture {
        kind: TextureKind::Cylindrical,
        size: [nu as u32, nv as u32],
        texels,
        origin,
    }
}

fn material(rng: &mut ChaCha8Rng, i: usize) -> Material {
    if i.is_multiple_of(2) {
        Material::Diffuse
    } else {
        // A lobe whose support contains the whole upper hemisphere's lights used here.
        let a = rng.random_range(0.5..2.0);
        Material::Ltc {
            minv: [
                [a, 0.0, rng.random_range(-0.3..0.3)],
                [0.0, a * 0.8, 0.0],
                [0.0, 0.0, 1.0],
            ],
        }
    }
}

/// A segment well above the surface (every point of a tube of radius ≤ 0.2 around it at z > 0.3).
fn segment(rng: &mut ChaCha8Rng) -> (Vec3, Vec3) {
    let p1 = [
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
        rng.random_range(0.6..1.5),
    ];
    let dir = unit([
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
        rng.random_range(-0.3..0.3),
    ]);
    let len = rng.random_range(0.3..2.0);
    let p2 = add(p1, mul(dir, len));
    (p1, if p2[2] < 0.6 { [p2[0], p2[1], 0.6] } else { p2 })
}

/// The default origin: the first vector of Listing 1.3's basis (Frisvad), as the prelude has it.
fn frisvad(n: Vec3) -> Vec3 {
    if n[2] < -0.9999999 {
        return [0.0, -1.0, 0.0];
    }
    let a = 1.0 / (1.0 + n[2]);
    [1.0 - n[0] * n[0] * a, -n[0] * n[1] * a, -n[0]]
}

/// The light's frame: unit tangent, origin (φ = 0) and ω_t × origin.
fn frame(c: &Config) -> (Vec3, Vec3, Vec3) {
    let t = unit(sub(c.p2, c.p1));
    let o = c.texture.as_ref().unwrap().origin.unwrap_or_else(|| frisvad(t));
    (t, o, cross(t, o))
}

/// `line` of the textured emitter: ∫ D(ω_p)·‖ω_p × ω_t‖/‖p‖² ∫ max(0, −ω_p·ω_n(φ))/‖ω_p×ω_t‖ ·
/// T(l/L, φ/2π) dφ dl, the thin tube's visible half, in the angle θ = atan((l − l0)/d).
fn brute_line(c: &Config) -> f64 {
    let tex = c.texture.as_ref().unwrap();
    let [nu, nv] = tex.size.map(|n| n as usize);
    let (t, o, b) = frame(c);
    let len = norm(sub(c.p2, c.p1));
    let l0 = dot(c.p1, t);
    let foot = sub(c.p1, mul(t, l0));
    let d = norm(foot);
    let minv = c.material.minv();
    // ω_n(φ) = cos φ·o + sin φ·b; −ω_p·ω_n = −(foot·ω_n)/‖p‖, the same sign along the line.
    let weight = |u: f64| {
        let f = |phi: f64| {
            let n = add(mul(o, phi.cos()), mul(b, phi.sin()));
            (-dot(foot, n) / d).max(0.0) * lookup(nu, nv, &tex.texels, u, phi / (2.0 * PI))
        };
        let mut cuts: Vec<f64> = (0..nv).map(|j| 2.0 * PI * (j as f64 + 0.5) / nv as f64).collect();
        let phi0 = (-dot(foot, b)).atan2(-dot(foot, o)).rem_euclid(2.0 * PI);
        cuts.extend([
            (phi0 + PI / 2.0).rem_euclid(2.0 * PI),
            (phi0 + 1.5 * PI).rem_euclid(2.0 * PI),
        ]);
        composite(&f, 0.0, 2.0 * PI, &cuts, 4)
    };
    let f = |th: f64| {
        let l = d * th.tan();
        let p = add(foot, mul(t, l));
        let r = norm(p);
        // dl/‖p‖² = dθ/d; the projected width's ‖ω_p × ω_t‖ = d/r cancels against the
        // normalisation of max(0, −ω_p·ω_n) = (d/r)·max(0, −n̂_foot·ω_n).
        ltc_d(&minv, mul(p, 1.0 / r)) * (d / r) * weight((l - l0) / len) / d
    };
    let (a, bb) = ((l0 / d).atan(), ((l0 + len) / d).atan());
    let cuts: Vec<f64> = (0..nu)
        .map(|i| ((l0 + len * (i as f64 + 0.5) / nu as f64) / d).atan())
        .collect();
    composite(&f, a, bb, &cuts, 24)
}

/// `cylinder` of the textured emitter: ∫∫ D(ω_p) max(0, −ω_p·ω_n)/‖p‖² T R dφ dl over the side,
/// in φ (outer) and l (inner, in θ about the generator's own foot).
fn brute_cylinder(c: &Config) -> f64 {
    let tex = c.texture.as_ref().unwrap();
    let [nu, nv] = tex.size.map(|n| n as usize);
    let (t, o, b) = frame(c);
    let r = c.radius.unwrap();
    let len = norm(sub(c.p2, c.p1));
    let minv = c.material.minv();
    let outer = |phi: f64| {
        let n = add(mul(o, phi.cos()), mul(b, phi.sin()));
        let q1 = add(c.p1, mul(n, r));
        let l0 = dot(q1, t);
        let foot = sub(q1, mul(t, l0));
        let d = norm(foot);
        // −p·ω_n is the same along the generator.
        let facing = -dot(q1, n);
        if facing <= 0.0 {
            return 0.0;
        }
        let v = phi / (2.0 * PI);
        let f = |th: f64| {
            let l = d * th.tan();
            let p = add(foot, mul(t, l));
            let rr = norm(p);
            let u = (l - l0) / len;
            ltc_d(&minv, mul(p, 1.0 / rr)) * (facing / rr) * lookup(nu, nv, &tex.texels, u, v) * r / d
        };
        let (a, bb) = ((l0 / d).atan(), ((l0 + len) / d).atan());
        let cuts: Vec<f64> = (0..nu)
            .map(|i| ((l0 + len * (i as f64 + 0.5) / nu as f64) / d).atan())
            .collect();
        composite(&f, a, bb, &cuts, 8)
    };
    // The visible arc's ends and the texel centres around the axis.
    let p1_foot = sub(c.p1, mul(t, dot(c.p1, t)));
    let dist = norm(p1_foot);
    let phi0 = (-dot(p1_foot, b)).atan2(-dot(p1_foot, o));
    let beta = (r / dist).acos();
    let mut cuts: Vec<f64> = (0..nv).map(|j| 2.0 * PI * (j as f64 + 0.5) / nv as f64).collect();
    cuts.extend([phi0 - beta, phi0 + beta].map(|x| x.rem_euclid(2.0 * PI)));
    composite(&outer, 0.0, 2.0 * PI, &cuts, 12)
}

fn config(p1: Vec3, p2: Vec3, material: Material, radius: Option<f64>, texture: Option<Texture>) -> Config {
    Config {
        id: "t".into(),
        p1,
        p2,
        radius,
        rect: None,
        material,
        texture,
    }
}

/// A random unit vector ⟂ t.
fn perpendicular(rng: &mut ChaCha8Rng, t: Vec3) -> Vec3 {
    let (e1, e2) = basis(t);
    let a: f64 = rng.random_range(0.0..2.0 * PI);
    add(mul(e1, a.cos()), mul(e2, a.sin()))
}

#[test]
fn textured_line_and_cylinder_agree_with_brute_force() {
    let mut rng = ChaCha8Rng::seed_from_u64(25);
    for i in 0..8 {
        let (p1, p2) = segment(&mut rng);
        let t = unit(sub(p2, p1));
        let origin = (i % 3 == 0).then(|| perpendicular(&mut rng, t));
        let tex = texture(&mut rng, origin);
        let m = material(&mut rng, i);
        let radius = rng.random_range(0.02..0.2);
        let c = config(p1, p2, m, Some(radius), Some(tex));
        c.validate().unwrap();
        let line = reference(&c, Target::Line).unwrap();
        let brute = brute_line(&c);
        let gap = (line.value - brute).abs() / brute.abs();
        assert!(gap < 1e-7, "{i} line: {line:?} vs {brute} ({gap:e})");
        assert!(line.error < 1e-9 * line.value.abs(), "{i}: {line:?}");
        let cyl = reference(&c, Target::Cylinder).unwrap();
        let brute = brute_cylinder(&c);
        let gap = (cyl.value - brute).abs() / brute.abs();
        assert!(gap < 1e-7, "{i} cylinder: {cyl:?} vs {brute} ({gap:e})");
        assert!(cyl.error < 1e-7 * cyl.value.abs(), "{i}: {cyl:?}");
    }
}

#[test]
fn thin_textured_tube_tends_to_the_textured_line() {
    let mut rng = ChaCha8Rng::seed_from_u64(26);
    let (p1, p2) = segment(&mut rng);
    let tex = texture(&mut rng, None);
    let line = reference(
        &config(p1, p2, Material::Diffuse, None, Some(tex.clone())),
        Target::Line,
    )
    .unwrap();
    let mut last = f64::INFINITY;
    for r in [1e-2, 1e-3, 1e-4] {
        let cyl = reference(
            &config(p1, p2, Material::Diffuse, Some(r), Some(tex.clone())),
            Target::Cylinder,
        )
        .unwrap();
        let gap = (cyl.value / r - line.value).abs() / line.value;
        assert!(gap < last, "R={r}: {gap:e}");
        last = gap;
    }
    assert!(last < 1e-3, "{last:e}");
}

#[test]
fn constant_texture_scales_every_reference() {
    let mut rng = ChaCha8Rng::seed_from_u64(27);
    for i in 0..6 {
        let (p1, p2) = segment(&mut rng);
        let m = material(&mut rng, i);
        let cval = rng.random_range(0.1..3.0);
        let plain = config(p1, p2, m.clone(), Some(0.05), None);
        let mut tex = Texture::constant(cval);
        if i % 2 == 1 {
            // The same constant spread over texels of a cubemap.
            tex = Texture {
                kind: TextureKind::Cubemap,
                size: [3, 3],
                texels: vec![cval; 54],
                origin: None,
            };
        }
        let textured = config(p1, p2, m, Some(0.05), Some(tex));
        for target in [
            Target::Line,
            Target::LineUpper,
            Target::LineIsotropic,
            Target::Cylinder,
            Target::Caps,
        ] {
            let a = reference(&plain, target).unwrap();
            let b = reference(&textured, target).unwrap();
            // The cylindrical kind leaves the caps untextured.
            let scale = if target == Target::Caps && i % 2 == 0 {
                1.0
            } else {
                cval
            };
            let gap = (b.value - scale * a.value).abs();
            assert!(
                gap <= b.error + scale * a.error && gap <= 1e-12 * b.value.abs(),
                "{i} {target:?}: {b:?} vs {scale} × {a:?}"
            );
        }
    }
}
