//! Every built-in method on lavapipe, on a small fixed set of well-conditioned
//! configurations: the GPU agrees with the CPU evaluator's f32 column of the same kernel, and the method agrees
//! with the f64 reference to the accuracy its kind promises.

use crate::common;

use linelight::eval::interp::CpuColumns;
use linelight::input::scene::{Config, GpuScene, Material, Rect};
use linelight::kernel::builtin_kernels;
use linelight::kernel::methods::{resolve, Method};
use linelight::measure::gpu::Gpu;
use linelight::reference::reference;

fn fixed_set() -> Vec<Config> {
    let materials = [
        Material::Diffuse,
        Material::Ltc {
            minv: [[0.5, 0.0, 0.1], [0.0, 0.6, 0.0], [-0.2, 0.0, 1.0]],
        },
        Material::Ltc {
            minv: [[4.0, 0.0, -1.5], [0.0, 3.5, 0.0], [0.1, 0.0, 1.0]],
        },
        Material::Ltc {
            minv: [[2.0, 0.7, -0.4], [-0.5, 3.0, 0.3], [0.1, -0.2, 1.0]],
        },
    ];
    let segments = [
        ([0.3, -0.2, 1.0], [0.9, 0.4, 1.6]),
        ([-1.0, 0.5, 1.0], [1.0, 0.5, 1.0]),
        ([0.2, 0.1, -0.5], [0.4, 0.3, 1.5]),
        ([1.5, -1.0, 0.4], [-0.5, 1.0, 0.9]),
        ([0.1, 0.3, 0.6], [0.2, 0.35, 0.9]),
    ];
    let mut out = Vec::new();
    for (i, m) in materials.iter().enumerate() {
        for (j, (p1, p2)) in segments.iter().enumerate() {
            let mut c = Config {
                id: format!("m{i}s{j}"),
                p1: *p1,
                p2: *p2,
                radius: Some(0.05),
                // A thin rectangle turned partly towards the shading point.
                rect: Some(Rect {
                    normal: [0.3, -0.5, -1.0],
                    width: 0.05,
                }),
                material: m.clone(),
                texture: None,
            };
            c.orthonormalize_rect().expect("normal not parallel to the segment");
            c.validate().expect("a valid configuration");
            out.push(c);
        }
    }
    out
}

fn run(gpu: &Gpu, m: &Method, configs: &[Config]) -> Vec<f32> {
    let scenes: Vec<GpuScene> = configs.iter().map(GpuScene::from).collect();
    let pipeline = gpu.pipeline(m).unwrap_or_else(|e| panic!("{}: {e}", m.label));
    gpu.run(&pipeline, &scenes, 7, &mut |_| {}).unwrap().values
}

/// Vulkan lets atan/acos be off by 4096 ULP (≈ 2.4e-4 relative; lavapipe's acos is measured
/// at 2.3e-4): the GPU and the CPU evaluator's f32 column of a formula built on them may differ by that much.
/// lavapipe's acos, measured against correctly rounded acos: absolute error up to 1.6e-4.
const LAVAPIPE_ACOS: f64 = 1.6e-4;
const VULKAN_TRANSCENDENTAL: f64 = 5e-4;

/// Relative accuracy each method must reach against the reference on this benign set, about
/// 10× its worst error measured here on lavapipe (in the comments) and never looser than the
/// 1e-3 it was. Every built-in method has its own bound against the reference on a larger set
/// in tests/method_bounds.rs.
fn promised(label: &str) -> Option<f64> {
    match label {
        // 1.25e-5, 1.10e-5 and 1.28e-5: f32 rounding only.
        "line.ltc2017" | "line.ltc2017_fwt" | "line.ltc2023_fix" => Some(1.3e-4),
        // 1.95e-4 and 2.05e-4: the 2023 listing's acos of the end points' cosine loses digits in f32
        // (reports/line_fwt, "The 2023 listing is much less accurate in f32"). 5× that: the
        // bound was 1e-3 before, and is not widened to 10×.
        "line.ltc2023" | "line.ltc2023_full" => Some(1e-3),
        // 1.52e-5 (7×).
        "line.numeric@64" => Some(1e-4),
        // Listing 1.4 is a crude rule (end points included, weight L/n): only its cpu_f32 column is checked.
        _ => None,
    }
}

#[test]
fn every_builtin_method_runs_and_matches_its_cpu_f32_column_and_the_reference() {
    let gpu = common::gpu();
    let configs = fixed_set();
    let kernels = builtin_kernels();
    let mut labels: Vec<String> = kernels.iter().map(|k| k.id.clone()).collect();
    labels.push("line.numeric@64".into());
    let mut tested = 0;
    for label in labels {
        let m = resolve(&label, &kernels).unwrap();
        let values = run(gpu, &m, &configs);
        assert_eq!(values.len(), configs.len());
        for (c, &v) in configs.iter().zip(&values) {
            // A `minv: ggx` kernel reads the ggx roughness, which is 0 on this set's materials
            // (its lobe is undefined there): tests/mrp_specular.rs checks those on ggx.
            let ggx_only = m.kernel.minv == linelight::kernel::MinvSupport::Ggx;
            if !m.applies(c) || (ggx_only && !m.supports(c)) {
                continue;
            }
            let r = reference(c, m.target()).unwrap();
            let scale = r.value.abs().max(1e-6);
            assert!(v.is_finite(), "{label} on {}: {v}", c.id);
            // Every built-in, engine formulas included, runs in the CPU evaluator (src/eval/interp).
            let cpu = m
                .eval_f32_cpu(c)
                .map(f64::from)
                .unwrap_or_else(|| panic!("{label}: the CPU evaluator runs every built-in"));
            // GPU and CPU round differently (FMA, atan/acos implementations); a porting
            // mistake shows as an O(1) difference, far above this. Seed 003's polygon form
            // sums an acos per edge (4 edges, each over 2π): lavapipe's acos is off by up to
            // LAVAPIPE_ACOS absolute, whatever the size of the result.
            let allowance = if m.id() == "rectangle.ltc_polygon" {
                (VULKAN_TRANSCENDENTAL * scale).max(4.0 * LAVAPIPE_ACOS / std::f64::consts::TAU)
            } else {
                VULKAN_TRANSCENDENTAL * scale
            };
            assert!(
                (v as f64 - cpu).abs() <= allowance,
                "{label} on {}: GPU {v:e} vs CPU f32 {cpu:e} (ref {:e})",
                c.id,
                r.value
            );
            if let (Some(tol), true) = (promised(&label), m.supports(c)) {
                let rel = (v as f64 - r.value).abs() / scale;
                assert!(
                    rel <= tol,
                    "{label} on {}: GPU {v:e} vs reference {:e} (rel {rel:e})",
                    c.id,
                    r.value
                );
                let f64_rel = (m.eval_f64(c).unwrap() - r.value).abs() / scale;
                // The 2023 listing's INV_PI = 0.3183098861 alone is 2.6e-10 off.
                assert!(
                    f64_rel <= 1e-9 || label.starts_with("line.numeric"),
                    "{label} f64 on {}: rel {f64_rel:e}",
                    c.id
                );
            }
            tested += 1;
        }
    }
    assert!(tested >= 100, "only {tested} evaluations checked");
}

#[test]
fn the_2023_listing_is_wrong_for_full_matrices_and_the_fix_is_not() {
    let gpu = common::gpu();
    let kernels = builtin_kernels();
    let full: Vec<Config> = fixed_set().into_iter().filter(|c| !c.material.is_sparse()).collect();
    let published = run(gpu, &resolve("line.ltc2023", &kernels).unwrap(), &full);
    let full_m = resolve("line.ltc2023_full", &kernels).unwrap();
    let fixed = run(gpu, &full_m, &full);
    let mut worst_published = 0.0f64;
    for ((c, &p), &f) in full.iter().zip(&published).zip(&fixed) {
        let r = reference(c, linelight::input::target::Target::Line).unwrap().value;
        worst_published = worst_published.max((p as f64 - r).abs() / r.abs());
        // 1e-4 before the composite commit, which moved it to `promised` (1e-3) without a
        // word; measured 2.05e-4 (the 2023 acos in f32, not the width factor, which the f64
        // bound below holds to its INV_PI), so 1e-4 cannot come back: 1e-3, 5× measured.
        assert!(
            (f as f64 - r).abs() <= promised("line.ltc2023_full").unwrap() * r.abs(),
            "{}: fix {f:e} vs {r:e}",
            c.id
        );
        let fixed_f64 = full_m.eval_f64(c).unwrap();
        assert!(
            (fixed_f64 - r).abs() <= 1e-9 * r.abs(),
            "{}: fix in f64 {fixed_f64:e} vs {r:e}",
            c.id
        );
    }
    // Measured 6.19e-2 on m3s0 (the sparse width factor's own error: f64 gives 6.18e-2), pinned
    // within a factor 2 both ways: a silent fix of the published listing fails here too.
    assert!(
        worst_published > 3e-2 && worst_published < 0.125,
        "the sparse width factor should be visibly wrong, by what it was: {worst_published:e}"
    );
}
