//! The envelope (docs/envelope.md): exact bounds for one correctly rounded
//! operation, the spec's 4096 ULP for `atan`, a flagged division by zero with its line, every
//! built-in's CPU f32 and lavapipe value inside its envelope on held-out lights, and the
//! acos-based 2023 listing's envelope wider than the 2017 listing's on the dimmest lights.

use crate::common::{self, segment};
use linelight::eval::envelope::interval::{Gap, Iv};
use linelight::eval::interp::{envelope, CpuColumns, EnvelopeStop};
use linelight::input::scene::{Config, Material, Rect};
use linelight::input::target::Target;
use linelight::kernel::methods::{kernel_set, resolve, Method};
use rand::{Rng, SeedableRng};

fn config(p1: [f64; 3], p2: [f64; 3], material: Material) -> Config {
    segment("", p1, p2, material)
}

/// A user kernel whose `method` body is `body` (reading `scene.p1.x` and `scene.p2.x`).
fn user(id: &str, body: &str) -> (Method, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("k.wgsl");
    let text = format!("//! id: {id}\n//! target: line\n\nfn method(scene: Scene) -> f32 {{\n{body}\n}}\n");
    std::fs::write(&path, text).unwrap();
    let kernels = kernel_set(&[path], &linelight::kernel::Includes::none()).unwrap();
    (resolve(id, &kernels).unwrap(), dir)
}

fn bounded(m: &Method, c: &Config) -> Iv {
    envelope(m, c)
        .unwrap()
        .expect("applies")
        .value
        .expect("a finite envelope")
}

/// Either f32 neighbour of an exact value (the value itself when it is an f32).
fn neighbours(exact: f64) -> Iv {
    let r = exact as f32;
    if r as f64 == exact {
        return Iv::point(exact);
    }
    let (lo, hi) = if (r as f64) < exact {
        (r, r.next_up())
    } else {
        (r.next_down(), r)
    };
    Iv::new(lo as f64, hi as f64)
}

#[test]
fn one_add_sub_or_mul_is_exactly_round_down_and_round_up_of_the_exact_result() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(22);
    type Exact = fn(f64, f64) -> f64;
    let ops: [(&str, Exact); 3] = [("+", |a, b| a + b), ("-", |a, b| a - b), ("*", |a, b| a * b)];
    for (i, (op, exact)) in ops.iter().enumerate() {
        let (m, _dir) = user(
            &format!("user.op{i}"),
            &format!("    return scene.p1.x {op} scene.p2.x;"),
        );
        let mut inexact = 0;
        for _ in 0..200 {
            let a = rng.random_range(-3.0..3.0f64) as f32 as f64;
            let b = rng.random_range(-3.0..3.0f64) as f32 as f64;
            let c = config([a, 0.1, 1.0], [b, 0.7, 1.3], Material::Diffuse);
            // f32 arguments: the sum and difference (exponents close) and the product are exact in f64.
            let want = neighbours(exact(a, b));
            inexact += usize::from(!want.is_point());
            assert_eq!(bounded(&m, &c), want, "{a} {op} {b}");
        }
        assert!(inexact > 50, "{op}: the sample must hold inexact results ({inexact})");
    }
}

#[test]
fn a_kernel_whose_only_builtin_is_atan_is_8192_ulp_wide() {
    let (m, _dir) = user("user.atan", "    return atan(scene.p1.x);");
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4096);
    for _ in 0..200 {
        let x = rng.random_range(-8.0..8.0f64) as f32 as f64;
        let c = config([x, 0.1, 1.0], [0.3, 0.7, 1.3], Material::Diffuse);
        let e = bounded(&m, &c);
        let result = x.atan();
        // The spec's ULP: the smallest gap between f32 values around the result.
        let r = result as f32;
        let ulp = (r.next_up() as f64 - r as f64)
            .abs()
            .min((r as f64 - r.next_down() as f64).abs());
        let width = e.hi - e.lo;
        assert!(
            (width - 2.0 * 4096.0 * ulp).abs() <= 2.0 * ulp,
            "atan({x}): width {width:e} against 2·4096 ULP = {:e} (ULP {ulp:e})",
            8192.0 * ulp
        );
        assert!(e.contains(result));
    }
}

#[test]
fn a_division_by_zero_is_flagged_with_its_line() {
    let (m, _dir) = user(
        "user.divzero",
        "    let z = scene.p1.x - scene.p1.x;\n    let q = 1.0 / z;\n    return q;",
    );
    let c = config([0.5, 0.1, 1.0], [0.3, 0.7, 1.3], Material::Diffuse);
    let out = envelope(&m, &c).unwrap().unwrap();
    let Err(EnvelopeStop::Gap { gap, line, forked }) = out.value else {
        panic!("not flagged: {:?}", out.value)
    };
    assert!(matches!(gap, Gap::NonFinite(_)), "{gap:?}");
    assert!(!forked);
    let program = linelight::eval::interp::program(&m).unwrap();
    let l = &program.lines[line.expect("a line")];
    // The kernel file's line 6: the header (2 lines), a blank, `fn method`, `let z`, `let q`.
    assert_eq!((l.line, l.text.trim()), (6, "let q = 1.0 / z;"), "{l:?}");
    // The CPU's IEEE f32 gives inf there: the flag is what a finite-math driver may break.
    assert_eq!(m.eval_f32_cpu(&c), Some(f32::INFINITY));
}

/// Seeded lights no other test samples: diffuse, sparse and full M⁻¹, with a radius and a
/// rectangle so every target applies.
fn held_out(n: usize, seed: u64) -> Vec<Config> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
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
        c.id = format!("h{}", out.len());
        c.radius = Some(0.02);
        let (dx, dy) = (p2[0] - p1[0], p2[1] - p1[1]);
        let len = (dx * dx + dy * dy).sqrt();
        if len < 1e-3 {
            continue;
        }
        c.rect = Some(Rect {
            normal: [dy / len, -dx / len, 0.0],
            width: 0.03,
        });
        if c.validate().is_ok() {
            out.push(c);
        }
    }
    out
}

#[test]
fn every_builtin_cpu_f32_value_lies_inside_its_envelope_on_held_out_lights() {
    let kernels = kernel_set(&[], &linelight::kernel::Includes::none()).unwrap();
    let configs = held_out(90, 2222);
    let (mut inside, mut undefined) = (0, 0);
    for k in &kernels {
        let m = resolve(&k.id, &kernels).unwrap();
        for c in &configs {
            let Some(out) = envelope(&m, c).unwrap() else { continue };
            let Some(v) = m.eval_f32_cpu(c) else { continue };
            match out.value {
                Ok(e) => {
                    assert!(
                        e.contains(v as f64),
                        "{} on {}: cpu f32 {v:e} outside {e:?}",
                        m.label,
                        c.id
                    );
                    inside += 1;
                }
                Err(_) => undefined += 1,
            }
        }
    }
    eprintln!("{inside} CPU f32 values inside their envelopes, {undefined} envelopes not bounded");
    assert!(inside > 20 * configs.len(), "{inside}");
}

#[test]
fn lavapipe_values_lie_inside_the_envelope_on_held_out_lights() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.jsonl");
    let output = dir.path().join("out.jsonl");
    let lines: Vec<String> = held_out(40, 2223)
        .iter()
        .map(|c| serde_json::to_string(c).unwrap())
        .collect();
    std::fs::write(&input, lines.join("\n")).unwrap();
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_linelight"))
        .args(["eval", "--envelope", "--input"])
        .arg(&input)
        .arg("--output")
        .arg(&output)
        .status()
        .unwrap();
    assert!(status.success());
    let (mut inside, mut outside) = (0, Vec::new());
    for line in std::fs::read_to_string(&output).unwrap().lines() {
        let row: serde_json::Value = serde_json::from_str(line).unwrap();
        for (m, e) in row["envelope"].as_object().unwrap() {
            let (Some(lo), Some(hi)) = (e[0].as_f64(), e[1].as_f64()) else {
                assert!(
                    row["envelope_undefined"][m].is_object(),
                    "{m}: unbounded without a reason"
                );
                continue;
            };
            let Some(gpu) = row["methods"][m]["f32"].as_f64() else {
                continue;
            };
            if lo <= gpu && gpu <= hi {
                inside += 1;
            } else {
                outside.push(format!("{m} on {}: {gpu:e} outside [{lo:e}, {hi:e}]", row["id"]));
            }
        }
    }
    // No departure from the written order has been found on lavapipe: none is excused.
    assert!(
        outside.is_empty(),
        "lavapipe outside the envelope:\n{}",
        outside.join("\n")
    );
    assert!(inside > 20 * 40, "{inside}");
}

#[test]
fn on_the_dimmest_lights_the_2023_listings_envelope_is_wider_than_2017s() {
    let kernels = kernel_set(&[], &linelight::kernel::Includes::none()).unwrap();
    let m2017 = resolve("line.ltc2017", &kernels).unwrap();
    let m2023 = resolve("line.ltc2023", &kernels).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1717);
    let sparse = Material::Ltc {
        minv: [[0.7, 0.0, 0.15], [0.0, 0.9, 0.0], [-0.25, 0.0, 1.0]],
    };
    // Lines at distance ~1 above the surface, some far and short: a wide range of brightness.
    let mut rows = Vec::new();
    while rows.len() < 400 {
        let d = 10f64.powf(rng.random_range(0.0..2.0));
        let c = [
            rng.random_range(-1.0..1.0) * d,
            rng.random_range(-1.0..1.0) * d,
            rng.random_range(0.2..1.0) * d,
        ];
        let t = [
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-0.3..0.3),
        ];
        let half = 0.5 * rng.random_range(0.1..2.0);
        let p1 = [0, 1, 2].map(|k| c[k] - half * t[k]);
        let p2 = [0, 1, 2].map(|k| c[k] + half * t[k]);
        let cfg = config(p1, p2, sparse.clone());
        if cfg.validate().is_err() {
            continue;
        }
        let reference = linelight::reference::reference(&cfg, Target::Line).unwrap().value;
        if reference <= 0.0 {
            continue;
        }
        let width = |m: &Method| {
            envelope(m, &cfg)
                .unwrap()
                .unwrap()
                .value
                .map(|e| (e.hi - e.lo) / reference)
                .unwrap_or(f64::INFINITY)
        };
        rows.push((reference, width(&m2017), width(&m2023)));
    }
    rows.sort_by(|a, b| a.0.total_cmp(&b.0));
    let dim = &rows[..rows.len() / 10];
    let median = |k: usize| {
        let mut v: Vec<f64> = dim.iter().map(|r| if k == 0 { r.1 } else { r.2 }).collect();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (w2017, w2023) = (median(0), median(1));
    eprintln!(
        "dimmest {}: median relative envelope width 2017 {w2017:e}, 2023 {w2023:e}",
        dim.len()
    );
    assert!(w2023 > w2017, "2023 {w2023:e} not wider than 2017 {w2017:e}");
}

/// The opt-in gate checks on the envelope (docs/envelope.md, "In the gate"), through a sweep:
/// `gate = true` checks every sampled GPU value against its envelope and the run passes on
/// lavapipe (which stays inside, as the test above finds); `max_past_budget` fails the sweep
/// (exit 1, a failed check in the report and the JUnit file) when more of a method's envelopes
/// reach past the budget than it allows, though every GPU value met the tolerances.
#[test]
fn the_envelope_gate_checks_fail_a_sweep_only_where_they_should() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let case = |envelope: &str, budget: f64| {
        common::case("envelope_gate")
            .title("envelope gate")
            .key("seed", "31")
            .methods(&["line.ltc2017", "line.ltc2023"])
            .key("envelope", &format!("{{ {envelope} }}"))
            .table(&format!(
                "[budget]\nquantile = 0.99\nvalue = {budget}\ntarget = \"line_upper\"\nmin_count = 10"
            ))
            .diffuse(200)
            .to_string()
    };
    let sweep = |name: &str, text: &str| {
        let path = d.join(format!("{name}.toml"));
        std::fs::write(&path, text).unwrap();
        let junit = d.join(format!("{name}.xml"));
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_linelight"))
            .args(["sweep", path.to_str().unwrap(), "--out"])
            .arg(d.join(name))
            .arg("--junit")
            .arg(&junit)
            .output()
            .unwrap();
        let report = std::fs::read_to_string(d.join(name).join("envelope_gate/report.md")).unwrap_or_default();
        let xml = std::fs::read_to_string(&junit).unwrap_or_default();
        (o, report, xml)
    };
    // Every GPU value inside its envelope: the gate check passes (one per method and material).
    let (o, report, xml) = sweep("inside", &case("sample = 24, gate = true", 0.5));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}\n{report}");
    assert_eq!(
        xml.matches("/ GPU values outside the envelope (of ").count(),
        2,
        "one check per method: {xml}"
    );
    assert!(!xml.contains("<failure"), "{xml}");
    assert!(
        report.contains("| GPU outside |") && report.contains("Verdict: PASS"),
        "{report}"
    );
    // The same envelopes against a budget of 1e-7 with none allowed past it: the envelope is
    // wider than that (at least the final rounding's two neighbours, ~6e-8 each way, plus every
    // atan's 4096 ULP), so the sweep fails on the envelope alone, with its numbers.
    let (o, report, xml) = sweep("past", &case("sample = 24, max_past_budget = 0.0", 1e-7));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}\n{report}");
    assert!(xml.contains("share of envelopes past the budget 0.0000001"), "{xml}");
    assert!(xml.contains("<failure") && xml.contains("limit 0e0"), "{xml}");
    assert!(report.contains("Verdict: FAIL"), "{report}");
    // Without the keys, the section is reported and nothing is checked.
    let (o, _, xml) = sweep("plain", &case("sample = 24", 1e-7));
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(!xml.contains("envelope"), "{xml}");
    // A share outside 0..1 is bad input.
    let (o, _, _) = sweep("bad", &case("sample = 24, max_past_budget = 1.5", 0.5));
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("max_past_budget = 1.5"));
}

/// A streamed sweep holds no samples up front: each envelope row must still name the material
/// its configuration was drawn for (once every row was given material 0). Two families of
/// different kinds, so a row's configuration tells which family drew it.
#[test]
fn each_envelope_row_names_the_material_its_configuration_was_drawn_for() {
    use linelight::app::prepare_with;
    use linelight::app::swept::measure;
    use linelight::measure::setup::Holds;
    use linelight::measure::sweep::MeasureOptions;
    let text = common::case("envelope_materials")
        .title("envelope materials")
        .methods(&["line.ltc2017", "line.ltc2023"])
        .key("envelope", "{ sample = 40 }")
        .diffuse(120)
        .material(
            "ltc",
            "ltc_sparse",
            120,
            "alpha = { dist = \"log_uniform\", min = 0.05, max = 1.0 }\n\
             aspect = { dist = \"uniform\", min = 0.8, max = 1.25 }\n\
             peak = { dist = \"uniform\", min = -60.0, max = 60.0 }",
        )
        .to_string();
    let case = linelight::input::case::Case::parse("envelope_materials.toml", &text).unwrap();
    let setup = prepare_with(case, &[], &linelight::kernel::Includes::none(), None, Holds::default()).unwrap();
    assert!(setup.samples.is_empty(), "a streamed sweep draws chunk by chunk");
    let gpu = crate::common::gpu();
    let options = MeasureOptions {
        chunk: 0,
        raw: None,
        shard: None,
    };
    let swept = measure(&setup, gpu, options, false).unwrap();
    assert_eq!(swept.measured.envelope.len(), 2);
    for m in &swept.measured.envelope {
        let mut per = [0usize; 2];
        for r in &m.rows {
            per[r.material] += 1;
            let drawn = match r.config.material {
                Material::Diffuse => 0,
                Material::Ltc { .. } => 1,
                ref other => panic!("{}: a material neither family draws: {other:?}", m.label),
            };
            assert_eq!(r.material, drawn, "{}: row of {:?}", m.label, r.config);
        }
        assert!(per[0] > 0 && per[1] > 0, "{}: rows per material {per:?}", m.label);
    }
}
