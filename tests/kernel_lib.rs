//! Kernels built from the shared pieces of kernels/lib/ (`#include "lib/…"`) and
//! `line.ltc2017_atan5` (derived from `line.ltc2017`) compute exactly what their standalone
//! files computed: the same bits on the GPU and in the CPU evaluator (f32 and f64), on a
//! seeded sample of diffuse, LTC and ggx configurations. tests/data/standalone/ holds those
//! files as they were before, frozen for this comparison (they are not built in). Also: an
//! error inside a piece names the piece's own file and line.

use crate::common;

use linelight::eval::interp::{CpuColumns, Mode};
use linelight::input::scene::{Config, GpuScene, Material, Rect, Roughness};
use linelight::kernel::methods::{resolve, Method};
use linelight::kernel::{builtin_kernels, compose, KernelFile};
use rand::{Rng, SeedableRng};

/// Built-in kernels (path under kernels/) and the frozen file each is compared with.
const CHANGED: &[(&str, &str)] = &[
    ("cylinder_numeric", "cylinder_numeric"),
    ("rectangle_numeric", "rectangle_numeric"),
    ("engines/line_ltc2017_atan5", "line_ltc2017_atan5"),
    ("mrp/cylinder_mrp_tube", "cylinder_mrp_tube"),
    ("mrp/line_mrp_bisector", "line_mrp_bisector"),
    ("mrp/line_mrp_bisector_visible", "line_mrp_bisector_visible"),
    ("mrp/line_mrp_intersection", "line_mrp_intersection"),
    ("mrp/line_mrp_specular", "line_mrp_specular"),
    ("mrp/line_mrp_sum", "line_mrp_sum"),
];

fn sample(n: usize) -> Vec<Config> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let mut out = Vec::new();
    while out.len() < n {
        let mut p = || [0, 1, 2].map(|k| rng.random_range(-2.0..2.0f64) + if k == 2 { 0.5 } else { 0.0 });
        let (p1, p2, normal, view) = (p(), p(), p(), p());
        let material = match out.len() % 4 {
            0 => Material::Diffuse,
            1 => Material::Ltc {
                minv: [[0.7, 0.0, 0.15], [0.0, 0.9, 0.0], [-0.25, 0.0, 1.0]],
            },
            2 => Material::Ltc {
                minv: [[2.0, 0.7, -0.4], [-0.5, 3.0, 0.3], [0.1, -0.2, 1.0]],
            },
            _ => {
                let len = (view[0] * view[0] + view[1] * view[1] + view[2] * view[2]).sqrt();
                let view = [view[0] / len, view[1] / len, view[2].abs() / len];
                match Material::ggx(Roughness::Iso(rng.random_range(0.2..1.0)), view, Some("table")) {
                    Ok(m) => m,
                    Err(_) => continue,
                }
            }
        };
        let mut c = Config {
            id: format!("c{}", out.len()),
            p1,
            p2,
            radius: Some(0.05),
            rect: Some(Rect { normal, width: 0.1 }),
            material,
            texture: None,
        };
        if c.orthonormalize_rect().is_some() && c.validate().is_ok() {
            out.push(c);
        }
    }
    out
}

/// The built-in kernel and the frozen standalone file, under the id `standalone.ID`.
fn pair(path: &str, frozen: &str) -> (Method, Method) {
    let mut kernels = builtin_kernels();
    let new = kernels
        .iter()
        .find(|k| k.path == format!("kernels/{path}.wgsl"))
        .unwrap_or_else(|| panic!("{path} is built in"))
        .clone();
    let file = format!("{}/tests/data/standalone/{frozen}.wgsl", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&file).unwrap();
    assert!(
        !text.contains("#include") && !text.contains("//! derive"),
        "{frozen} is standalone"
    );
    let text = text.replacen("//! id: ", "//! id: standalone.", 1);
    let old = KernelFile::parse(&file, &text).unwrap();
    assert_eq!(
        (old.target, old.minv, &old.params, old.uses_line, old.uses_target),
        (new.target, new.minv, &new.params, new.uses_line, new.uses_target),
        "{path}: the header"
    );
    let old_id = old.id.clone();
    kernels.push(old);
    (resolve(&new.id, &kernels).unwrap(), resolve(&old_id, &kernels).unwrap())
}

fn bits(v: &[Option<f64>]) -> Vec<Option<u64>> {
    v.iter().map(|x| x.map(f64::to_bits)).collect()
}

#[test]
fn kernels_on_lib_pieces_match_the_standalone_files_in_the_evaluator() {
    let configs = sample(240);
    for (path, frozen) in CHANGED {
        let (new, old) = pair(path, frozen);
        for mode in [Mode::F32, Mode::F64] {
            let (a, b) = (
                new.cpu_column(&configs, mode).unwrap(),
                old.cpu_column(&configs, mode).unwrap(),
            );
            let nonzero = a.iter().filter(|v| v.is_some_and(|x| x != 0.0)).count();
            assert!(nonzero > 20, "{path}: {nonzero} nonzero values");
            assert_eq!(bits(&a), bits(&b), "{path} {mode:?}");
        }
    }
}

#[test]
fn gpu_kernels_on_lib_pieces_match_the_standalone_files() {
    let gpu = common::gpu();
    let configs = sample(240);
    let scenes: Vec<GpuScene> = configs.iter().map(GpuScene::from).collect();
    for (path, frozen) in CHANGED {
        let (new, old) = pair(path, frozen);
        let run = |m: &Method| {
            let p = gpu.pipeline(m).unwrap_or_else(|e| panic!("{}: {e}", m.label));
            gpu.run(&p, &scenes, 64, &mut |_| {}).unwrap().values
        };
        let (a, b) = (run(&new), run(&old));
        let nonzero = a.iter().filter(|x| **x != 0.0 && x.is_finite()).count();
        assert!(nonzero > 20, "{path}: {nonzero} nonzero values");
        let (a, b): (Vec<u32>, Vec<u32>) = (
            a.iter().map(|x| x.to_bits()).collect(),
            b.iter().map(|x| x.to_bits()).collect(),
        );
        assert_eq!(a, b, "{path}");
    }
}

#[test]
fn a_piece_keeps_its_own_file_and_line() {
    let k = builtin_kernels()
        .into_iter()
        .find(|k| k.id == "cylinder.numeric")
        .unwrap();
    let parts = k.parts();
    let paths: Vec<&str> = parts.iter().map(|(p, _)| p.as_str()).collect();
    assert_eq!(
        paths,
        [
            "kernels/cylinder_numeric.wgsl",
            "kernels/lib/theta_quadrature.wgsl",
            "kernels/cylinder_numeric.wgsl"
        ]
    );
    // Every part's lines stand at their own numbers in their own file.
    for (path, text) in &parts {
        let file = std::fs::read_to_string(format!("{}/{path}", env!("CARGO_MANIFEST_DIR"))).unwrap();
        let own: Vec<&str> = file.lines().collect();
        for (i, line) in text.lines().enumerate() {
            assert!(line.is_empty() || own[i] == line, "{path}:{}: `{line}`", i + 1);
        }
    }
    let composed = compose(&k).unwrap();
    let at = composed.source.find("fn theta_quadrature").unwrap();
    let (path, line, text) = composed.locate(at);
    let piece = linelight::kernel::lib_pieces()
        .iter()
        .find(|(p, _)| *p == "kernels/lib/theta_quadrature.wgsl")
        .unwrap()
        .1;
    let want = piece
        .lines()
        .position(|l| l.starts_with("fn theta_quadrature"))
        .unwrap()
        + 1;
    assert_eq!((path.as_str(), line), ("kernels/lib/theta_quadrature.wgsl", want));
    assert!(text.starts_with("fn theta_quadrature"));

    // An error inside a piece names the piece's line; one in the kernel after the include, the kernel's.
    let user = |body: &str| {
        let text = format!("//! id: user.k\n//! target: line\n#include \"lib/theta_quadrature.wgsl\"\n{body}");
        KernelFile::parse("user.wgsl", &text).unwrap()
    };
    let e = compose(&user(
        "override NL: u32 = 4;\nfn method(scene: Scene) -> f32 { return nope; }\n",
    ))
    .unwrap_err();
    assert_eq!(
        (e.path.as_str(), e.location.map(|l| l.0)),
        ("user.wgsl", Some(5)),
        "{e}"
    );
    let e = compose(&user("fn method(scene: Scene) -> f32 { return 0.0; }\n")).unwrap_err();
    assert_eq!(e.path, "kernels/lib/theta_quadrature.wgsl", "{e}");
    assert!(e.report.contains("NL"), "{e}");

    let bad = |inc: &str| {
        KernelFile::parse(
            "user.wgsl",
            &format!("//! id: user.k\n//! target: line\n#include {inc}\n"),
        )
        .unwrap_err()
        .to_string()
    };
    assert!(bad("\"lib/none.wgsl\"").starts_with("user.wgsl:3: cannot find included file `lib/none.wgsl`"));
    assert!(bad("\"../kernels/lib/theta_quadrature.wgsl\"").contains("without `..`"));
    assert!(bad("\"/etc/passwd\"").contains("without `..`"));
    assert!(bad("lib/x").contains("an include names its file as"));
}
