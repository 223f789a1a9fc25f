//! The specular MRP kernels (kernels/mrp/line_mrp_specular*.wgsl, line_mrp_sum*.wgsl): their
//! f64 values (the CPU evaluator on the kernel's own source) against an independent
//! computation written here in the configuration's own frame (no rotation into the kernels'
//! frame): the horizon clip by its crossing parameter, the point by minimising the distance
//! to the reflection line over the segment (golden section), the diffuse point by bisecting
//! the angle condition, the subtended angle by atan2, the GGX D of docs/conventions.md term by term; and the
//! GPU's f32 values against the same, and the kernels' support (ggx only, no fed magnitude).

use linelight::eval::interp::{CpuColumns, Mode};
use linelight::input::scene::{Config, GpuScene, Material, Roughness, Vec3};
use linelight::kernel::builtin_kernels;
use linelight::kernel::methods::resolve;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

use crate::common;
use common::independent::*;
use common::segment;

/// The part of the segment with z > 0 (the whole segment when it does not cross z = 0).
fn clip(p1: Vec3, p2: Vec3) -> (Vec3, Vec3) {
    if (p1[2] > 0.0) == (p2[2] > 0.0) {
        return (p1, p2);
    }
    let s = p1[2] / (p1[2] - p2[2]);
    let x = add(p1, mul(sub(p2, p1), s));
    if p1[2] > 0.0 {
        (p1, x)
    } else {
        (x, p2)
    }
}

/// The point of AB closest to the line through the origin along R: the squared distance to
/// a line is convex along the segment, so the minimum is where its derivative changes sign
/// (or an end), found by bisection to the last bit.
fn specular_point(a: Vec3, b: Vec3, r: Vec3) -> Vec3 {
    let e = sub(b, a);
    let p = |t: f64| add(a, mul(e, t));
    let slope = |t: f64| {
        let q = p(t);
        dot(q, e) - dot(q, r) * dot(e, r)
    };
    if slope(0.0) >= 0.0 {
        return a;
    }
    if slope(1.0) <= 0.0 {
        return b;
    }
    let (mut lo, mut hi) = (0.0, 1.0);
    for _ in 0..200 {
        let m = (lo + hi) / 2.0;
        if slope(m) < 0.0 {
            lo = m;
        } else {
            hi = m;
        }
    }
    p((lo + hi) / 2.0)
}

/// The point of AB seen at equal angles from A and B (the half vector's direction), by
/// bisection of the angle difference, which changes sign once along the segment.
fn diffuse_point(a: Vec3, b: Vec3) -> Vec3 {
    let p = |t: f64| add(a, mul(sub(b, a), t));
    let angle = |x: Vec3, y: Vec3| norm(cross(x, y)).atan2(dot(x, y));
    let (mut lo, mut hi) = (0.0, 1.0);
    for _ in 0..200 {
        let m = (lo + hi) / 2.0;
        if angle(a, p(m)) < angle(p(m), b) {
            lo = m;
        } else {
            hi = m;
        }
    }
    p((lo + hi) / 2.0)
}

#[derive(Clone, Copy, PartialEq)]
enum Norm {
    None,
    Widened,
    Energy,
    EnergyLine,
}

fn specular(c: &Config, norm_kind: Norm) -> f64 {
    let Material::Ggx { alpha, view, .. } = &c.material else {
        unreachable!()
    };
    let alpha = alpha.xy();
    let (a, b) = clip(c.p1, c.p2);
    let r = [-view[0], -view[1], view[2]];
    let x = specular_point(a, b, r);
    let half = norm(cross(a, b)).atan2(dot(a, b)) / 2.0;
    let widened = alpha.map(|al| (al + half.sin() / 2.0).min(1.0));
    let ratio = alpha[0] / widened[0] * alpha[1] / widened[1];
    let (lobe, factor) = match norm_kind {
        Norm::None => (alpha, 1.0),
        Norm::Widened => (widened, 1.0),
        Norm::Energy => (alpha, ratio),
        Norm::EnergyLine => (alpha, ratio.sqrt()),
    };
    norm(sub(c.p2, c.p1)) * ggx_d(lobe, *view, unit(x)) * factor / dot(x, x)
}

fn diffuse(c: &Config) -> f64 {
    let (a, b) = clip(c.p1, c.p2);
    let x = diffuse_point(a, b);
    norm(sub(c.p2, c.p1)) * unit(x)[2].max(0.0) / PI / dot(x, x)
}

/// Segments at distance ≥ 0.2 from the shading point, a third crossing the horizon, seen
/// with isotropic and anisotropic roughness at any view azimuth.
fn configs(seed: u64, n: usize, min_alpha: f64) -> Vec<Config> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::new();
    while out.len() < n {
        let i = out.len();
        let a = rng.random_range(min_alpha..1.0f64);
        // Anisotropic roughness is fed an exact per-configuration fit (slow): a few only.
        let alpha = if i % 20 != 1 {
            Roughness::Iso(a)
        } else {
            Roughness::Aniso([a, rng.random_range(min_alpha..1.0)])
        };
        let theta = rng.random_range(0.0..80.0f64).to_radians();
        let phi = rng.random_range(0.0..2.0 * PI);
        let view = [theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()];
        let material = Material::ggx(alpha, view, Some("table")).or_else(|_| Material::ggx(alpha, view, Some("fit")));
        let mirror = [-view[0], -view[1], view[2]];
        let mut p = || add(mul(mirror, 1.5), [0; 3].map(|_| rng.random_range(-1.0..1.0f64)));
        let (mut p1, mut p2) = (p(), p());
        if i % 3 == 0 {
            p1[2] = -p1[2].abs();
            p2[2] = p2[2].abs();
        }
        let c = segment(format!("s{i}"), p1, p2, material.unwrap());
        if c.validate().is_ok() && c.distance_to_segment() > 0.2 {
            out.push(c);
        }
    }
    out
}

fn rel(v: f64, r: f64) -> f64 {
    if r == 0.0 {
        v.abs()
    } else {
        (v - r).abs() / r.abs()
    }
}

const KERNELS: [(&str, Norm, bool); 6] = [
    ("line.mrp_specular", Norm::None, false),
    ("line.mrp_specular_widened", Norm::Widened, false),
    ("line.mrp_specular_energy", Norm::Energy, false),
    ("line.mrp_specular_energy_line", Norm::EnergyLine, false),
    ("line.mrp_sum", Norm::None, true),
    ("line.mrp_sum_energy", Norm::Energy, true),
];

fn independent(c: &Config, n: Norm, sum: bool) -> f64 {
    specular(c, n) + if sum { diffuse(c) } else { 0.0 }
}

#[test]
fn f64_values_match_an_independent_computation() {
    let kernels = builtin_kernels();
    let cs = configs(11, 40, 0.02);
    for (spec, n, sum) in KERNELS {
        let m = resolve(spec, &kernels).unwrap();
        let f64s = m.cpu_column(&cs, Mode::F64).unwrap();
        let mut lit = 0;
        for (c, v) in cs.iter().zip(f64s) {
            let (v, want) = (v.unwrap(), independent(c, n, sum));
            lit += usize::from(want > 0.0);
            // The golden section and the bisection stop at 1e-16 of the segment; the
            // kernel's closed forms in f64 agree to rounding.
            assert!(rel(v, want) < 1e-9, "{spec} {}: f64 {v:e}, independent {want:e}", c.id);
        }
        assert!(lit >= 30, "{spec}: only {lit} of 40 lit");
    }
}

#[test]
fn gpu_values_match_in_f32_and_are_not_scaled_by_the_fed_magnitude() {
    let gpu = common::gpu();
    let kernels = builtin_kernels();
    let cs = configs(12, 40, 0.1);
    let scenes: Vec<GpuScene> = cs.iter().map(GpuScene::from).collect();
    for (spec, n, sum) in KERNELS {
        let m = resolve(spec, &kernels).unwrap();
        assert!(cs.iter().all(|c| m.supports(c)), "{spec} handles ggx");
        let mut diffuse_config = cs[0].clone();
        diffuse_config.material = Material::Diffuse;
        assert!(!m.supports(&diffuse_config), "{spec} is ggx only");
        let pipeline = gpu.pipeline(&m).unwrap();
        let out = gpu.run(&pipeline, &scenes, 64, &mut |_| {}).unwrap().values;
        for (c, v) in cs.iter().zip(out) {
            let want = independent(c, n, sum);
            // α ≥ 0.1 and a segment 0.2 away: the lobe's slope times f32 rounding of the
            // point's direction stays well below 1e-4.
            assert!(
                rel(f64::from(v), want) < 1e-4,
                "{spec} {}: GPU {v:e}, independent {want:e}",
                c.id
            );
        }
    }
}
