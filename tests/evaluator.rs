//! The CPU evaluator from outside: a user's kernel gets its f64 column, and the bits lost
//! per source line (attribution) land where the findings say they do.

use crate::common::segment;
use linelight::eval::interp::CpuColumns;
use linelight::eval::interp::{program, Mode};
use linelight::input::scene::{Config, Material};
use linelight::input::target::Target;
use linelight::kernel::methods::{kernel_set, resolve};
use rand::{Rng, SeedableRng};

fn config(p1: [f64; 3], p2: [f64; 3], material: Material) -> Config {
    segment("", p1, p2, material)
}

fn sparse() -> Material {
    Material::Ltc {
        minv: [[0.7, 0.0, 0.15], [0.0, 0.9, 0.0], [-0.25, 0.0, 1.0]],
    }
}

/// Short segments well above the surface at distance ~1: every subtended angle below
/// `max_angle` (radians).
fn small_angle_configs(n: usize, max_angle: f64) -> Vec<Config> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(23);
    (0..n)
        .map(|i| {
            let c = [
                rng.random_range(-0.5..0.5),
                rng.random_range(-0.5..0.5),
                rng.random_range(0.8..1.2),
            ];
            let t = [
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0f64),
            ];
            let norm = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
            let half = 0.5 * max_angle * rng.random_range(0.05..1.0) * 0.8;
            let p1 = [0, 1, 2].map(|k| c[k] - half * t[k] / norm);
            let p2 = [0, 1, 2].map(|k| c[k] + half * t[k] / norm);
            config(p1, p2, if i % 2 == 0 { Material::Diffuse } else { sparse() })
        })
        .collect()
}

#[test]
fn a_user_copy_of_a_builtin_gets_f64_agreeing_with_the_reference() {
    let builtin = kernel_set(&[], &linelight::kernel::Includes::none()).unwrap();
    let text = builtin
        .iter()
        .find(|k| k.id == "line.ltc2017")
        .unwrap()
        .text
        .replace("//! id: line.ltc2017\n", "//! id: user.copy2017\n");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("copy.wgsl");
    std::fs::write(&path, text).unwrap();
    let kernels = kernel_set(&[path], &linelight::kernel::Includes::none()).unwrap();
    let m = resolve("user.copy2017", &kernels).unwrap();
    // Well conditioned: above the surface, length and distance of the same order.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let configs: Vec<Config> = (0..200)
        .map(|i| {
            let mut p = || {
                [
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(0.5..1.5),
                ]
            };
            config(p(), p(), if i % 2 == 0 { Material::Diffuse } else { sparse() })
        })
        .filter(|c| c.validate().is_ok() && c.distance_to_line() > 0.2)
        .collect();
    assert!(configs.len() > 100);
    let f64s = m.cpu_column(&configs, Mode::F64).unwrap();
    let mut worst = 0.0f64;
    for (c, v) in configs.iter().zip(&f64s) {
        let r = linelight::reference::reference(c, Target::Line).unwrap();
        assert!(
            r.error < 1e-13 * r.value.abs(),
            "reference error {:e} of {:e}",
            r.error,
            r.value
        );
        worst = worst.max((v.unwrap() - r.value).abs() / r.value.abs());
    }
    eprintln!(
        "user.copy2017 f64 against the reference: worst relative {worst:.1e} over {}",
        configs.len()
    );
    assert!(worst < 1e-12, "{worst:e}");
    // And an f32 column, on the CPU, for the same user kernel.
    let f32s = m.cpu_column(&configs, Mode::F32).unwrap();
    assert!(f32s.iter().all(|v| v.is_some_and(|x| x == (x as f32) as f64)));
}

fn top_line(spec: &str, configs: &[Config]) -> linelight::eval::interp::LineSummary {
    let kernels = kernel_set(&[], &linelight::kernel::Includes::none()).unwrap();
    let p = program(&resolve(spec, &kernels).unwrap()).unwrap();
    let refs: Vec<&Config> = configs.iter().collect();
    let a = p.attribute(&refs).unwrap();
    // The f32 values of the attribution run are the plain f32 evaluation's.
    assert_eq!(a.f32, p.eval(&refs, Mode::F32).unwrap());
    let summary = a.summary();
    for s in summary.iter().take(5) {
        eprintln!(
            "{spec}: {}:{} mean {:.2} p99 {:.2} bits  {}",
            s.line.path,
            s.line.line,
            s.mean,
            s.p99,
            s.line.text.trim()
        );
    }
    summary.into_iter().next().unwrap()
}

#[test]
fn the_2023_acos_tops_at_small_subtended_angles() {
    let top = top_line("line.ltc2023", &small_angle_configs(400, 1e-2));
    assert!(top.line.text.contains("acos("), "{top:?}");
    assert!(top.line.path.ends_with("line_ltc2023.wgsl"));
}

#[test]
fn the_2017_fwt_subtraction_tops_beside_a_steep_segment() {
    // Nearly vertical segments passing close beside the shading point: |l| ≫ d at both ends.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(17);
    let configs: Vec<Config> = (0..400)
        .map(|i| {
            let d = rng.random_range(0.01..0.05);
            let a: f64 = rng.random_range(0.0..std::f64::consts::TAU);
            let (x, y) = (d * a.cos(), d * a.sin());
            let tilt = rng.random_range(-0.02..0.02);
            let p1 = [x, y, rng.random_range(0.5..1.0)];
            let p2 = [x + tilt, y, rng.random_range(5.0..20.0)];
            config(p1, p2, if i % 2 == 0 { Material::Diffuse } else { sparse() })
        })
        .collect();
    let top = top_line("line.ltc2017", &configs);
    assert!(top.line.text.contains("(Fwt(d, l2) - Fwt(d, l1))"), "{top:?}");
}

#[test]
fn eval_gives_a_user_kernel_f64_cpu_f32_and_attribution() {
    let dir = tempfile::tempdir().unwrap();
    let kernel = dir.path().join("half.wgsl");
    std::fs::write(
        &kernel,
        "//! id: user.half\n//! target: line\nconst HALF: f32 = 0.1;\n\nfn method(scene: Scene) -> f32 {\n    let l = length(scene.p2 - scene.p1);\n    return HALF * l;\n}\n",
    )
    .unwrap();
    let input = dir.path().join("in.jsonl");
    std::fs::write(
        &input,
        r#"{"id":"a","p1":[0.3,-0.2,1.0],"p2":[0.9,0.4,1.6],"material":{"kind":"diffuse"}}"#,
    )
    .unwrap();
    let output = dir.path().join("out.jsonl");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_linelight"))
        .args([
            "eval",
            "--attribution",
            "--methods",
            "user.half,line.ltc2023",
            "--kernel",
        ])
        .arg(&kernel)
        .arg("--input")
        .arg(&input)
        .arg("--output")
        .arg(&output)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let row: serde_json::Value = serde_json::from_str(std::fs::read_to_string(&output).unwrap().trim()).unwrap();
    let m = &row["methods"]["user.half"];
    let l = (0.6f64 * 0.6 * 3.0).sqrt();
    // f64 with the constant's written digits: 0.1 exactly as f64 reads it, not f32(0.1).
    assert_eq!(m["f64"].as_f64().unwrap(), 0.1 * l);
    assert_eq!(m["cpu_f32"].as_f64().unwrap() as f32, m["f32"].as_f64().unwrap() as f32);
    let lines = row["attribution"]["user.half"].as_array().unwrap();
    assert!(!lines.is_empty());
    for l in lines {
        assert!(l["file"].as_str().unwrap().ends_with("half.wgsl"));
        assert!(l["bits_max"].as_f64().unwrap() >= l["bits_mean"].as_f64().unwrap());
        let text = std::fs::read_to_string(&kernel).unwrap();
        let n = l["line"].as_u64().unwrap() as usize;
        assert_eq!(text.lines().nth(n - 1).unwrap().trim(), l["source"].as_str().unwrap());
    }
    assert!(row["attribution"]["line.ltc2023"]
        .as_array()
        .is_some_and(|a| !a.is_empty()));
}

#[test]
fn check_emit_prints_the_composed_kernel_and_says_the_evaluator_runs_it() {
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_linelight"))
        .args(["check", "--emit", "kernels/cylinder_line.wgsl"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert!(o.status.success());
    let (out, err) = (String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    assert!(
        err.contains("ok (cylinder.line → cylinder); CPU evaluator: ok"),
        "{err}"
    );
    // Prelude, the default inner line method renamed, the glue, the kernel, the entry point.
    for part in [
        "struct Scene",
        "fn ll_line_method(",
        "fn I_line(",
        "fn I_cylinder_approx(",
        "fn ll_main(",
    ] {
        assert!(out.contains(part), "{part}");
    }
    // It is what naga validates: it parses again.
    naga::front::wgsl::parse_str(&out).unwrap();
}
