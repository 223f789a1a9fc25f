//! The evaluator's constants, its libm, its attribution. (Its agreement with the hand
//! ports it replaced, run just before they were deleted: docs/evaluator-agreement.txt.)

use super::*;
use crate::input::geometry::{v3, DVec3};
use crate::input::scene::Material;
use crate::kernel::methods::{kernel_set, resolve};

fn config(p1: [f64; 3], p2: [f64; 3], material: Material) -> Config {
    Config {
        id: String::new(),
        p1,
        p2,
        radius: None,
        rect: None,
        material,
        texture: None,
    }
}

/// Seeded configurations over the materials the ports handle: diffuse, sparse and full
/// M⁻¹, with a radius and a rectangle (so every target applies).
fn configs(n: usize) -> Vec<Config> {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
    let mut out = Vec::new();
    while out.len() < n {
        let mut p = || {
            [
                rng.random_range(-2.0..2.0),
                rng.random_range(-2.0..2.0),
                rng.random_range(-0.5..2.0),
            ]
        };
        let (p1, p2) = (p(), p());
        let material = match out.len() % 3 {
            0 => Material::Diffuse,
            1 => Material::Ltc {
                minv: [[0.7, 0.0, 0.15], [0.0, 0.9, 0.0], [-0.25, 0.0, 1.0]],
            },
            _ => Material::Ltc {
                minv: [[0.8, 0.1, 0.2], [-0.05, 0.6, 0.1], [-0.2, 0.15, 1.1]],
            },
        };
        let mut c = config(p1, p2, material);
        c.radius = Some(0.02);
        let n0 = (v3(p2) - v3(p1)).cross(DVec3::Z);
        let len = n0.length();
        if len > 1e-3 {
            c.rect = Some(crate::input::scene::Rect {
                normal: (n0 / len).to_array(),
                width: 0.03,
            });
        }
        if c.rect.is_some() && c.validate().is_ok() {
            out.push(c);
        }
    }
    out
}

/// The 2023 listing's `INV_PI = 0.3183098861` is 2.6e-10 off 1/π: the f64 evaluation
/// must show it (its constant read from the written digits, not through f32).
#[test]
#[allow(clippy::approx_constant)] // the listing's own digits are the point
fn f64_keeps_written_digits() {
    let mut kernels = kernel_set(&[], &crate::kernel::Includes::none()).unwrap();
    let base = kernels.iter().find(|k| k.id == "line.ltc2023").unwrap().clone();
    let text = base
        .text
        .replace("//! id: line.ltc2023\n", "//! id: line.ltc2023_exact_pi\n")
        .replace("const INV_PI: f32 = 0.3183098861;", "const INV_PI: f32 = 1.0 / PI;");
    assert_ne!(text, base.text);
    kernels.push(crate::kernel::KernelFile::parse("exact_pi.wgsl", &text).unwrap());
    let listing = program(&resolve("line.ltc2023", &kernels).unwrap()).unwrap();
    let exact = program(&resolve("line.ltc2023_exact_pi", &kernels).unwrap()).unwrap();
    let cs = configs(30);
    let refs: Vec<&Config> = cs.iter().collect();
    let (a, b) = (
        listing.eval(&refs, Mode::F64).unwrap(),
        exact.eval(&refs, Mode::F64).unwrap(),
    );
    let expected = 0.3183098861 * std::f64::consts::PI;
    let mut seen = 0;
    for (x, y) in a.iter().zip(&b) {
        if *y != 0.0 {
            seen += 1;
            assert!((x / y - expected).abs() < 1e-14, "{x} / {y} = {}", x / y);
        }
    }
    assert!(seen > 10);
    assert!(
        (1.0 - expected).abs() > 2.5e-10,
        "the offset itself: {:e}",
        1.0 - expected
    );
    // In f32 the two constants are the same number.
    let (a, b) = (
        listing.eval(&refs, Mode::F32).unwrap(),
        exact.eval(&refs, Mode::F32).unwrap(),
    );
    assert_eq!(a, b);
}

/// The `libm` crate's f32 transcendentals against its f64 ones (exact to far below an
/// f32 ulp), in f32 ulps at the result, over the ranges the kernels use. Printed, and
/// bounded (musl documents < 1 ulp for these; atan2f measures up to 2).
#[test]
fn libm_f32_accuracy() {
    fn ulps(got: f32, want: f64) -> f64 {
        let w = (want as f32).abs().max(f32::MIN_POSITIVE);
        let ulp = f64::from(f32::from_bits(w.to_bits() + 1) - w);
        (got as f64 - want).abs() / ulp
    }
    type F = (&'static str, fn(f32) -> f32, fn(f64) -> f64, f32, f32);
    let funcs: [F; 8] = [
        ("acosf", libm::acosf, libm::acos, -1.0, 1.0),
        ("asinf", libm::asinf, libm::asin, -1.0, 1.0),
        ("atanf", libm::atanf, libm::atan, -100.0, 100.0),
        ("sinf", libm::sinf, libm::sin, -7.0, 7.0),
        ("cosf", libm::cosf, libm::cos, -7.0, 7.0),
        ("tanf", libm::tanf, libm::tan, -1.5, 1.5),
        ("expf", libm::expf, libm::exp, -20.0, 20.0),
        ("logf", libm::logf, libm::log, 1e-6, 1e6),
    ];
    let n = 200_000;
    for (name, f32f, f64f, lo, hi) in funcs {
        let worst = (0..=n)
            .map(|i| lo + (hi - lo) * (i as f32 / n as f32))
            .map(|x| ulps(f32f(x), f64f(x as f64)))
            .fold(0.0, f64::max);
        eprintln!("libm {name}: max error {worst:.3} ulp over [{lo}, {hi}], {n} points");
        assert!(worst < 1.0, "{name}: {worst} ulp");
    }
    let mut worst = 0.0f64;
    for i in 0..=n {
        let y = -3.0 + 6.0 * (i as f32 / n as f32);
        for x in [-2.0f32, -0.3, 0.01, 1.0, 5.0] {
            worst = worst.max(ulps(libm::atan2f(y, x), libm::atan2(y as f64, x as f64)));
        }
    }
    eprintln!("libm atan2f: max error {worst:.3} ulp");
    assert!(worst < 2.5, "atan2f: {worst} ulp");
}

/// Every pair of f32 values the attribution can meet, special ones included: the vectorised
/// [`exec::ulp_distance`] and [`exec::bits_of`] give [`ulp_bits`]'s bits.
#[test]
fn coded_ulp_distance_gives_ulp_bits() {
    use rand::{Rng, SeedableRng};
    let mut values = vec![
        0.0f32,
        -0.0,
        f32::MIN_POSITIVE,
        -f32::MIN_POSITIVE,
        f32::from_bits(1),
        -f32::from_bits(1),
        1.0,
        -1.0,
        f32::MAX,
        f32::MIN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        -f32::NAN,
        f32::from_bits(0x7fff_ffff),
        f32::from_bits(0xff80_0001),
    ];
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(23);
    for _ in 0..300 {
        let x: f32 = f32::from_bits(rng.random());
        values.push(x);
        // Neighbours at small distances (the table) and at its edge.
        for k in [1u32, 2, 7, 254, 255, 256, 257, 100_000] {
            values.push(f32::from_bits(x.to_bits().wrapping_add(k)));
        }
    }
    let small: std::sync::LazyLock<[f64; 256]> =
        std::sync::LazyLock::new(|| std::array::from_fn(|k| (k as f64 + 1.0).log2()));
    let mut pairs = 0;
    for &a in &values {
        for &b in values.iter().step_by(7) {
            let want = ulp_bits(a, b);
            let got = exec::bits_of(exec::ulp_distance(a, b), &small);
            assert_eq!(
                got.to_bits(),
                want.to_bits(),
                "{a:e} ({:#x}) vs {b:e} ({:#x})",
                a.to_bits(),
                b.to_bits()
            );
            pairs += 1;
        }
    }
    assert!(pairs > 100_000, "{pairs}");
}

/// Every built-in kernel and composite (as `tests/compiled.rs` lists them) over every case's
/// seeded sample, cut down, and inputs no sampler draws (NaN, infinities, degenerate
/// segments): the attribution's vectorised recording gives the bits of the straightforward
/// one, which records each lane of each operation through [`ulp_bits`], and the same f32
/// values. Compared bit for bit, configuration by configuration, line by line.
#[test]
fn the_vectorised_attribution_gives_the_straightforward_ones_bits() {
    use crate::kernel::builtin_kernels;
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("cases");
    let mut paths: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    paths.sort();
    let mut sample = Vec::new();
    for path in paths {
        let case = crate::input::case::Case::load(&path).unwrap();
        let setup = crate::app::prepare(case, &[], &crate::kernel::Includes::none(), Some(12)).unwrap();
        sample.extend(setup.samples.into_iter().map(|s| s.config));
    }
    // Odd inputs in each material kind of the sample.
    let odd_coords = [
        [0.0, 0.0, 0.0],
        [1e-30, -1e-30, 1e-20],
        [3e19, -2e19, 1e19],
        [f64::INFINITY, 0.0, 1.0],
        [f64::NAN, 0.5, 1.0],
        [0.3, -0.2, -1e-7],
    ];
    let mut kinds: Vec<Config> = Vec::new();
    for c in &sample {
        if !kinds
            .iter()
            .any(|k| std::mem::discriminant(&k.material) == std::mem::discriminant(&c.material))
        {
            kinds.push(c.clone());
        }
    }
    assert_eq!(kinds.len(), 3, "diffuse, ltc and ggx in the sample");
    for base in &kinds {
        for a in odd_coords {
            for b in [[0.5, 0.2, 1.0], [0.0, 0.0, 0.0], [f64::NAN, 0.0, 1.0]] {
                let mut c = base.clone();
                c.p1 = a;
                c.p2 = b;
                sample.push(c);
            }
        }
    }
    let kernels = builtin_kernels();
    let mut methods = Vec::new();
    for k in &kernels {
        methods.push(resolve(&k.id, &kernels).unwrap());
        if k.uses_line {
            for inner in kernels.iter().filter(|i| !i.uses_line) {
                if let Ok(m) = resolve(&format!("{}[{}]", k.id, inner.id), &kernels) {
                    methods.push(m);
                }
            }
        }
    }
    assert!(methods.len() > 40, "{} methods", methods.len());
    let (mut lines, mut nan_lines) = (0usize, 0usize);
    for m in &methods {
        let configs: Vec<&Config> = sample.iter().filter(|c| m.applies(c)).collect();
        let p = program(m).unwrap();
        let slow = p.attribute_with(&configs, true, false).unwrap();
        // The baseline build of the lane loops, and their AVX2 build where the CPU has it.
        for wide in [false, true] {
            let fast = p.attribute_with(&configs, false, wide).unwrap();
            assert_eq!(fast.f32.len(), slow.f32.len());
            for (i, (x, y)) in fast.f32.iter().zip(&slow.f32).enumerate() {
                assert!(
                    x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()),
                    "{} f32 on {:?}",
                    m.label,
                    configs[i]
                );
            }
            for (i, (f, s)) in fast.per_config.iter().zip(&slow.per_config).enumerate() {
                let key = |v: &Vec<LineBits>| {
                    v.iter()
                        .map(|b| (b.line, b.mean.to_bits(), b.max.to_bits()))
                        .collect::<Vec<_>>()
                };
                assert_eq!(key(f), key(s), "{} on {:?} (wide: {wide})", m.label, configs[i]);
                lines += f.len();
                nan_lines += f.iter().filter(|b| b.max == 32.0).count();
            }
        }
    }
    eprintln!(
        "{} methods, {} configurations, {lines} line records compared bit for bit ({nan_lines} with a NaN operation)",
        methods.len(),
        sample.len()
    );
    assert!(lines > 10_000 && nan_lines > 0, "{lines} {nan_lines}");
}
