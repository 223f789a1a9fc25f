//! `linelight eval` on explicit configurations: its references agree with an independent
//! quadrature (written here, sharing no code with src/reference) to 1e-8 relative.

use crate::common;

type V = [f64; 3];

fn dot(a: V, b: V) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn axpy(a: f64, x: V, y: V) -> V {
    [a * x[0] + y[0], a * x[1] + y[1], a * x[2] + y[2]]
}

/// Gauss–Legendre nodes and weights on [-1, 1] by Newton iteration on P_n.
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            loop {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                    p0 = p1;
                    p1 = p2;
                }
                let dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-15 {
                    return (x, 2.0 / ((1.0 - x * x) * dp * dp));
                }
            }
        })
        .collect()
}

/// The line integral by angle: l = l_foot + d·tan θ turns Eq. 1.6 into ∫ 2 D(ω(θ)) cos θ / d dθ,
/// split where D has a kink (its support plane and, for `upper`, the horizon).
fn independent_line(p1: V, p2: V, minv: [[f64; 3]; 3], upper: bool) -> f64 {
    let e = [p2[0] - p1[0], p2[1] - p1[1], p2[2] - p1[2]];
    let len = dot(e, e).sqrt();
    let t = [e[0] / len, e[1] / len, e[2] / len];
    let l1 = dot(p1, t);
    let po = axpy(-l1, t, p1);
    let d = dot(po, po).sqrt();
    let det = minv[0][0] * (minv[1][1] * minv[2][2] - minv[1][2] * minv[2][1])
        - minv[0][1] * (minv[1][0] * minv[2][2] - minv[1][2] * minv[2][0])
        + minv[0][2] * (minv[1][0] * minv[2][1] - minv[1][1] * minv[2][0]);
    let dist = |w: V| -> f64 {
        let wo = [dot(minv[0], w), dot(minv[1], w), dot(minv[2], w)];
        let lo = dot(wo, wo).sqrt();
        let mut v = (wo[2] / lo).max(0.0) * det.abs() / (std::f64::consts::PI * lo * lo * lo);
        if upper && w[2] <= 0.0 {
            v = 0.0;
        }
        v
    };
    let (th1, th2) = ((l1 / d).atan(), ((l1 + len) / d).atan());
    let mut cuts = vec![th1, th2];
    // Plane n·p = 0 crosses p(θ) = po + d tanθ t where tanθ = -(n·po)/(d n·t).
    let mut planes = vec![minv[2]];
    if upper {
        planes.push([0.0, 0.0, 1.0]);
    }
    for n in planes {
        let th = (-dot(n, po) / (d * dot(n, t))).atan();
        if th > th1 && th < th2 {
            cuts.push(th);
        }
    }
    cuts.sort_by(f64::total_cmp);
    let rule = gauss_legendre(12);
    let panels = 400;
    let mut sum = 0.0;
    for w in cuts.windows(2) {
        let h = (w[1] - w[0]) / panels as f64;
        for k in 0..panels {
            let mid = w[0] + (k as f64 + 0.5) * h;
            for &(x, wt) in &rule {
                let th = mid + 0.5 * h * x;
                let dir = axpy(
                    th.sin(),
                    t,
                    [po[0] / d * th.cos(), po[1] / d * th.cos(), po[2] / d * th.cos()],
                );
                sum += 0.5 * h * wt * 2.0 * dist(dir) * th.cos() / d;
            }
        }
    }
    sum
}

fn configs() -> Vec<serde_json::Value> {
    use serde_json::json;
    let iso = [[0.5, 0.0, 0.1], [0.0, 0.6, 0.0], [-0.2, 0.0, 1.0]];
    let sharp = [[12.0, 0.0, -6.0], [0.0, 10.0, 0.0], [0.2, 0.0, 1.0]];
    let full = [[2.0, 0.7, -0.4], [-0.5, 3.0, 0.3], [0.1, -0.2, 1.0]];
    let mut out = vec![
        json!({"id": "design", "p1": [0.3, -0.2, 1.0], "p2": [0.9, 0.4, 1.6], "radius": 0.01,
        "rect": {"normal": [0.0, 0.0, -1.0], "width": 0.02},
        "material": {"kind": "ltc", "minv": iso}}),
    ];
    let segs: [(V, V); 6] = [
        ([-1.0, 0.5, 1.0], [1.0, 0.5, 1.0]),    // parallel to the surface
        ([0.2, 0.1, -0.5], [0.4, 0.3, 1.5]),    // crosses the horizon
        ([3.0, -2.0, 0.2], [-3.0, 2.5, 0.1]),   // long, grazing
        ([0.05, 0.0, 0.2], [0.05, 0.01, 0.21]), // short, close
        ([-20.0, 1.0, 2.0], [30.0, 1.0, 3.0]),  // very long
        ([0.5, 0.5, -0.1], [0.6, -0.5, 0.05]),  // mostly below
    ];
    for (k, (p1, p2)) in segs.iter().enumerate() {
        out.push(json!({"id": format!("diffuse{k}"), "p1": p1, "p2": p2, "material": {"kind": "diffuse"}}));
        for (name, m) in [("iso", iso), ("sharp", sharp), ("full", full)] {
            out.push(json!({"id": format!("{name}{k}"), "p1": p1, "p2": p2, "material": {"kind": "ltc", "minv": m}}));
        }
    }
    out
}

/// Runs `linelight eval` on `configs` with `methods` and returns its output rows.
fn run_eval(configs: &[serde_json::Value], methods: &str) -> Vec<serde_json::Value> {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.jsonl");
    let output = dir.path().join("out.jsonl");
    std::fs::write(&input, configs.iter().map(|c| c.to_string() + "\n").collect::<String>()).unwrap();
    let o = common::eval(&input, &output, &["--methods", methods]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::read_to_string(&output)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

#[test]
fn eval_references_agree_with_an_independent_quadrature() {
    let cs = configs();
    let rows = run_eval(&cs, "line.ltc2023");
    assert_eq!(rows.len(), cs.len());
    let v = |x: &serde_json::Value| -> V { [0, 1, 2].map(|i| x[i].as_f64().unwrap()) };
    let mut worst = 0.0f64;
    for (c, row) in cs.iter().zip(&rows) {
        assert_eq!(c["id"], row["id"]);
        let minv = match c["material"]["kind"].as_str().unwrap() {
            "diffuse" => [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            _ => [0, 1, 2].map(|r| v(&c["material"]["minv"][r])),
        };
        for (target, upper) in [("line", false), ("line_upper", true)] {
            let expected = independent_line(v(&c["p1"]), v(&c["p2"]), minv, upper);
            let got = row["reference"][target].as_f64().unwrap();
            let err = row["reference_error"][target].as_f64().unwrap();
            let rel = (got - expected).abs() / expected.abs().max(1e-300);
            worst = worst.max(rel);
            assert!(
                rel <= 1e-8 || (got - expected).abs() < 1e-14,
                "{} {target}: eval {got:e} ± {err:e}, independent {expected:e} (rel {rel:e})",
                c["id"]
            );
            assert!(
                err >= 0.0 && err <= 1e-8 * got.abs().max(1e-14),
                "{} {target}: error estimate {err:e}",
                c["id"]
            );
        }
    }
    eprintln!("worst relative disagreement: {worst:e}");
}

/// `eval` writes the surface and `line_isotropic` references the library computes (whose
/// agreement with an independent quadrature is `tests/reference_independent.rs`), with their
/// errors.
#[test]
fn eval_writes_cylinder_caps_tube_and_rectangle_references() {
    use linelight::input::scene::Config;
    use linelight::input::target::Target;
    use linelight::reference::reference;
    let cs: Vec<serde_json::Value> = configs().into_iter().filter(|c| c["id"] != "design").collect();
    let with_surfaces: Vec<serde_json::Value> = cs
        .iter()
        .map(|c| {
            let mut c = c.clone();
            c["radius"] = serde_json::json!(0.02);
            c["rect"] = serde_json::json!({"normal": [0.0, 0.0, 1.0], "width": 0.03});
            c
        })
        .collect();
    let rows = run_eval(&with_surfaces, "caps.point");
    for (c, row) in with_surfaces.iter().zip(&rows) {
        let mut config: Config = serde_json::from_value(c.clone()).unwrap();
        config.orthonormalize_rect();
        for t in [
            Target::LineIsotropic,
            Target::Cylinder,
            Target::Caps,
            Target::Tube,
            Target::Rectangle,
        ] {
            let expected = reference(&config, t).unwrap();
            assert_eq!(
                row["reference"][t.name()].as_f64().unwrap(),
                expected.value,
                "{} {t}",
                c["id"]
            );
            let err = row["reference_error"][t.name()].as_f64().unwrap();
            assert!(
                err <= 1e-7 * expected.value.abs().max(1e-12),
                "{} {t}: error estimate {err:e}",
                c["id"]
            );
        }
    }
}

/// The summed targets are in eval's output when a method is judged against one, and not
/// otherwise (each costs its parts' integrals again). `line_sum` is the material's `line`
/// plus the same segment's `line` under the white Lambertian base, their error estimates
/// added; `line_isotropic_sum` likewise.
#[test]
fn eval_writes_the_summed_references_a_method_needs() {
    use serde_json::json;
    let geometry = |material: serde_json::Value| json!({"id": "s", "p1": [-0.4, 0.3, 0.9], "p2": [1.1, -0.2, 0.6], "material": material});
    let ggx = geometry(json!({"kind": "ggx", "alpha": 0.35, "view": [0.6, 0.0, 0.8]}));
    let diffuse = geometry(json!({"kind": "diffuse"}));
    let sum = &run_eval(std::slice::from_ref(&ggx), "line.mrp_sum,line.mrp_sum~line_sum")[0];
    let lobe = &run_eval(&[ggx], "line.ltc2017")[0];
    let base = &run_eval(&[diffuse], "line.ltc2017")[0];
    assert!(lobe["reference"].get("line_sum").is_none(), "{lobe}");
    for (summed, part) in [("line_sum", "line"), ("line_isotropic_sum", "line_isotropic")] {
        let r = |row: &serde_json::Value, key: &str, t: &str| row[key][t].as_f64().unwrap();
        let expected = r(lobe, "reference", part) + r(base, "reference", part);
        let got = r(sum, "reference", summed);
        assert!(
            (got - expected).abs() <= 1e-12 * expected.abs(),
            "{summed}: {got} against {expected}"
        );
        let err = r(sum, "reference_error", summed);
        let parts = r(lobe, "reference_error", part) + r(base, "reference_error", part);
        assert!(err >= 0.999 * parts, "{summed}: error {err} below its parts' {parts}");
    }
}

/// Eval format 2: `reference_f32_inputs` holds every reference again at the configuration with
/// each input number rounded to f32 as given (`as f32 as f64`, nothing renormalised), with its
/// own error estimate; `line` and `line_upper` there agree with this file's quadrature at those
/// rounded inputs. On segments far along their own line the rounding alone moves the value by
/// percents (input rounding, docs/statistics.md), which the exact reference (also checked) keeps apart.
#[test]
fn eval_writes_the_references_at_f32_rounded_inputs() {
    use serde_json::json;
    let mut cs = configs();
    let unit = |a: V| {
        let n = dot(a, a).sqrt();
        a.map(|x| x / n)
    };
    let cross = |a: V, b: V| -> V {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    // Distance 1 from the shading point, the near end `along` away from the closest point,
    // 0.05 long, above the surface.
    for (k, along) in [30.0, 100.0, 300.0, 1000.0].into_iter().enumerate() {
        let t = unit([1.0, 0.7, 0.3]);
        let foot = unit(cross(cross(t, [0.0, 0.0, 1.0]), t));
        assert!(foot[2] > 0.0);
        let p1 = axpy(along, t, foot);
        let p2 = axpy(along + 0.05, t, foot);
        cs.push(json!({"id": format!("far{k}"), "p1": p1, "p2": p2, "material": {"kind": "diffuse"}}));
    }
    let rows = run_eval(&cs, "line.ltc2017");
    let v = |x: &serde_json::Value| -> V { [0, 1, 2].map(|i| x[i].as_f64().unwrap()) };
    let r32 = |x: f64| x as f32 as f64;
    let mut moved = Vec::new();
    for (c, row) in cs.iter().zip(&rows) {
        assert_eq!(row["version"], 2, "{row}");
        let minv = match c["material"]["kind"].as_str().unwrap() {
            "diffuse" => [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            _ => [0, 1, 2].map(|r| v(&c["material"]["minv"][r])),
        };
        let (p1, p2) = (v(&c["p1"]).map(r32), v(&c["p2"]).map(r32));
        let minv32 = minv.map(|r| r.map(r32));
        for (target, upper) in [("line", false), ("line_upper", true)] {
            let expected = independent_line(p1, p2, minv32, upper);
            let got = row["reference_f32_inputs"][target].as_f64().unwrap();
            let err = row["reference_f32_inputs_error"][target].as_f64().unwrap();
            let rel = (got - expected).abs() / expected.abs().max(1e-300);
            assert!(
                rel <= 1e-8 || (got - expected).abs() < 1e-14,
                "{} {target}: eval at f32 inputs {got:e} ± {err:e}, independent {expected:e} (rel {rel:e})",
                c["id"]
            );
            assert!(
                err >= 0.0 && err <= 1e-8 * got.abs().max(1e-14),
                "{} {target}: {err:e}",
                c["id"]
            );
            let exact = row["reference"][target].as_f64().unwrap();
            let independent = independent_line(v(&c["p1"]), v(&c["p2"]), minv, upper);
            assert!(
                (exact - independent).abs() <= 1e-8 * independent.abs().max(1e-6),
                "{}",
                c["id"]
            );
            if exact != 0.0 {
                moved.push(((got - exact).abs() / exact.abs(), c["id"].as_str().unwrap().to_string()));
            }
        }
        // Every target of the row is there again at the f32 inputs, and only those.
        let keys = |k: &str| row[k].as_object().unwrap().keys().cloned().collect::<Vec<_>>();
        assert_eq!(keys("reference"), keys("reference_f32_inputs"), "{}", c["id"]);
        assert_eq!(
            keys("reference_error"),
            keys("reference_f32_inputs_error"),
            "{}",
            c["id"]
        );
    }
    moved.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (worst, id) = moved.last().unwrap();
    eprintln!("largest input rounding: {worst:e} ({id})");
    assert!(id.starts_with("far") && *worst > 1e-2, "{moved:?}");
    // Near the shading point the inputs' rounding moves the value by about f32's ε, no more.
    let near = moved.iter().find(|(_, id)| id == "design").unwrap().0;
    assert!(near < 1e-5, "design: {near:e}");
}

/// The surface views in eval (format 2): with a radius and a rect, `cylinder_upper`,
/// `caps_upper`, `tube_upper` and `rectangle_upper` are written beside the unclipped ones, at
/// the exact and at the f32-rounded configuration, each the library's reference of that
/// configuration (tests/reference_independent.rs checks those against its own quadrature), and
/// 0 exactly for a tube wholly below the surface.
#[test]
fn eval_writes_the_surface_views_at_both_configurations() {
    use linelight::input::scene::Config;
    use linelight::input::target::Target;
    use linelight::reference::reference;
    use serde_json::json;
    let cs = [
        json!({"id": "straddle", "p1": [0.31, -0.22, -0.4], "p2": [0.93, 0.41, 0.6], "radius": 0.013,
               "rect": {"normal": [0.6, -0.8, 0.0], "width": 0.021},
               "material": {"kind": "ltc", "minv": [[3.1, 0.0, -1.3], [0.0, 2.7, 0.0], [0.7, 0.0, 1.0]]}}),
        json!({"id": "below", "p1": [0.31, -0.22, -0.4], "p2": [0.93, 0.41, -0.3], "radius": 0.013,
               "rect": {"normal": [0.6, -0.8, 0.0], "width": 0.021},
               "material": {"kind": "ltc", "minv": [[3.1, 0.0, -1.3], [0.0, 2.7, 0.0], [0.7, 0.0, 1.0]]}}),
    ];
    let rows = run_eval(&cs, "caps.point");
    for (c, row) in cs.iter().zip(&rows) {
        let mut config: Config = serde_json::from_value(c.clone()).unwrap();
        config.orthonormalize_rect();
        let mut rounded: Config = serde_json::from_value(c.clone()).unwrap();
        rounded.orthonormalize_rect();
        let rounded = rounded.rounded_to_f32();
        for t in [
            Target::CylinderUpper,
            Target::CapsUpper,
            Target::TubeUpper,
            Target::RectangleUpper,
        ] {
            let got = row["reference"][t.name()].as_f64().unwrap();
            assert_eq!(got, reference(&config, t).unwrap().value, "{} {t}", c["id"]);
            let got32 = row["reference_f32_inputs"][t.name()].as_f64().unwrap();
            assert_eq!(got32, reference(&rounded, t).unwrap().value, "{} {t}", c["id"]);
            let own = row["reference"][t.own().name()].as_f64().unwrap();
            if c["id"] == "below" {
                assert_eq!((got, got32), (0.0, 0.0), "{t}");
            } else {
                // Neither cap faces the shading point here (it is beside the tube).
                assert!(got <= own, "{t}: {got} vs {own}");
                assert!(got > 0.0 || t == Target::CapsUpper, "{t}: {got}");
                assert!(got < own || t == Target::CapsUpper, "{t}: no leak cut, {got} vs {own}");
            }
        }
        // The leaking lobe lights the tube below the surface in its own target.
        if c["id"] == "below" {
            assert!(row["reference"]["cylinder"].as_f64().unwrap() > 0.0, "{row}");
        }
    }
}
