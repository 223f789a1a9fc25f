//! Derived kernels (`//! derive:` + `//! replace:`) compute exactly what the standalone
//! files they replaced computed: the same bits on the GPU and in the CPU evaluator (f32 and
//! f64), on a seeded sample. tests/data/standalone/ holds those files as they were before the
//! conversion, frozen for this comparison (they are not built in).

use crate::common;

use linelight::eval::interp::CpuColumns;
use linelight::eval::interp::Mode;
use linelight::input::scene::{Config, GpuScene, Material, Rect};
use linelight::kernel::methods::{resolve, Method};
use linelight::kernel::{builtin_kernels, KernelFile};
use rand::{Rng, SeedableRng};

const CONVERTED: &[&str] = &[
    "line_ltc2023_full",
    "line_ltc2023_fix",
    "line_ltc2017_fwt",
    "rectangle_line_fixed",
    "rectangle_ltc_polygon_atan2",
];

fn sample(n: usize) -> Vec<Config> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
    let mut out = Vec::new();
    while out.len() < n {
        let mut p = || [0, 1, 2].map(|k| rng.random_range(-2.0..2.0) + if k == 2 { 0.5 } else { 0.0 });
        let (p1, p2, normal) = (p(), p(), p());
        let material = match out.len() % 3 {
            0 => Material::Diffuse,
            1 => Material::Ltc {
                minv: [[0.7, 0.0, 0.15], [0.0, 0.9, 0.0], [-0.25, 0.0, 1.0]],
            },
            _ => Material::Ltc {
                minv: [[2.0, 0.7, -0.4], [-0.5, 3.0, 0.3], [0.1, -0.2, 1.0]],
            },
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

/// The derived built-in and the frozen standalone file, under the id `standalone.ID`.
fn pair(name: &str) -> (Method, Method) {
    let mut kernels = builtin_kernels();
    let derived = kernels
        .iter()
        .find(|k| k.path == format!("kernels/{name}.wgsl"))
        .unwrap_or_else(|| panic!("{name} is built in"))
        .clone();
    assert!(derived.derived.is_some(), "{name} is a derived kernel");
    let path = format!("{}/tests/data/standalone/{name}.wgsl", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap();
    let text = text.replacen("//! id: ", "//! id: standalone.", 1);
    let old = KernelFile::parse(&path, &text).unwrap();
    assert!(old.derived.is_none());
    assert_eq!(
        (old.target, old.minv, &old.params, old.uses_line, old.uses_target),
        (
            derived.target,
            derived.minv,
            &derived.params,
            derived.uses_line,
            derived.uses_target
        ),
        "{name}: the header the derived kernel inherits"
    );
    let old_id = old.id.clone();
    kernels.push(old);
    (
        resolve(&derived.id, &kernels).unwrap(),
        resolve(&old_id, &kernels).unwrap(),
    )
}

fn bits(v: &[Option<f64>]) -> Vec<Option<u64>> {
    v.iter().map(|x| x.map(f64::to_bits)).collect()
}

#[test]
fn derived_kernels_match_the_standalone_files_in_the_evaluator() {
    let configs = sample(300);
    for name in CONVERTED {
        let (new, old) = pair(name);
        for mode in [Mode::F32, Mode::F64] {
            let (a, b) = (
                new.cpu_column(&configs, mode).unwrap(),
                old.cpu_column(&configs, mode).unwrap(),
            );
            assert!(
                a.iter().filter(|v| v.is_some_and(|x| x != 0.0)).count() > 50,
                "{name}: too few values"
            );
            assert_eq!(bits(&a), bits(&b), "{name} {mode:?}");
        }
    }
}

#[test]
fn gpu_derived_kernels_match_the_standalone_files() {
    let gpu = common::gpu();
    let configs = sample(300);
    let scenes: Vec<GpuScene> = configs.iter().map(GpuScene::from).collect();
    for name in CONVERTED {
        let (new, old) = pair(name);
        let run = |m: &Method| {
            let p = gpu.pipeline(m).unwrap_or_else(|e| panic!("{}: {e}", m.label));
            gpu.run(&p, &scenes, 64, &mut |_| {}).unwrap().values
        };
        let (a, b) = (run(&new), run(&old));
        let nonzero = a.iter().filter(|x| **x != 0.0 && x.is_finite()).count();
        assert!(nonzero > 50, "{name}: {nonzero} nonzero values");
        let (a, b): (Vec<u32>, Vec<u32>) = (
            a.iter().map(|x| x.to_bits()).collect(),
            b.iter().map(|x| x.to_bits()).collect(),
        );
        assert_eq!(a, b, "{name}");
    }
}
