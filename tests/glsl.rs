//! GLSL kernels: the GLSL port of a built-in (kernels/glsl/line_ltc2017.glsl, Listings 1.6 +
//! 1.7 in their own language) agrees with the WGSL port (kernels/line_ltc2017.wgsl) to f32
//! rounding on the GPU and in the CPU evaluator (f32 and f64), over a case's configurations on
//! all three material kinds.

use crate::common;

use linelight::eval::interp::{CpuColumns, Engine};
use linelight::eval::program::Mode;
use linelight::input::case::Case;
use linelight::input::scene::GpuScene;
use linelight::kernel::methods::{kernel_set, resolve};
use std::path::PathBuf;

const GLSL: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/kernels/glsl/line_ltc2017.glsl");

/// Units in the last place of f32 between two results (0 for equal, both NaN, same infinity).
fn ulps(a: f32, b: f32) -> u64 {
    if a == b || (a.is_nan() && b.is_nan()) {
        return 0;
    }
    if !a.is_finite() || !b.is_finite() {
        return u64::MAX;
    }
    let key = |x: f32| {
        let i = x.to_bits() as i32;
        if i < 0 {
            i64::from(i32::MIN) - i64::from(i)
        } else {
            i64::from(i)
        }
    };
    (key(a) - key(b)).unsigned_abs()
}

#[test]
fn glsl_port_agrees_with_the_wgsl_port_on_the_gpu() {
    let mut case = Case::load(&PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/cases/line_fwt.toml"
    )))
    .unwrap();
    for m in &mut case.materials {
        m.count = 2000;
    }
    let configs: Vec<_> = linelight::input::sampler::sample_case(&case)
        .into_iter()
        .map(|s| s.config)
        .collect();
    let kernels = kernel_set(&[PathBuf::from(GLSL)], &linelight::kernel::Includes::none()).unwrap();
    let gpu = common::gpu();
    let scenes: Vec<GpuScene> = configs.iter().map(GpuScene::from).collect();
    let run = |spec: &str| {
        let m = resolve(spec, &kernels).unwrap();
        gpu.run(&gpu.pipeline(&m).unwrap(), &scenes, 0, &mut |_| {})
            .unwrap()
            .values
    };
    let wgsl = run("line.ltc2017");
    let glsl = run("line.ltc2017_glsl");
    let worst = wgsl.iter().zip(&glsl).map(|(&a, &b)| ulps(a, b)).max().unwrap();
    let differ = wgsl.iter().zip(&glsl).filter(|(a, b)| ulps(**a, **b) > 0).count();
    println!("{differ} of {} configurations differ; worst {worst} ulp", wgsl.len());
    // Same operations in the same order: at most a rounding step apart where the two
    // front ends order a sum or fold a constant differently.
    assert!(
        worst <= 4,
        "GLSL and WGSL ports differ by {worst} ulp ({differ} configurations differ)"
    );

    // The CPU evaluator runs the GLSL kernel's translation like any kernel: f32 and f64.
    let some: Vec<_> = configs.iter().step_by(10).cloned().collect();
    for mode in [linelight::eval::interp::Mode::F32, linelight::eval::interp::Mode::F64] {
        let f32_mode = matches!(mode, linelight::eval::interp::Mode::F32);
        let cpu = |spec: &str| resolve(spec, &kernels).unwrap().cpu_column(&some, mode).unwrap();
        let (w, g) = (cpu("line.ltc2017"), cpu("line.ltc2017_glsl"));
        let worst = w
            .iter()
            .zip(&g)
            .map(|(a, b)| match (a, b) {
                (Some(a), Some(b)) if a == b || (a.is_nan() && b.is_nan()) => 0.0,
                (Some(a), Some(b)) => (a - b).abs() / a.abs().max(b.abs()),
                _ => f64::INFINITY,
            })
            .fold(0.0, f64::max);
        println!(
            "evaluator {}: worst relative difference {worst:e} over {} configurations",
            if f32_mode { "f32" } else { "f64" },
            some.len()
        );
        // f32 rounding: a few units of 2^-24 in f32; f64's own rounding in f64.
        let limit = if f32_mode { 4.0 * f64::from(f32::EPSILON) } else { 1e-12 };
        assert!(worst <= limit, "evaluator: GLSL and WGSL ports differ by {worst:e}");
    }
}

#[test]
fn glsl_specialization_constants_are_the_header_params() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.glsl");
    std::fs::write(
        &path,
        "//! id: line.gp\n//! target: line\n//! params: N=3 SCALE=0.5\n\
         layout(constant_id = 0) const uint N = 7;\n\
         layout(constant_id = 1) const float SCALE = 1.0;\n\
         float method(Scene scene) {\n    return SCALE * scene.p1.x + float(N);\n}\n",
    )
    .unwrap();
    let kernels = kernel_set(&[path], &linelight::kernel::Includes::none()).unwrap();
    let gpu = common::gpu();
    let scenes: Vec<GpuScene> = [1.0f32, 3.0]
        .iter()
        .map(|&x| GpuScene {
            p1: [x, 0.0, 1.0],
            p2: [x, 1.0, 1.0],
            ..Default::default()
        })
        .collect();
    let run = |spec: &str| {
        let m = resolve(spec, &kernels).unwrap();
        gpu.run(&gpu.pipeline(&m).unwrap(), &scenes, 0, &mut |_| {})
            .unwrap()
            .values
    };
    // The header's defaults, not the GLSL initialisers; then both set from the spec.
    assert_eq!(run("line.gp"), vec![3.5, 4.5]);
    assert_eq!(run("line.gp@2x-0.25"), vec![1.75, 1.25]);
}

#[test]
fn glsl_composite_takes_any_line_method() {
    let mut case = Case::load(&PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/cases/cylinder.toml"
    )))
    .unwrap();
    for m in &mut case.materials {
        m.count = 500;
    }
    let configs: Vec<_> = linelight::input::sampler::sample_case(&case)
        .into_iter()
        .map(|s| s.config)
        .collect();
    let cyl = concat!(env!("CARGO_MANIFEST_DIR"), "/kernels/glsl/cylinder_line.glsl");
    let kernels = kernel_set(
        &[PathBuf::from(cyl), PathBuf::from(GLSL)],
        &linelight::kernel::Includes::none(),
    )
    .unwrap();
    let gpu = common::gpu();
    let scenes: Vec<GpuScene> = configs.iter().map(GpuScene::from).collect();
    let run = |spec: &str| {
        let m = resolve(spec, &kernels).unwrap();
        gpu.run(&gpu.pipeline(&m).unwrap(), &scenes, 0, &mut |_| {})
            .unwrap()
            .values
    };
    let wgsl = run("cylinder.line[line.ltc2017]");
    for glsl in [
        run("cylinder.line_glsl[line.ltc2017]"),
        run("cylinder.line_glsl[line.ltc2017_glsl]"),
    ] {
        let worst = wgsl.iter().zip(&glsl).map(|(&a, &b)| ulps(a, b)).max().unwrap();
        assert!(worst <= 4, "GLSL and WGSL composites differ by {worst} ulp");
    }
}

/// The configurations where the 2017 listing loses most in its Fwt subtraction: nearly
/// vertical segments close beside the shading point.
fn steep_configs() -> Vec<linelight::input::scene::Config> {
    let mut case = Case::load(&PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/cases/line_fwt.toml"
    )))
    .unwrap();
    for m in &mut case.materials {
        m.count = 300;
    }
    linelight::input::sampler::sample_case(&case)
        .into_iter()
        .map(|s| s.config)
        .collect()
}

#[test]
fn glsl_attribution_names_the_glsl_files_own_lines() {
    let glsl_text = std::fs::read_to_string(GLSL).unwrap();
    let kernels = kernel_set(&[PathBuf::from(GLSL)], &linelight::kernel::Includes::none()).unwrap();
    let configs = steep_configs();
    let refs: Vec<_> = configs.iter().collect();
    let lines = |spec: &str| {
        let p = linelight::eval::interp::program(&resolve(spec, &kernels).unwrap()).unwrap();
        p.attribute(&refs).unwrap().summary()
    };
    let glsl = lines("line.ltc2017_glsl");
    // The prelude's helpers (inverse3) keep their own file; every other line is the kernel's.
    let own: Vec<_> = glsl.iter().filter(|s| !s.line.path.ends_with("prelude.wgsl")).collect();
    assert!(own.len() >= 5, "{glsl:?}");
    for s in own {
        assert!(s.line.path.ends_with("line_ltc2017.glsl"), "{:?}", s.line);
        // The attributed line is the GLSL file's own line, text and number.
        assert_eq!(
            glsl_text.lines().nth(s.line.line - 1),
            Some(s.line.text.as_str()),
            "{:?}",
            s.line
        );
        assert!(!s.line.text.contains("_e"), "a line of the translation: {:?}", s.line);
    }
    // The same statement tops both ports: the WGSL port's top line and the GLSL port's
    // top line hold the same Fwt subtraction.
    let wgsl = lines("line.ltc2017");
    let squash = |t: &str| {
        t.split_whitespace()
            .collect::<String>()
            .replace("let", "")
            .replace("float", "")
    };
    println!(
        "top lines: WGSL `{}`, GLSL `{}`",
        wgsl[0].line.text.trim(),
        glsl[0].line.text.trim()
    );
    assert!(
        squash(&glsl[0].line.text).contains("(Fwt(d,l2)-Fwt(d,l1))"),
        "{:?}",
        glsl[0].line
    );
    assert!(
        squash(&wgsl[0].line.text).contains("(Fwt(d,l2)-Fwt(d,l1))"),
        "{:?}",
        wgsl[0].line
    );
}

#[test]
fn an_error_found_after_translation_names_the_glsl_line() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.glsl");
    // The header's param has no specialization constant: found in the translation, at
    // the header line of the GLSL file.
    std::fs::write(
        &path,
        "//! id: line.gq\n//! target: line\n\nfloat twice(float x) {\n    return 2.0 * x;\n}\n\n\
         //! params: SAMPLES=4\nfloat method(Scene scene) {\n    return twice(scene.p1.z);\n}\n",
    )
    .unwrap();
    let kernel = linelight::kernel::KernelFile::read(&path, &linelight::kernel::Includes::none()).unwrap();
    let Err(e) = linelight::kernel::compose(&kernel) else {
        panic!("a header param without its specialization constant is refused");
    };
    assert_eq!(e.location.map(|l| l.0), Some(8), "{}", e.report);
    assert!(e.report.contains("p.glsl:8"), "{}", e.report);
}

/// A GLSL local matrix built from nine constants: naga emits its columns in the body and
/// makes the matrix the variable's initialiser, which the CPU evaluator needs before the
/// body runs. Every CPU column is there and is the product's value, on both engines.
#[test]
fn a_local_matrix_of_constants_is_evaluated_on_the_cpu() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("mat3_local.glsl");
    std::fs::write(
        &path,
        "//! id: test.mat3_local\n//! target: line\n//! minv: full\n\n\
         float method(Scene scene) {\n    mat3 m = mat3(1.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 3.0);\n    \
         vec3 v = m * scene.p1;\n    return v.x + v.y + v.z;\n}\n",
    )
    .unwrap();
    let kernels = kernel_set(&[path], &linelight::kernel::Includes::none()).unwrap();
    let configs = steep_configs();
    let refs: Vec<_> = configs.iter().take(64).collect();
    let p = linelight::eval::interp::program(&resolve("test.mat3_local", &kernels).unwrap()).unwrap();
    for engine in [Engine::Interpreter, Engine::Compiled] {
        let got = p.eval_on(&refs, Mode::F64, engine).unwrap();
        for (c, v) in refs.iter().zip(&got) {
            let want = c.p1[0] + 2.0 * c.p1[1] + 3.0 * c.p1[2];
            assert!(
                (v - want).abs() <= 1e-6 * want.abs().max(1.0),
                "{engine:?}: {v} against {want}"
            );
        }
        let f32s = p.eval_on(&refs, Mode::F32, engine).unwrap();
        assert_eq!(f32s.len(), refs.len());
    }
}

/// three.js writes `const in` parameters (`LTC_Evaluate(const in vec3 N, …)`): such a kernel
/// is read as with `in`, and gives the same values as the same kernel without `const`.
#[test]
fn const_in_parameters_are_accepted_as_engines_write_them() {
    let dir = tempfile::tempdir().unwrap();
    let kernel = |id: &str, qualifier: &str| {
        let text = format!(
            "//! id: {id}\n//! target: line\n//! minv: full\n\n\
             float twice(const {qualifier} vec3 v) {{\n    return 2.0 * (v.x + v.y);\n}}\n\n\
             float method(Scene scene) {{\n    return twice(scene.p1);\n}}\n"
        );
        let path = dir.path().join(format!("{id}.glsl"));
        std::fs::write(&path, text.replace(&format!("const {qualifier}"), qualifier)).unwrap();
        let with_const = dir.path().join(format!("{id}_const.glsl"));
        std::fs::write(
            &with_const,
            text.replace(&format!("//! id: {id}"), &format!("//! id: {id}_const")),
        )
        .unwrap();
        (path, with_const)
    };
    let (plain, with_const) = kernel("test.param_in", "in");
    let kernels = kernel_set(&[plain, with_const], &linelight::kernel::Includes::none()).unwrap();
    let configs = steep_configs();
    let refs: Vec<_> = configs.iter().take(32).collect();
    let values = |spec: &str| {
        let p = linelight::eval::interp::program(&resolve(spec, &kernels).unwrap()).unwrap();
        p.eval(&refs, Mode::F32).unwrap()
    };
    let (a, b) = (values("test.param_in"), values("test.param_in_const"));
    assert_eq!(a, b);
    assert!(a.iter().any(|v| *v != 0.0));
}

/// An engine's own `#define PI 3.14159265` gives the f64 column its digits (not the prelude's
/// π, which rounds to the same f32), and a folded constant that lost its digits refuses the
/// f64 column only of a method that reaches it.
#[test]
fn lost_digits_refuse_only_the_methods_that_reach_them() {
    let dir = tempfile::tempdir().unwrap();
    let kernel = |id: &str, ret: &str| {
        let text = format!(
            "//! id: {id}\n//! target: line\n//! minv: full\n#define PI 3.14159265\n\n\
             float unused_fn(float x) {{\n    return x * log(3.0);\n}}\n\n\
             float method(Scene scene) {{\n    return {ret};\n}}\n"
        );
        common::write(dir.path(), &format!("{id}.glsl"), &text)
    };
    let files = [
        kernel("test.pi_define", "scene.p1.x / PI"),
        kernel("test.pi_reached", "scene.p1.x / PI + unused_fn(1.0)"),
    ];
    let kernels = kernel_set(&files, &linelight::kernel::Includes::none()).unwrap();
    let configs = steep_configs();
    let refs: Vec<_> = configs.iter().take(16).collect();
    let program = |spec: &str| linelight::eval::interp::program(&resolve(spec, &kernels).unwrap()).unwrap();
    let f64s = program("test.pi_define").eval(&refs, Mode::F64).unwrap();
    for (c, v) in refs.iter().zip(&f64s) {
        #[allow(clippy::approx_constant)] // the kernel's own #define, not π
        let want = c.p1[0] / 3.14159265;
        assert!((v - want).abs() <= 1e-14 * want.abs(), "{v} against {want}");
    }
    let e = program("test.pi_reached").eval(&refs, Mode::F64).unwrap_err();
    assert!(format!("{e:#}").contains(":7: the constant 1.0986123"), "{e:#}");
}
