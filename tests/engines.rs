//! The engine formulas (kernels/engines/), the MRP kernels (kernels/mrp/) and the polygon-LTC
//! rectangle methods on lavapipe, each against the f64 reference of the target it models,
//! on small fixed sets where the formula is known to be exact or to tend to the target; and
//! the polygon integral of the thin rectangle checked in f64 against the rectangle reference.

use crate::common;
use common::segment;

use linelight::input::scene::{Config, GpuScene, Material, Rect, Vec3};
use linelight::input::target::Target;
use linelight::kernel::builtin_kernels;
use linelight::kernel::methods::resolve;
use linelight::measure::gpu::Gpu;
use linelight::reference::reference;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

fn gpu() -> &'static Gpu {
    common::gpu()
}

fn run(gpu: &Gpu, spec: &str, configs: &[Config]) -> Vec<f64> {
    let m = resolve(spec, &builtin_kernels()).unwrap();
    let scenes: Vec<GpuScene> = configs.iter().map(GpuScene::from).collect();
    let pipeline = gpu.pipeline(&m).unwrap_or_else(|e| panic!("{spec}: {e}"));
    gpu.run(&pipeline, &scenes, 64, &mut |_| {})
        .unwrap()
        .values
        .into_iter()
        .map(f64::from)
        .collect()
}

/// Random segments at distance ≥ 0.1, a third of them crossing the horizon.
fn segments(seed: u64, n: usize) -> Vec<Config> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::new();
    while out.len() < n {
        let mut p = || [0; 3].map(|_| rng.random_range(-2.0..2.0f64));
        let (mut p1, mut p2) = (p(), p());
        if out.len() % 3 == 0 {
            p1[2] = -p1[2].abs();
            p2[2] = p2[2].abs();
        }
        let c = segment(format!("s{}", out.len()), p1, p2, Material::Diffuse);
        if c.validate().is_ok() && c.distance_to_segment() > 0.1 {
            out.push(c);
        }
    }
    out
}

fn rel(v: f64, r: f64) -> f64 {
    (v - r).abs() / r.abs()
}

#[test]
fn karis_line_irradiance_is_exact_for_isotropic_emitters_above_the_horizon() {
    let gpu = gpu();
    let configs = segments(1, 60);
    let clip = run(gpu, "line_isotropic.karis2013_clip", &configs);
    let unclipped = run(gpu, "line_isotropic.karis2013", &configs);
    let (mut crossing, mut differs) = (0, 0);
    for ((c, &v), &u) in configs.iter().zip(&clip).zip(&unclipped) {
        let r = reference(c, Target::LineIsotropic).unwrap().value;
        if r > 1e-4 {
            // f32 on well-separated geometry: a few hundred ULP at most.
            assert!(rel(v, r) < 1e-4, "{}: clipped {v:e} vs {r:e}", c.id);
        }
        let above = c.p1[2] > 0.0 && c.p2[2] > 0.0;
        if above {
            assert!(rel(u, r) < 1e-4, "{}: unclipped {u:e} vs {r:e}", c.id);
        } else if c.p1[2] * c.p2[2] < 0.0 {
            crossing += 1;
            differs += (rel(u, r) > 1e-2) as usize;
        }
    }
    // Without the clip the cosine goes negative below the horizon and the sum is wrong.
    assert!(crossing >= 15 && differs * 2 > crossing, "{differs} of {crossing}");
}

#[test]
fn point_light_forms_tend_to_the_target_for_short_distant_segments() {
    let gpu = gpu();
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let configs: Vec<Config> = (0..40)
        .map(|i| {
            let centre = [
                rng.random_range(-3.0..3.0),
                rng.random_range(-3.0..3.0),
                rng.random_range(0.5..3.0),
            ];
            let dir: Vec3 = [0; 3].map(|_| rng.random_range(-1.0..1.0f64));
            let half = 1e-2;
            let p1 = [0, 1, 2].map(|k| centre[k] - half * dir[k]);
            let p2 = [0, 1, 2].map(|k| centre[k] + half * dir[k]);
            segment(format!("short{i}"), p1, p2, Material::Diffuse)
        })
        .collect();
    let length = |c: &Config| (0..3).map(|k| (c.p2[k] - c.p1[k]).powi(2)).sum::<f64>().sqrt();
    // The same segments ten times longer: a representative point within O(L²/d) of where
    // the light's centroid would shade gives an error second order in L/d, so shrinking L
    // tenfold must shrink it about a hundredfold (a first-order error: tenfold).
    let longer: Vec<Config> = configs
        .iter()
        .map(|c| {
            let m = [0, 1, 2].map(|k| 0.5 * (c.p1[k] + c.p2[k]));
            let stretch = |p: Vec3| [0, 1, 2].map(|k| m[k] + 10.0 * (p[k] - m[k]));
            segment(c.id.clone(), stretch(c.p1), stretch(c.p2), Material::Diffuse)
        })
        .collect();
    for spec in [
        "line.mrp_bisector",
        "line.mrp_intersection",
        "line.mrp_bisector_nohorizon",
    ] {
        let (short, long) = (run(gpu, spec, &configs), run(gpu, spec, &longer));
        for i in 0..configs.len() {
            let r = reference(&configs[i], Target::LineIsotropic).unwrap().value;
            let r_long = reference(&longer[i], Target::LineIsotropic).unwrap().value;
            let (e, e_long) = (rel(short[i], r), rel(long[i], r_long));
            // The f32 floor: end points rounded to f32 move the length by ε·‖p‖/L, relatively.
            let c = &configs[i];
            let norm = |p: Vec3| dot(p, p).sqrt();
            let floor = 8.0 * f64::from(f32::EPSILON) * norm(c.p1).max(norm(c.p2)) / length(c);
            assert!(
                e <= 0.03 * e_long + floor,
                "{spec} on {}: {e:e} at L, {e_long:e} at 10L",
                c.id
            );
        }
    }
    // The closest point q is within L/2 of the centre, where a point light is second-order
    // accurate; moving f = z/r³ by δ changes it by at most (1/z + 3/r)·δ, relatively.
    let short = run(gpu, "line_isotropic.closest_point_r2", &configs);
    let offset = run(gpu, "line_isotropic.closest_point", &configs);
    for i in 0..configs.len() {
        let c = &configs[i];
        let r = reference(c, Target::LineIsotropic).unwrap().value;
        let (z, d) = (c.p1[2].min(c.p2[2]), c.distance_to_segment());
        let bound = (1.0 / z + 3.0 / d) * 0.5 * length(c) * 1.1 + 1e-4;
        assert!(
            rel(short[i], r) <= bound,
            "{}: {:e} vs {r:e}, bound {bound:e}",
            c.id,
            short[i]
        );
        // The 1/(d² + 1) falloff is off by the factor d²/(d² + 1) more, as written.
        let d2 = d * d;
        assert!(
            rel(offset[i], short[i] * d2 / (d2 + 1.0)) < 1e-5,
            "{}: {:e}",
            c.id,
            offset[i]
        );
    }
}

#[test]
fn mrp_intersection_and_bisector_forms_find_the_same_point() {
    let gpu = gpu();
    let configs = segments(3, 60);
    let a = run(gpu, "line.mrp_intersection", &configs);
    let b = run(gpu, "line.mrp_bisector", &configs);
    let mut compared = 0;
    for ((c, &x), &y) in configs.iter().zip(&a).zip(&b) {
        if y > 1e-3 {
            // Both are the intersection of the bisector of the angle at the shading point
            // with the (clipped) segment; f32 rounding differs by the intersection's solve.
            assert!(rel(x, y) < 1e-3, "{}: intersection {x:e} vs bisector {y:e}", c.id);
            compared += 1;
        }
    }
    assert!(compared >= 30, "{compared}");
}

/// The four corners of the configuration's rectangle, in the order the kernels use.
fn corners(c: &Config) -> [Vec3; 4] {
    let rect = c.rect.as_ref().unwrap();
    let e = [0, 1, 2].map(|k| c.p2[k] - c.p1[k]);
    let t = unit(e);
    let b = unit(cross(rect.normal, t));
    let h = b.map(|x| 0.5 * rect.width * x);
    let add = |p: Vec3, s: f64| [0, 1, 2].map(|k| p[k] + s * h[k]);
    [add(c.p1, -1.0), add(c.p2, -1.0), add(c.p2, 1.0), add(c.p1, 1.0)]
}

fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: Vec3, b: Vec3) -> Vec3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn unit(a: Vec3) -> Vec3 {
    let l = dot(a, a).sqrt();
    a.map(|x| x / l)
}

/// Lambert's formula for the transformed, horizon-clipped polygon in f64 (a test-only check
/// of the math of kernels/rectangle_ltc_polygon.wgsl until the CPU evaluator gives the kernel
/// an f64 column). The angle is taken by atan2(‖a×b‖, a·b), accurate at every size.
fn polygon_f64(c: &Config) -> f64 {
    polygon_terms_f64(c).0
}

/// (|Σ terms|/(2π), Σ|terms|/(2π)): the value and the size of the terms that cancel in it.
fn polygon_terms_f64(c: &Config) -> (f64, f64) {
    let minv = c.material.minv();
    let q = corners(c).map(|p| minv.map(|row| dot(row, p)));
    let mut v: Vec<Vec3> = Vec::new();
    for i in 0..4 {
        let (a, b) = (q[i], q[(i + 1) % 4]);
        if a[2] > 0.0 {
            v.push(a);
        }
        if (a[2] > 0.0) != (b[2] > 0.0) {
            let t = a[2] / (a[2] - b[2]);
            v.push([0, 1, 2].map(|k| a[k] + t * (b[k] - a[k])));
        }
    }
    if v.len() < 3 {
        return (0.0, 0.0);
    }
    let (mut sum, mut size) = (0.0, 0.0);
    for i in 0..v.len() {
        let (a, b) = (unit(v[i]), unit(v[(i + 1) % v.len()]));
        let n = cross(a, b);
        let s = dot(n, n).sqrt();
        if s > 0.0 {
            let term = s.atan2(dot(a, b)) * n[2] / s;
            sum += term;
            size += term.abs();
        }
    }
    (sum.abs() / (2.0 * PI), size / (2.0 * PI))
}

fn rectangles(seed: u64, n: usize, width: (f64, f64)) -> Vec<Config> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::new();
    while out.len() < n {
        let mut p = || [0; 3].map(|_| rng.random_range(-2.0..2.0f64));
        let (mut p1, p2) = (p(), p());
        if out.len() % 3 == 0 {
            p1[2] = -p1[2].abs();
        }
        let i = out.len();
        let material = match i % 3 {
            0 => Material::Diffuse,
            1 => Material::Ltc {
                minv: [[4.0, 0.0, -1.5], [0.0, 3.5, 0.0], [0.1, 0.0, 1.0]],
            },
            _ => Material::Ltc {
                minv: [[2.0, 0.7, -0.4], [-0.5, 3.0, 0.3], [0.1, -0.2, 1.0]],
            },
        };
        let mut c = segment(format!("r{i}"), p1, p2, material);
        c.rect = Some(Rect {
            normal: p(),
            width: rng.random_range(width.0..width.1),
        });
        if c.orthonormalize_rect().is_some() && c.validate().is_ok() && c.distance_to_segment() > 0.2 {
            out.push(c);
        }
    }
    out
}

#[test]
fn polygon_integral_of_the_thin_rectangle_is_exact_in_f64() {
    let mut seen = 0;
    for c in rectangles(4, 45, (1e-3, 0.5)) {
        let r = reference(&c, Target::Rectangle).unwrap();
        let v = polygon_f64(&c);
        seen += (r.value > 0.0) as usize;
        assert!(
            (v - r.value).abs() <= 1e-8 * r.value.abs() + r.error,
            "{}: polygon {v:e} vs reference {r:?}",
            c.id
        );
    }
    assert!(seen >= 25, "{seen}");
}

#[test]
fn polygon_ltc_kernels_on_the_gpu() {
    let gpu = gpu();
    // Wide enough that f32 cancellation between the long edges stays small: each long
    // edge contributes O(1), their difference O(W), so the f32 error is O(ε/W) relatively.
    let configs = rectangles(5, 45, (0.1, 0.5));
    let exact = run(gpu, "rectangle.ltc_polygon", &configs);
    let atan2 = run(gpu, "rectangle.ltc_polygon_atan2", &configs);
    let fit = run(gpu, "rectangle.ltc_polygon_fit", &configs);
    let sphere = run(gpu, "rectangle.ltc_sphere", &configs);
    // The fit's own worst relative error of θ/sin θ on [−1, 1], measured here in f64.
    let fit_error = (0..=20000)
        .map(|i| {
            let x: f64 = -0.999 + 1.998 * i as f64 / 20000.0;
            let y = x.abs();
            let f = (5.42031 + (3.12829 + 0.0902326 * y) * y) / (3.45068 + (4.18814 + y) * y);
            let f = if x < 0.0 { PI / (1.0 - x * x).sqrt() - f } else { f };
            let t = x.acos();
            (f - t / t.sin()).abs() / (t / t.sin())
        })
        .fold(0.0f64, f64::max);
    let mut checked = 0;
    for (i, c) in configs.iter().enumerate() {
        let r = reference(c, Target::Rectangle).unwrap().value;
        if r < 1e-4 {
            continue;
        }
        // The long edges' terms cancel to O(W): each term carries the relative error of its
        // angle (Vulkan lets acos be off by 4096 ULP, 2.4e-4), so the sum is off by up to
        // that times the terms' total size, plus f32 rounding of the value itself.
        let size = polygon_terms_f64(c).1;
        let acos_bound = 5e-4 * size + 1e-4 * r;
        assert!(
            (exact[i] - r).abs() < acos_bound,
            "{}: polygon {:e} vs {r:e}",
            c.id,
            exact[i]
        );
        // Vulkan allows atan2 the same 4096 ULP.
        assert!(
            (atan2[i] - r).abs() < acos_bound,
            "{}: atan2 {:e} vs {r:e}",
            c.id,
            atan2[i]
        );
        // Every edge's weight θ/sin θ is off by at most fit_error, relatively.
        let fit_bound = (fit_error + 1e-4) * size + 1e-4 * r;
        assert!((fit[i] - r).abs() < fit_bound, "{}: fit {:e} vs {r:e}", c.id, fit[i]);
        // The clipped-sphere form factor is an approximation everywhere (the sweep measures
        // it); it is finite and never negative.
        assert!(
            sphere[i].is_finite() && sphere[i] >= 0.0,
            "{}: sphere {:e}",
            c.id,
            sphere[i]
        );
        checked += 1;
    }
    assert!(checked >= 20, "{checked}");
    assert!(fit_error > 0.0 && fit_error < 1e-2, "{fit_error}");
}

#[test]
fn the_2017_integral_with_the_polynomial_atan_is_off_by_the_polynomial_only() {
    let gpu = gpu();
    let configs = segments(6, 60);
    let exact = run(gpu, "line.ltc2017", &configs);
    let poly = run(gpu, "line.ltc2017_atan5", &configs);
    let mut worst = 0.0f64;
    for ((c, &a), &p) in configs.iter().zip(&exact).zip(&poly) {
        // I = (Fpo(l2) − Fpo(l1))·po.z/π + …: each atan off by ≤ 1.351e-3 (published) moves I
        // by ≤ 2·1.351e-3·|po.z|/(π d²), po the foot of the clipped segment (|po.z| ≤ d).
        let d = c.distance_to_line();
        let bound = 2.0 * 1.351e-3 / (PI * d) + 1e-4 * a.abs();
        assert!((a - p).abs() <= bound, "{}: {p:e} vs {a:e} (bound {bound:e})", c.id);
        if a > 1e-3 {
            worst = worst.max(rel(p, a));
        }
    }
    assert!(worst > 1e-5, "the polynomial is in use: {worst:e}");
}

#[test]
fn isotropic_composites_take_an_isotropic_line_method() {
    let gpu = gpu();
    let kernels = builtin_kernels();
    let e = resolve("cylinder.isotropic[line.ltc2017]", &kernels)
        .unwrap_err()
        .to_string();
    assert!(e.contains("must be a `target: line_isotropic` kernel"), "{e}");
    let m = resolve("cylinder.isotropic", &kernels).unwrap();
    assert_eq!(m.describe(), "cylinder.isotropic[line_isotropic.karis2013_clip]");
    let mut configs = segments(7, 20);
    for c in &mut configs {
        c.radius = Some(0.01);
    }
    let tube = run(gpu, "cylinder.isotropic", &configs);
    let line = run(gpu, "line_isotropic.karis2013_clip", &configs);
    for ((c, t), l) in configs.iter().zip(tube).zip(line) {
        let expected = 0.5 * PI * 0.01 * l;
        assert!(
            (t - expected).abs() <= 4.0 * f64::from(f32::EPSILON) * expected,
            "{}: {t:e} vs {expected:e}",
            c.id
        );
    }
}

#[test]
fn the_intersection_form_fails_for_a_segment_pointing_at_the_shading_point() {
    // Seed 002 says the half vector and the line intersect "by construction"; when the line
    // runs through the shading point (outside the segment) H ∥ AB, cross(H, AB) = 0 and the
    // intersection form divides 0 by 0. The bisector form needs no intersection.
    let gpu = gpu();
    let end_on = vec![
        segment("end-on", [0.0, 0.6, 0.8], [0.0, 1.2, 1.6], Material::Diffuse),
        segment("end-on-2", [0.3, 0.0, 0.4], [1.5, 0.0, 2.0], Material::Diffuse),
    ];
    let a = run(gpu, "line.mrp_intersection", &end_on);
    let b = run(gpu, "line.mrp_bisector", &end_on);
    for ((c, &x), &y) in end_on.iter().zip(&a).zip(&b) {
        let r = reference(c, Target::LineIsotropic).unwrap().value;
        assert!(r > 0.0, "{}", c.id);
        assert!(
            !(x.is_finite() && rel(x, r) < 0.5),
            "{}: intersection {x:e} vs {r:e}",
            c.id
        );
        assert!(y.is_finite() && y > 0.0, "{}: bisector {y:e}", c.id);
    }
}
