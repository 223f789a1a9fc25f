//! Fresnel: the `ggx` material's `f0` (Schlick's F0), everywhere a material goes.
//!
//! - The held-out must-show: `line` references on `ggx` with `f0` against a quadrature written
//!   here alone (not src/reference, not tests/ggx_reference.rs): the segment in the angle ψ it
//!   subtends, adaptive Gauss–Legendre with bisection to a local error bound, D and F term by
//!   term as docs/conventions.md writes them (normalised half vector, `powi(5)`), to 1e-7.
//! - f0 absent and f0 = 1 are the same, bit for bit (references, fed magnitude, scenes, every
//!   method's CPU columns).
//! - The fed magnitude is `f0·magnitude + (1 − f0)·fresnel` of the feed's channels, and close
//!   to the exact ∫D·F.
//! - Bad f0 is refused on every input, naming the field; the published table, which has no
//!   Fresnel channel, is refused with f0 < 1.

use crate::common;
use common::segment;

use common::independent::*;
use linelight::eval::interp::{CpuColumns, Mode};
use linelight::input::scene::{Config, GpuScene, Material, Roughness, Vec3};
use linelight::input::target::Target;
use linelight::kernel::builtin_kernels;
use linelight::kernel::methods::resolve;
use linelight::reference::reference;
use rayon::prelude::*;

/// Schlick's F at h = normalize(v + ω), as docs/conventions.md writes it.
fn schlick(f0: f64, v: Vec3, w: Vec3) -> f64 {
    let h = unit(add(v, w));
    f0 + (1.0 - f0) * (1.0 - dot(v, h)).powi(5)
}

/// ∫ f over [a, b] by 16-point Gauss–Legendre, bisected until the two halves agree with the
/// whole within `tol` (absolute), at most `depth` times.
fn adaptive(f: &dyn Fn(f64) -> f64, a: f64, b: f64, whole: f64, tol: f64, depth: u32) -> f64 {
    let m = 0.5 * (a + b);
    let (l, r) = (gauss(f, a, m), gauss(f, m, b));
    if depth == 0 || (l + r - whole).abs() <= tol {
        return l + r;
    }
    adaptive(f, a, m, l, 0.5 * tol, depth - 1) + adaptive(f, m, b, r, 0.5 * tol, depth - 1)
}

fn gauss(f: &dyn Fn(f64) -> f64, a: f64, b: f64) -> f64 {
    let (c, h) = (0.5 * (a + b), 0.5 * (b - a));
    gauss16().iter().map(|&(x, w)| w * f(c + h * x)).sum::<f64>() * h
}

/// `line` with D·F: with the foot point q of the origin on the line (|q| = d) and ω(ψ) =
/// cos ψ·q/d + sin ψ·t, dl/‖p‖² = dψ/d and ‖ω × t‖ = cos ψ, so the integral is
/// ∫ D(ω)·F·2 cos ψ / d dψ over the angles of the end points. Cut at the horizon, 256 equal
/// panels first (lobes down to α = 0.05 are several panels wide), then adaptive.
fn line_with_fresnel(c: &Config, alpha: [f64; 2], v: Vec3, f0: f64) -> f64 {
    let t = unit(sub(c.p2, c.p1));
    let s1 = dot(c.p1, t);
    let q = sub(c.p1, mul(t, s1));
    let d = norm(q);
    let n = mul(q, 1.0 / d);
    let (a, b) = ((s1 / d).atan(), ((s1 + norm(sub(c.p2, c.p1))) / d).atan());
    let f = |psi: f64| {
        let w = add(mul(n, psi.cos()), mul(t, psi.sin()));
        ggx_d(alpha, v, w) * schlick(f0, v, w) * 2.0 * psi.cos() / d
    };
    let mut cuts = vec![a, b];
    if t[2] != 0.0 {
        // ω.z = 0: cos ψ·n.z + sin ψ·t.z = 0.
        let h = (-n[2] / t[2]).atan();
        if h > a && h < b {
            cuts.push(h);
        }
    }
    cuts.sort_by(f64::total_cmp);
    let panels = 256;
    let coarse: f64 = cuts
        .windows(2)
        .flat_map(|w| (0..panels).map(move |i| (w[0], w[1], i)))
        .map(|(lo, hi, i)| {
            let h = (hi - lo) / panels as f64;
            gauss(&f, lo + i as f64 * h, lo + (i + 1) as f64 * h).abs()
        })
        .sum();
    let tol = 1e-12 * coarse.max(1e-300);
    cuts.windows(2)
        .map(|w| {
            let h = (w[1] - w[0]) / panels as f64;
            (0..panels)
                .map(|i| {
                    let (lo, hi) = (w[0] + i as f64 * h, w[0] + (i + 1) as f64 * h);
                    adaptive(&f, lo, hi, gauss(&f, lo, hi), tol / panels as f64, 30)
                })
                .sum::<f64>()
        })
        .sum()
}

fn view(theta_deg: f64, phi_deg: f64) -> Vec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()]
}

/// Held-out configurations: roughness × view × F0, each with a segment across the mirror
/// direction (the highlight), one beside it, and one crossing the horizon.
fn cases() -> Vec<(Config, [f64; 2], Vec3, f64)> {
    let mut out = Vec::new();
    let alphas = [
        Roughness::Iso(0.05),
        Roughness::Iso(0.25),
        Roughness::Aniso([0.15, 0.6]),
        Roughness::Iso(0.8),
    ];
    let views = [view(5.0, 0.0), view(45.0, 30.0), view(78.0, 200.0)];
    let f0s = [0.0, 0.04, 0.5, 0.9];
    for (ai, alpha) in alphas.iter().enumerate() {
        for (vi, v) in views.iter().enumerate() {
            for (fi, &f0) in f0s.iter().enumerate() {
                let mirror = [-v[0], -v[1], v[2]];
                let side = unit(cross(mirror, [0.3, 0.7, 0.2]));
                let k = (ai + vi + fi) % 3;
                let (p1, p2) = match k {
                    // Across the mirror direction.
                    0 => (
                        add(mul(mirror, 1.5), mul(side, -0.7)),
                        add(mul(mirror, 1.5), mul(side, 0.4)),
                    ),
                    // Beside it: the lobe's tail.
                    1 => (
                        add(mul(mirror, 2.0), mul(side, 0.6)),
                        add(add(mul(mirror, 2.0), mul(side, 1.8)), [0.0, 0.0, 0.4]),
                    ),
                    // Crossing the horizon.
                    _ => (
                        add(mul(mirror, 1.2), [0.2, -0.3, 0.3]),
                        [1.5 * mirror[0] - 0.4, 1.5 * mirror[1] + 0.5, -0.6],
                    ),
                };
                let ltc = if matches!(alpha, Roughness::Iso(_)) {
                    "table"
                } else {
                    "aniso"
                };
                let material = Material::ggx_fresnel(*alpha, *v, Some(f0), Some(ltc)).unwrap();
                let c = segment(format!("a{ai}v{vi}f{fi}"), p1, p2, material);
                c.validate().unwrap();
                out.push((c, alpha.xy(), *v, f0));
            }
        }
    }
    out
}

#[test]
fn ggx_line_references_with_f0_agree_with_an_independent_quadrature() {
    let cases = cases();
    let worst = std::sync::Mutex::new(0.0f64);
    let results: Vec<(String, f64, f64)> = cases
        .par_iter()
        .map(|(c, alpha, v, f0)| {
            let independent = line_with_fresnel(c, *alpha, *v, *f0);
            for target in [Target::Line, Target::LineUpper] {
                let r = reference(c, target).unwrap();
                let rel = (r.value - independent).abs() / independent.abs();
                if rel.is_finite() {
                    let mut w = worst.lock().unwrap();
                    *w = w.max(rel);
                }
                assert!(
                    rel <= 1e-7,
                    "{} {target}: reference {r:?}, independent {independent:e}, relative {rel:e}",
                    c.id
                );
                assert!(r.error <= 1e-7 * r.value, "{} {target}: error estimate {r:?}", c.id);
            }
            // F is really in it: the same lobe without F gives more light, by at most 1/F0.
            let mut without = c.clone();
            if let Material::Ggx { f0, .. } = &mut without.material {
                *f0 = None;
            }
            let plain = reference(&without, Target::Line).unwrap().value;
            (c.id.clone(), independent, plain)
        })
        .collect();
    eprintln!(
        "{} configurations: worst relative difference to the independent quadrature {:.2e}",
        cases.len(),
        *worst.lock().unwrap()
    );
    let lit = results.iter().filter(|r| r.1 > 0.0).count();
    assert!(
        lit >= results.len() - 4,
        "only {lit} of {} see the light",
        results.len()
    );
    for ((id, with, plain), (_, _, _, f0)) in results.iter().zip(&cases) {
        assert!(
            *with <= *plain * (1.0 + 1e-12),
            "{id}: F ≤ 1 cannot add light ({with:e} > {plain:e})"
        );
        assert!(
            *with >= f0 * plain * (1.0 - 1e-12),
            "{id}: F ≥ F0 ({with:e} < {f0}·{plain:e})"
        );
        if *f0 <= 0.04 && *plain > 0.0 {
            assert!(
                *with < 0.5 * plain,
                "{id}: a dielectric keeps most of the light ({with:e} of {plain:e})"
            );
        }
    }
}

/// Every other target of the `ggx` material integrates F too: F ≤ 1 and F ≥ F0 bound each one
/// against the same lobe without F, and the tube is its side plus its caps.
#[test]
fn surface_references_integrate_f_as_well() {
    // Near the mirror direction, running away from the shading point: the cap at p1 faces it.
    let v = view(45.0, 30.0);
    let mirror = [-v[0], -v[1], v[2]];
    let t = unit(add(mirror, mul(unit(cross(mirror, [0.0, 0.0, 1.0])), 0.6)));
    let mut c = Config {
        id: "surfaces".into(),
        p1: mul(mirror, 1.2),
        p2: add(mul(mirror, 1.2), mul(t, 0.8)),
        radius: Some(0.05),
        rect: None,
        material: Material::ggx_fresnel(Roughness::Iso(0.3), v, Some(0.04), None).unwrap(),
        texture: None,
    };
    c.rect = Some(linelight::input::scene::Rect {
        normal: unit(cross(t, [0.0, 0.0, 1.0])),
        width: 0.1,
    });
    c.validate().unwrap();
    let f0 = c.material.f0();
    let mut plain = c.clone();
    if let Material::Ggx { f0, .. } = &mut plain.material {
        *f0 = None;
    }
    for target in [
        Target::Cylinder,
        Target::Caps,
        Target::Tube,
        Target::Rectangle,
        Target::CylinderUpper,
        Target::RectangleUpper,
        Target::LineIsotropic,
    ] {
        let (w, p) = (reference(&c, target).unwrap(), reference(&plain, target).unwrap());
        assert!(p.value > 0.0, "{target}: the light must be seen");
        assert!(
            w.value < p.value && w.value >= f0 * p.value,
            "{target}: {w:?} against {p:?} (F0 {f0})"
        );
        assert!(w.error <= 1e-7 * w.value, "{target}: {w:?}");
    }
}

fn with_f0(c: &Config, f0: Option<f64>) -> Config {
    let Material::Ggx { alpha, view, ltc, .. } = &c.material else {
        unreachable!()
    };
    Config {
        material: Material::ggx_fresnel(*alpha, *view, f0, ltc.as_deref()).unwrap(),
        ..c.clone()
    }
}

#[test]
fn f0_absent_and_f0_one_are_the_same_bit_for_bit() {
    let base: Vec<Config> = cases()
        .into_iter()
        .step_by(7)
        .flat_map(|(c, ..)| {
            ["table", "fit"].map(|ltc| {
                let Material::Ggx { alpha, view, .. } = &c.material else {
                    unreachable!()
                };
                let mut c = c.clone();
                c.material = Material::ggx_fresnel(*alpha, *view, None, Some(ltc))
                    .or_else(|_| Material::ggx_fresnel(*alpha, *view, None, Some("fit")))
                    .unwrap();
                c.radius = Some(0.02);
                c
            })
        })
        .collect();
    let absent: Vec<Config> = base.iter().map(|c| with_f0(c, None)).collect();
    let one: Vec<Config> = base.iter().map(|c| with_f0(c, Some(1.0))).collect();
    for (a, b) in absent.iter().zip(&one) {
        for t in [Target::Line, Target::Cylinder, Target::Caps] {
            assert_eq!(reference(a, t), reference(b, t), "{} {t}", a.id);
        }
        assert_eq!(
            a.material.fed_magnitude().unwrap().to_bits(),
            b.material.fed_magnitude().unwrap().to_bits()
        );
        assert_eq!(
            bytemuck::bytes_of(&GpuScene::from(a)),
            bytemuck::bytes_of(&GpuScene::from(b)),
            "{}",
            a.id
        );
    }
    let kernels = builtin_kernels();
    for spec in [
        "line.ltc2017",
        "line.ltc2023",
        "tube.line[line.ltc2017]",
        "line.mrp_specular",
        "line.mrp_sum",
        "line.mrp_specular_energy",
    ] {
        let m = resolve(spec, &kernels).unwrap();
        for mode in [Mode::F32, Mode::F64] {
            let (x, y) = (m.cpu_column(&absent, mode).unwrap(), m.cpu_column(&one, mode).unwrap());
            let bits = |v: Vec<Option<f64>>| v.into_iter().map(|v| v.map(f64::to_bits)).collect::<Vec<_>>();
            assert_eq!(bits(x), bits(y), "{spec} {mode:?}");
        }
    }
}

/// What an LTC method is multiplied by: `f0·magnitude + (1 − f0)·fresnel` of the feed's two
/// channels, in f32 for a table (as the shader combines its texels), in f64 for the exact
/// fit; within 3 % of the exact ∫D·F (an independent quadrature over directions; measured at
/// most 5.2e-3, the f0 = 0 table look-ups at α = 0.1, where ∫D·F is all Schlick tail).
#[test]
fn the_fed_magnitude_is_the_fresnel_weighted_channels() {
    for (alpha, theta) in [(0.1, 20.0), (0.4, 60.0), (0.8, 80.0)] {
        let v = view(theta, 0.0);
        for f0 in [0.0, 0.04, 0.9] {
            for ltc in ["table", "table_f16", "fit"] {
                let m = Material::ggx_fresnel(Roughness::Iso(alpha), v, Some(f0), Some(ltc)).unwrap();
                let fed = *m.fed().unwrap();
                let want = if ltc == "fit" {
                    f0 * fed.magnitude + (1.0 - f0) * fed.fresnel
                } else {
                    let f = f0 as f32;
                    f64::from(f * fed.magnitude as f32 + (1.0 - f) * fed.fresnel as f32)
                };
                assert_eq!(m.fed_magnitude(), Some(want), "{alpha} {theta} {f0} {ltc}");
                // ∫D·F over the hemisphere in (cos θ, φ), here, term by term.
                let n = 400;
                let mut exact = 0.0;
                for i in 0..n {
                    for j in 0..n {
                        // u = cos θ graded towards the peak's z by u = 1 − s², s uniform.
                        let s = (i as f64 + 0.5) / n as f64;
                        let z = 1.0 - s * s;
                        let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / n as f64;
                        let r = (1.0 - z * z).max(0.0).sqrt();
                        let w = [r * phi.cos(), r * phi.sin(), z];
                        exact += ggx_d([alpha, alpha], v, w) * schlick(f0, v, w) * 2.0 * s;
                    }
                }
                exact *= 2.0 * std::f64::consts::PI / (n * n) as f64;
                let rel = (want - exact).abs() / exact;
                eprintln!("α {alpha} θ {theta}° f0 {f0} {ltc}: fed {want:.6e}, ∫D·F {exact:.6e}, relative {rel:.1e}");
                assert!(
                    rel < 0.03,
                    "{alpha} {theta} {f0} {ltc}: fed {want:e}, ∫D·F {exact:e}, {rel:e}"
                );
            }
        }
    }
}

#[test]
fn bad_f0_is_refused_naming_the_field() {
    let v = view(30.0, 0.0);
    for bad in [-0.1, 1.5, f64::NAN, f64::INFINITY] {
        let e = Material::ggx_fresnel(Roughness::Iso(0.3), v, Some(bad), None).unwrap_err();
        assert!(e.contains("f0") && e.contains("[0, 1]"), "{e}");
    }
    for ltc in ["published", "published_f16"] {
        let e = Material::ggx_fresnel(Roughness::Iso(0.3), v, Some(0.04), Some(ltc)).unwrap_err();
        assert!(e.contains("no Fresnel channel") && e.contains("f0"), "{e}");
        // F = 1 needs no Fresnel channel.
        Material::ggx_fresnel(Roughness::Iso(0.3), v, Some(1.0), Some(ltc)).unwrap();
    }
    let dir = tempfile::tempdir().unwrap();
    let line = |material: &str| format!(r#"{{"id":"a","p1":[0.3,-0.2,1.0],"p2":[0.9,0.4,1.6],"material":{material}}}"#);
    let ggx = r#"{"kind":"ggx","alpha":0.3,"view":[0.5,0.0,0.8660254037844386]"#;
    for (material, want) in [
        (format!(r#"{ggx},"f0":1.5}}"#), "f0"),
        (format!(r#"{ggx},"f0":-0.5}}"#), "f0"),
        (format!(r#"{ggx},"f0":"0.04"}}"#), "f64"),
        (format!(r#"{ggx},"f0":0.04,"ltc":"published"}}"#), "no Fresnel channel"),
        (r#"{"kind":"diffuse","f0":0.04}"#.to_string(), "f0"),
    ] {
        let input = common::write(dir.path(), "in.jsonl", &line(&material));
        let out = dir.path().join("out.jsonl");
        let o = common::eval(&input, &out, &[]);
        let err = common::stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{material}: {err}");
        assert!(err.contains(want) && err.contains("in.jsonl:1"), "{material}: {err}");
        assert!(!out.exists(), "{material}: nothing written");
    }
    // Case files: a range outside [0, 1], f0 on an ltc_ggx family, f0 with the published table.
    let case = |extra: &str, kind: &str| {
        format!(
            "{}\n[[materials]]\nname = \"g\"\nkind = \"{kind}\"\ncount = 5\nalpha = {{ dist = \"fixed\", value = 0.3 }}\n\
             view_angle = {{ dist = \"fixed\", value = 30.0 }}\n{extra}\n",
            common::CASE.replace("methods = [\"line.ltc2023\"]", "methods = [\"line.ltc2017\"]")
        )
    };
    for (text, want) in [
        (
            case("f0 = { dist = \"uniform\", min = 0.0, max = 1.2 }", "ggx"),
            "materials `g`.f0",
        ),
        (
            case("f0 = { dist = \"fixed\", value = 0.04 }", "ltc_ggx"),
            "materials `g`.f0",
        ),
        (
            case("f0 = { dist = \"fixed\", value = 0.04 }\nltc = \"published\"", "ggx"),
            "no Fresnel channel",
        ),
        (case("f0 = { dist = \"fixed\", value = 0.04 }", "diffuse"), "f0"),
    ] {
        let err = linelight::input::case::Case::parse("t.toml", &text)
            .unwrap_err()
            .to_string();
        assert!(err.contains(want), "{text}: {err}");
    }
    let ok = case("f0 = { dist = \"uniform\", min = 0.02, max = 0.05 }", "ggx");
    linelight::input::case::Case::parse("t.toml", &ok).unwrap();
}

/// Render scenes: every floor pixel's `ggx` material carries the scene's f0; f0 on another
/// material or with the published table is refused, naming the field.
#[test]
fn render_scenes_carry_f0() {
    use linelight::input::render_scene::RenderScene;
    let scene = |material: &str| {
        format!(
            "name = \"f\"\nmethods = [\"line.ltc2017\"]\n[render]\nwidth = 8\nheight = 6\n\
             camera = {{ position = [0.0, -3.0, 1.5], look_at = [0.0, 0.0, 0.0], fov_deg = 50.0 }}\n\
             light = {{ p1 = [-0.5, 0.5, 1.0], p2 = [0.5, 0.5, 1.0] }}\nmaterial = {material}\n"
        )
    };
    let s = RenderScene::parse(
        "s.toml",
        &scene("{ kind = \"ggx\", alpha_ramp = [0.2, 0.8], f0 = 0.04 }"),
    )
    .unwrap();
    let pixels = s.floor_pixels().unwrap();
    assert!(!pixels.is_empty());
    for p in &pixels {
        assert_eq!(p.config.material.f0(), 0.04, "pixel {} {}", p.x, p.y);
        assert_eq!(linelight::input::scene::SceneInput::new(&p.config).f0, 0.04);
    }
    for (material, want) in [
        ("{ kind = \"diffuse\", f0 = 0.04 }", "render.material.f0"),
        ("{ kind = \"ggx\", alpha = 0.3, f0 = 1.2 }", "render.material.f0"),
        (
            "{ kind = \"ggx\", alpha = 0.3, f0 = 0.5, ltc = \"published\" }",
            "no Fresnel channel",
        ),
    ] {
        let e = RenderScene::parse("s.toml", &scene(material)).unwrap_err().to_string();
        assert!(e.contains(want), "{material}: {e}");
    }
}

/// A case family's f0 is drawn into every material, and a family without it draws what it drew
/// before f0 existed (appending an f0 family leaves the others' configurations unchanged).
#[test]
fn case_families_draw_f0_and_leave_the_others_unchanged() {
    use linelight::input::case::Case;
    use linelight::input::sampler::sample_case;
    let base = common::CASE.replace("methods = [\"line.ltc2023\"]", "methods = [\"line.ltc2017\"]")
        + "[[materials]]\nname = \"g\"\nkind = \"ggx\"\ncount = 20\nalpha = { dist = \"log_uniform\", min = 0.05, max = 1.0 }\n\
           view_angle = { dist = \"uniform\", min = 0.0, max = 80.0 }\n";
    let with = base.clone()
        + "[[materials]]\nname = \"metal\"\nkind = \"ggx\"\ncount = 20\nalpha = { dist = \"log_uniform\", min = 0.05, max = 1.0 }\n\
           view_angle = { dist = \"uniform\", min = 0.0, max = 80.0 }\nf0 = { dist = \"uniform\", min = 0.5, max = 0.9 }\n";
    let (a, b) = (
        sample_case(&Case::parse("a.toml", &base).unwrap()),
        sample_case(&Case::parse("b.toml", &with).unwrap()),
    );
    let old: Vec<_> = a.iter().map(|s| &s.config).collect();
    let new: Vec<_> = b.iter().map(|s| &s.config).take(old.len()).collect();
    assert_eq!(old, new, "the families before the f0 family are unchanged");
    let metal: Vec<f64> = b[old.len()..].iter().map(|s| s.config.material.f0()).collect();
    assert_eq!(metal.len(), 20);
    assert!(metal.iter().all(|f| (0.5..=0.9).contains(f)), "{metal:?}");
    assert!(metal.windows(2).any(|w| w[0] != w[1]), "a range draws different values");
    assert!(old.iter().all(|c| c.material.f0() == 1.0));
}
