//! Composite methods (`//! uses: line`): the `method[inner]` spec, composition with the
//! inner line method on lavapipe, and errors attributed to the file that has them.

use crate::common;

use linelight::eval::interp::CpuColumns;
use linelight::input::scene::{Config, GpuScene, Material, Rect};
use linelight::kernel::methods::{resolve, Method};
use linelight::kernel::{builtin_kernels, KernelFile, PRELUDE_PATH};
use linelight::kernel::{compose, compose_with, KernelError};
use linelight::measure::gpu::Gpu;
use naga::valid::Capabilities;

/// A user composite: `SCALE` times the inner line integral. Its override shares the name
/// `SAMPLES` with line.numeric's, which composition must keep apart.
const TWICE: &str = "\
//! id: test.twice
//! target: line
//! uses: line
//! params: SAMPLES=2

override SAMPLES: u32 = 2u;

fn method(scene: Scene) -> f32 {
    return f32(SAMPLES) * I_line(scene.p1, scene.p2);
}
";

const CYLINDER: &str = "\
//! id: test.cyl
//! target: cylinder
fn method(scene: Scene) -> f32 { return scene.radius; }
";

fn parse(path: &str, text: &str) -> KernelFile {
    KernelFile::parse(path, text).unwrap_or_else(|e| panic!("{e}"))
}

fn kernels() -> Vec<KernelFile> {
    let mut ks = builtin_kernels();
    ks.push(parse("user/twice.wgsl", TWICE));
    ks.push(parse("user/cyl.wgsl", CYLINDER));
    ks
}

fn gpu() -> &'static Gpu {
    common::gpu()
}

fn configs() -> Vec<Config> {
    let materials = [
        Material::Diffuse,
        Material::Ltc {
            minv: [[0.5, 0.0, 0.1], [0.0, 0.6, 0.0], [-0.2, 0.0, 1.0]],
        },
        Material::Ltc {
            minv: [[2.0, 0.7, -0.4], [-0.5, 3.0, 0.3], [0.1, -0.2, 1.0]],
        },
    ];
    let segments = [
        ([0.3, -0.2, 1.0], [0.9, 0.4, 1.6]),
        ([-1.0, 0.5, 1.0], [1.0, 0.5, 1.0]),
        ([0.2, 0.1, -0.5], [0.4, 0.3, 1.5]),
    ];
    let mut out = Vec::new();
    for (i, m) in materials.iter().enumerate() {
        for (j, (p1, p2)) in segments.iter().enumerate() {
            // The rectangle's normal ⟂ the segment and the surface normal.
            let n: [f64; 3] = [p2[1] - p1[1], p1[0] - p2[0], 0.0];
            let len = n[0].hypot(n[1]);
            out.push(Config {
                id: format!("m{i}s{j}"),
                p1: *p1,
                p2: *p2,
                radius: Some(0.05),
                rect: Some(Rect {
                    normal: n.map(|x| x / len),
                    width: 0.1,
                }),
                material: m.clone(),
                texture: None,
            });
        }
    }
    out
}

fn run(m: &Method) -> Vec<f32> {
    let scenes: Vec<GpuScene> = configs().iter().map(GpuScene::from).collect();
    let pipeline = gpu().pipeline(m).unwrap_or_else(|e| panic!("{}: {e}", m.describe()));
    gpu().run(&pipeline, &scenes, 4, &mut |_| {}).unwrap().values
}

fn resolve_err(spec: &str) -> String {
    format!("{:#}", resolve(spec, &kernels()).err().unwrap())
}

#[test]
fn spec_names_the_inner_method_and_its_params() {
    let ks = kernels();
    let m = resolve("test.twice", &ks).unwrap();
    assert_eq!(m.label, "test.twice");
    assert_eq!(m.describe(), "test.twice[line.ltc2023_full]");
    assert_eq!(m.params, vec![2.0]);
    assert_eq!(m.inner.as_ref().unwrap().params, Vec::<f64>::new());

    let m = resolve("test.twice@3[line.numeric@32]", &ks).unwrap();
    assert_eq!(
        (m.label.as_str(), m.params.as_slice()),
        ("test.twice@3[line.numeric@32]", &[3.0][..])
    );
    let inner = m.inner.as_ref().unwrap();
    assert_eq!((inner.id(), inner.params.as_slice()), ("line.numeric", &[32.0][..]));
    assert_eq!(m.describe(), "test.twice@3[line.numeric@32]");
    assert_eq!(
        resolve("test.twice[line.numeric]", &ks).unwrap().inner.unwrap().params,
        vec![64.0]
    );

    let plain = resolve("line.numeric@16", &ks).unwrap();
    assert!(plain.inner.is_none());
    assert_eq!(plain.describe(), "line.numeric@16");
}

#[test]
fn spec_errors_are_clear() {
    let cases = [
        ("line.ltc2017[line.numeric]", "line.ltc2017 takes no `[line method]`"),
        (
            "test.twice[test.cyl]",
            "must be a `target: line` kernel; test.cyl targets cylinder",
        ),
        (
            "test.twice[test.twice]",
            "the inner method test.twice itself uses a line method",
        ),
        (
            "test.twice[line.nope]",
            "`test.twice[line.nope]`: unknown method `line.nope`",
        ),
        ("test.twice[line.numeric@0]", "parameter `0` is not a positive integer"),
        (
            "test.twice[line.numeric@8x8]",
            "line.numeric takes 1 parameter(s) (SAMPLES), got 2",
        ),
        (
            "test.twice[line.numeric[line.ltc2017]]",
            "line.numeric takes no `[line method]`",
        ),
        ("test.twice[line.numeric", "brackets at the end"),
        ("test.twice[line.numeric]@3", "brackets at the end"),
        ("test.twice[]", "empty `[]`"),
        ("test.twice]", "`]` without `[`"),
    ];
    for (spec, expected) in cases {
        let e = resolve_err(spec);
        assert!(e.contains(expected), "{spec}: {e}");
    }
}

#[test]
fn a_composite_supports_what_it_and_its_inner_support() {
    let ks = kernels();
    let full = configs().into_iter().find(|c| !c.material.is_sparse()).unwrap();
    let sparse = configs().into_iter().find(|c| c.material.is_sparse()).unwrap();
    let published = resolve("test.twice[line.ltc2023]", &ks).unwrap();
    assert!(published.supports(&sparse) && !published.supports(&full));
    let default = resolve("test.twice", &ks).unwrap();
    assert!(default.supports(&sparse) && default.supports(&full));
}

#[test]
fn composite_is_its_factor_times_the_inner_on_the_gpu() {
    let ks = kernels();
    for inner in ["line.ltc2017", "line.numeric@32", "line.numeric@4"] {
        let alone = run(&resolve(inner, &ks).unwrap());
        let twice = run(&resolve(&format!("test.twice[{inner}]"), &ks).unwrap());
        let thrice = run(&resolve(&format!("test.twice@3[{inner}]"), &ks).unwrap());
        assert!(alone.iter().all(|v| v.is_finite() && *v > 0.0), "{inner}: {alone:?}");
        for ((a, b), c) in alone.iter().zip(&twice).zip(&thrice) {
            // Scaling by 2 is exact however the driver reassociates the inlined product;
            // by 3 it may round once more.
            assert_eq!(*b, 2.0 * a, "{inner}");
            assert!((c - 3.0 * a).abs() <= 3.0 * a * f32::EPSILON, "{inner}: {c} vs 3 × {a}");
        }
    }
    // The inner's own SAMPLES reached it, apart from the composite's.
    let coarse = run(&resolve("test.twice[line.numeric@4]", &ks).unwrap());
    let fine = run(&resolve("test.twice[line.numeric@32]", &ks).unwrap());
    assert_ne!(coarse, fine);
}

/// Vulkan lets atan/acos be off by 4096 ULP; the GPU and the CPU evaluator's f32
/// column differ by up to that.
const VULKAN_TRANSCENDENTAL: f64 = 5e-4;

/// Every built-in composite with two inner methods: the GPU agrees with the CPU evaluator's
/// f32 column of the composite over its inner method (`Method::eval_f32_cpu`), and the f64
/// column exists.
#[test]
fn builtin_composites_on_the_gpu_match_their_cpu_f32_column() {
    let ks = builtin_kernels();
    // Composites over `line` methods (those over `line_isotropic` are in tests/engines.rs).
    for k in ks
        .iter()
        .filter(|k| k.uses_line && k.uses_target == linelight::input::target::Target::Line)
    {
        for inner in ["line.ltc2017", "line.numeric@32"] {
            let m = resolve(&format!("{}[{inner}]", k.id), &ks).unwrap();
            // Only the materials it claims (`minv: ggx` look-ups, kernels/ltc/, claim `ggx` only,
            // which this set lacks; tests/ltc_lookup.rs checks them on the GPU and CPU).
            for (c, v) in configs().iter().zip(run(&m)).filter(|(c, _)| m.supports(c)) {
                let cpu = m
                    .eval_f32_cpu(c)
                    .unwrap_or_else(|| panic!("{}: no CPU f32 column", m.label));
                let scale = f64::from(cpu.abs()).max(1e-6);
                assert!(
                    (f64::from(v) - f64::from(cpu)).abs() <= VULKAN_TRANSCENDENTAL * scale,
                    "{} on {}: GPU {v:e} vs cpu_f32 {cpu:e}",
                    m.label,
                    c.id
                );
                // The f64 column is the same formula: within f32 rounding of the cpu_f32 column.
                let f64_value = m.eval_f64(c).unwrap_or(f64::NAN);
                assert!(
                    (f64_value - f64::from(cpu)).abs() <= VULKAN_TRANSCENDENTAL * scale,
                    "{} on {}: f64 {f64_value:e} vs cpu_f32 {cpu:e}",
                    m.label,
                    c.id
                );
            }
        }
    }
}

/// `I_line` evaluates the inner on the end points it is given, not the scene's.
#[test]
fn i_line_takes_its_own_end_points() {
    let mut ks = kernels();
    ks.push(composite(
        "fn method(scene: Scene) -> f32 { return I_line(2.0 * scene.p2, 2.0 * scene.p1); }\n",
    ));
    let composite = run(&resolve("test.comp[line.ltc2017]", &ks).unwrap());
    let scenes: Vec<GpuScene> = configs()
        .iter()
        .map(|c| {
            let mut s = GpuScene::from(c);
            (s.p1, s.p2) = (s.p2.map(|x| 2.0 * x), s.p1.map(|x| 2.0 * x));
            s
        })
        .collect();
    let pipeline = gpu().pipeline(&resolve("line.ltc2017", &ks).unwrap()).unwrap();
    let alone = gpu().run(&pipeline, &scenes, 0, &mut |_| {}).unwrap().values;
    for (c, a) in composite.iter().zip(&alone) {
        assert!((c - a).abs() <= 4.0 * a.abs() * f32::EPSILON, "{c} vs {a}");
    }
}

#[test]
fn default_inner_composes_for_check() {
    let twice = parse("user/twice.wgsl", TWICE);
    let composed = compose(&twice).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(composed.inner.unwrap().id, "line.ltc2023_full");
    let out = run(&resolve("test.twice", &kernels()).unwrap());
    let alone = run(&resolve("line.ltc2023_full", &kernels()).unwrap());
    assert_eq!(out, alone.iter().map(|v| 2.0 * v).collect::<Vec<_>>());

    let o = std::process::Command::new(env!("CARGO_BIN_EXE_linelight"))
        .args(["check", "tests/data/does-not-exist.wgsl"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let dir = std::env::temp_dir().join(format!("linelight-composite-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("twice.wgsl");
    std::fs::write(&path, TWICE).unwrap();
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_linelight"))
        .args(["check", path.to_str().unwrap()])
        .output()
        .unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("ok (test.twice → line)"));
}

/// A user line method with a helper named like the glue's `I_line` and an override on
/// the line of a clash: both renamed or mapped back to where the user wrote them.
const USER_LINE: &str = "\
//! id: line.user
//! target: line
//! params: SAMPLES=3

fn I_line(p1: vec3<f32>, p2: vec3<f32>) -> f32 { return length(p2 - p1); }
override SAMPLES: u32 = 3u; fn helper() -> f32 { return f32(SAMPLES); }

fn method(scene: Scene) -> f32 {
    // method: f32(SAMPLES) * I_line
    return helper() * I_line(scene.p1, scene.p2);
}
";

fn composite(body: &str) -> KernelFile {
    parse(
        "user/comp.wgsl",
        &format!("//! id: test.comp\n//! target: line\n//! uses: line\n{body}"),
    )
}

fn compose_err(kernel: &KernelFile, inner: &KernelFile) -> KernelError {
    compose_with(kernel, Some(inner), Capabilities::default()).unwrap_err()
}

#[test]
fn inner_names_are_kept_apart_from_the_composite() {
    let mut ks = kernels();
    ks.push(parse("user/line.wgsl", USER_LINE));
    let alone = run(&resolve("line.user@5", &ks).unwrap());
    let twice = run(&resolve("test.twice@2[line.user@5]", &ks).unwrap());
    assert_eq!(alone[0], 5.0 * (0.36f32 + 0.36 + 0.36).sqrt());
    assert_eq!(twice, alone.iter().map(|v| 2.0 * v).collect::<Vec<_>>());
}

#[test]
fn helper_clash_names_both_files() {
    let user_line = parse("user/line.wgsl", USER_LINE);
    let k = composite(
        "\nfn helper() -> f32 { return 2.0; }\n\
         fn method(scene: Scene) -> f32 { return helper() * I_line(scene.p1, scene.p2); }\n",
    );
    let e = compose_err(&k, &user_line);
    let text = e.to_string();
    // `helper` at column 32 of the user's line 6 (composed after `ll_inner_SAMPLES`).
    assert!(
        text.contains("user/comp.wgsl:5:4") && text.contains("user/line.wgsl:6:32"),
        "{text}"
    );

    let ltc = builtin_kernels().into_iter().find(|k| k.id == "line.ltc2017").unwrap();
    let k = composite("fn Fpo(d: f32, l: f32) -> f32 { return d; }\nfn method(scene: Scene) -> f32 { return 0.0; }\n");
    let text = compose_err(&k, &ltc).to_string();
    assert!(
        text.contains("user/comp.wgsl:4:4") && text.contains("kernels/line_ltc2017.wgsl:10:4"),
        "{text}"
    );
}

#[test]
fn errors_in_the_inner_or_the_composite_name_their_own_file_and_line() {
    let bad_line = parse(
        "user/bad_line.wgsl",
        "//! id: line.bad\n//! target: line\n\nfn method(scene: Scene) -> f32 {\n    return nope;\n}\n",
    );
    let twice = parse("user/twice.wgsl", TWICE);
    let e = compose_err(&twice, &bad_line);
    assert_eq!(
        (e.path.as_str(), e.location),
        ("user/bad_line.wgsl", Some((5, 12))),
        "{e}"
    );
    assert!(e.to_string().contains("return nope;"), "{e}");

    let numeric = builtin_kernels().into_iter().find(|k| k.id == "line.numeric").unwrap();
    let k = composite("\n\nfn method(scene: Scene) -> f32 {\n    return I_line(scene.p1, scene.p2) + nope;\n}\n");
    let e = compose_err(&k, &numeric);
    assert_eq!((e.path.as_str(), e.location), ("user/comp.wgsl", Some((7, 41))), "{e}");

    // A validation (not parse) error: the wrong return type.
    let k =
        composite("fn method(scene: Scene) -> f32 {\n    return scene.flags + u32(I_line(scene.p1, scene.p2));\n}\n");
    let e = compose_err(&k, &numeric);
    assert_eq!(
        (e.path.as_str(), e.location.map(|l| l.0)),
        ("user/comp.wgsl", Some(5)),
        "{e}"
    );

    // A misspelled prelude name in the composite stays the composite's error.
    let k = composite("fn method(scene: Scene) -> f32 {\n    return PI2 * I_line(scene.p1, scene.p2);\n}\n");
    let e = compose_err(&k, &numeric);
    assert_eq!(e.path, "user/comp.wgsl", "{e}");
    assert!(!e.to_string().contains(PRELUDE_PATH), "{e}");
}

#[test]
fn composite_contract_errors() {
    let numeric = builtin_kernels().into_iter().find(|k| k.id == "line.numeric").unwrap();
    let k = composite(
        "fn I_line(a: vec3<f32>, b: vec3<f32>) -> f32 { return 0.0; }\n\
         fn method(scene: Scene) -> f32 { return I_line(scene.p1, scene.p2); }\n",
    );
    let e = compose_err(&k, &numeric);
    assert_eq!((e.path.as_str(), e.location), ("user/comp.wgsl", Some((4, 4))), "{e}");
    assert!(e.to_string().contains("must not define `I_line`"), "{e}");

    let k = composite("fn method(scene: Scene) -> f32 { return 1.0; }\nfn ll_line_method() {}\n");
    let e = compose_err(&k, &numeric);
    assert_eq!(
        (e.path.as_str(), e.location.map(|l| l.0)),
        ("user/comp.wgsl", Some(5)),
        "{e}"
    );

    // Without `uses: line` there is no `I_line`, and the message says where it comes from.
    let plain = parse(
        "user/plain.wgsl",
        "//! id: line.p\n//! target: line\nfn method(scene: Scene) -> f32 { return I_line(scene.p1, scene.p2); }\n",
    );
    let e = compose(&plain).unwrap_err().to_string();
    assert!(e.contains("user/plain.wgsl:3:") && e.contains("//! uses: line"), "{e}");
    let e = compose_err(&plain, &numeric).to_string();
    assert!(e.contains("takes no line method"), "{e}");

    // A composite cannot be a line method.
    let twice = parse("user/twice.wgsl", TWICE);
    let e = compose_err(&twice, &twice).to_string();
    assert!(e.contains("uses a line method itself"), "{e}");
}

#[test]
fn directives_of_both_kernels_are_hoisted() {
    let half_line = parse(
        "user/half.wgsl",
        "//! id: line.half\n//! target: line\nenable f16;\n\
         fn method(scene: Scene) -> f32 { return f32(f16(2.0) * 2.0h) * (scene.p2.x - scene.p1.x); }\n",
    );
    let k =
        composite("enable f16;\nfn method(scene: Scene) -> f32 { return f32(1.5h) * I_line(scene.p1, scene.p2); }\n");
    let method = Method {
        label: "test.comp[line.half]".into(),
        kernel: k,
        params: Vec::new(),
        inner: Some(Box::new(Method {
            label: "line.half".into(),
            kernel: half_line,
            params: Vec::new(),
            inner: None,
            judged: None,
        })),
        judged: None,
    };
    let out = run(&method);
    let expected: Vec<f32> = configs()
        .iter()
        .map(|c| 6.0 * (c.p2[0] as f32 - c.p1[0] as f32))
        .collect();
    assert_eq!(out, expected);
}
