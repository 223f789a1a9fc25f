//! The kernel contract (kernels/README.md): the `Scene` grew the ggx view and roughness by
//! adding members at its end, so a kernel written to the contract before that keeps working.
//! `tests/data/old_contract.wgsl` is such a kernel (it reads every old member and calls every
//! old prelude helper); its values on the GPU and in the CPU evaluator (f32 and f64) were
//! recorded with the contract as it stood before (`record_old_contract_values`, run once on
//! that commit) and must come out bit for bit the same. The layout test reads every member,
//! old and new, back through a kernel on both paths.

use crate::common;

use linelight::eval::interp::{CpuColumns, Mode};
use linelight::input::scene::{Config, GpuScene, Material, Rect, Roughness};
use linelight::kernel::methods::{resolve, Method};
use linelight::kernel::{builtin_kernels, KernelFile};
use linelight::measure::gpu::Gpu;

const OLD: &str = include_str!("data/old_contract.wgsl");
const RECORDED: &str = "tests/data/old_contract_values.json";

fn gpu() -> &'static Gpu {
    common::gpu()
}

fn method(path: &str, text: &str) -> Method {
    let mut kernels = builtin_kernels();
    let k = KernelFile::parse(path, text).unwrap();
    let id = k.id.clone();
    kernels.push(k);
    resolve(&id, &kernels).unwrap()
}

fn gpu_values(gpu: &Gpu, m: &Method, configs: &[Config]) -> Vec<f32> {
    let scenes: Vec<GpuScene> = configs.iter().map(GpuScene::from).collect();
    let pipeline = gpu.pipeline(m).unwrap();
    gpu.run(&pipeline, &scenes, 64, &mut |_| {}).unwrap().values
}

/// Every material and optional member: diffuse, sparse and full LTC, isotropic and
/// anisotropic ggx, with and without a radius and a rectangle.
fn configs() -> Vec<Config> {
    let ggx = |alpha, view: [f64; 3]| {
        let n = (view[0] * view[0] + view[1] * view[1] + view[2] * view[2]).sqrt();
        Material::ggx(alpha, view.map(|x| x / n), None).unwrap()
    };
    let materials = [
        Material::Diffuse,
        Material::Ltc {
            minv: [[0.5, 0.0, 0.1], [0.0, 0.6, 0.0], [-0.2, 0.0, 1.0]],
        },
        Material::Ltc {
            minv: [[0.7, 0.2, 0.1], [-0.1, 0.5, 0.3], [0.2, -0.3, 1.1]],
        },
        ggx(Roughness::Iso(0.3), [0.4, -0.3, 0.8]),
        ggx(Roughness::Aniso([0.2, 0.5]), [-0.5, 0.2, 0.7]),
    ];
    let mut out = Vec::new();
    for (i, material) in materials.into_iter().enumerate() {
        for k in 0..3 {
            let s = 0.3 * k as f64;
            let p1 = [0.3 - s, -0.2 + 0.1 * i as f64, 1.0 + s];
            let p2 = [0.9, 0.4 - s, 1.6 - 0.2 * i as f64];
            let mut c = Config {
                id: format!("m{i}k{k}"),
                p1,
                p2,
                radius: (k >= 1).then_some(0.01 + 0.002 * i as f64),
                rect: (k == 2).then_some(Rect {
                    normal: [0.0, 0.0, 1.0],
                    width: 0.02,
                }),
                material: material.clone(),
                texture: None,
            };
            if c.rect.is_some() {
                c.orthonormalize_rect().unwrap();
            }
            c.validate().unwrap();
            out.push(c);
        }
    }
    out
}

#[derive(serde::Serialize, serde::Deserialize, PartialEq, Debug)]
struct Recorded {
    adapter: String,
    /// Per configuration: the GPU value, the evaluator's f32 and f64 values, as bit patterns.
    gpu_f32_bits: Vec<u32>,
    cpu_f32_bits: Vec<u64>,
    cpu_f64_bits: Vec<u64>,
}

fn evaluate(gpu: &Gpu) -> Recorded {
    let m = method("tests/data/old_contract.wgsl", OLD);
    let cs = configs();
    let col = |mode| -> Vec<u64> {
        m.cpu_column(&cs, mode)
            .unwrap()
            .into_iter()
            .map(|v| v.unwrap().to_bits())
            .collect()
    };
    Recorded {
        adapter: gpu.adapter.to_string(),
        gpu_f32_bits: gpu_values(gpu, &m, &cs).into_iter().map(f32::to_bits).collect(),
        cpu_f32_bits: col(Mode::F32),
        cpu_f64_bits: col(Mode::F64),
    }
}

/// Run once, on the commit before the contract changed, to write the recorded values.
/// Re-recorded once since, when the host's 3×3 inverse moved to glam: the
/// anisotropic ggx configurations' exact-fit feed moved, and with it the last two f64 values
/// by 1 and 2 ulp; every GPU and f32 value stayed bit for bit. Command:
/// `cargo test --release --test all scene_contract::record -- --ignored`.
#[test]
#[ignore]
fn record_old_contract_values() {
    let r = evaluate(gpu());
    std::fs::write(RECORDED, serde_json::to_string_pretty(&r).unwrap() + "\n").unwrap();
}

#[test]
fn an_old_contract_kernel_gives_the_values_recorded_before_the_scene_grew() {
    let gpu = gpu();
    let recorded: Recorded = serde_json::from_str(&std::fs::read_to_string(RECORDED).unwrap()).unwrap();
    let now = evaluate(gpu);
    // The evaluator is deterministic on any machine; the GPU's values are the driver's,
    // comparable bit for bit only on the adapter they were recorded on.
    assert_eq!(now.cpu_f32_bits, recorded.cpu_f32_bits, "evaluator f32");
    assert_eq!(now.cpu_f64_bits, recorded.cpu_f64_bits, "evaluator f64");
    if now.adapter == recorded.adapter {
        assert_eq!(now.gpu_f32_bits, recorded.gpu_f32_bits, "GPU on {}", now.adapter);
    } else {
        common::skip_or_fail(
            "an_old_contract_kernel_gives_the_values_recorded_before_the_scene_grew",
            &format!(
                "GPU values not compared: recorded on {}, running on {}",
                recorded.adapter, now.adapter
            ),
        );
    }
}

/// A kernel that returns Scene member component `K` (a float param, so one kernel reads
/// them all): 0–2 p1, 3 radius, 4–6 p2, 7 rect_width, 8–10 rect_normal, 11 flags, 12–20 minv
/// column by column, 21–23 view, 24 alpha_x, 25–27 tangent, 28 alpha_y, and contract 3's
/// 29–31 tex_origin, 32 f0, 33 tex_kind, 34 tex_offset, 35 tex_nu, 36 tex_nv. `minv: ggx`, so no
/// fed magnitude multiplies what it reads (the harness runs it on every material here).
const PROBE: &str = "//! id: user.scene_probe
//! target: line
//! source: tests/scene_contract.rs: reads one Scene member component back
//! minv: ggx
//! params: K=0.0
override K: f32 = 0.0;
fn method(scene: Scene) -> f32 {
    let k = i32(K);
    var v = array<f32, 37>(
        scene.p1.x, scene.p1.y, scene.p1.z, scene.radius,
        scene.p2.x, scene.p2.y, scene.p2.z, scene.rect_width,
        scene.rect_normal.x, scene.rect_normal.y, scene.rect_normal.z, f32(scene.flags),
        scene.minv[0].x, scene.minv[0].y, scene.minv[0].z,
        scene.minv[1].x, scene.minv[1].y, scene.minv[1].z,
        scene.minv[2].x, scene.minv[2].y, scene.minv[2].z,
        scene.view.x, scene.view.y, scene.view.z, scene.alpha_x,
        scene.tangent.x, scene.tangent.y, scene.tangent.z, scene.alpha_y,
        scene.tex_origin.x, scene.tex_origin.y, scene.tex_origin.z, scene.f0,
        f32(scene.tex_kind), f32(scene.tex_offset), f32(scene.tex_nu), f32(scene.tex_nv));
    return v[k];
}
";

/// [`configs`] and ggx materials with Schlick's F0 ≠ 1 (isotropic from our table, anisotropic
/// from the exact fit): contract 3's `f0` set from the material. (Not in [`configs`]: the old
/// contract's recorded values are of those configurations.)
fn configs_with_fresnel() -> Vec<Config> {
    let mut out = configs();
    for (i, (alpha, f0)) in [(Roughness::Iso(0.25), 0.04), (Roughness::Aniso([0.3, 0.6]), 0.9)]
        .into_iter()
        .enumerate()
    {
        let view = [0.3f64, 0.4, 0.0];
        let view = [view[0], view[1], (1.0 - view[0] * view[0] - view[1] * view[1]).sqrt()];
        let c = Config {
            id: format!("fresnel{i}"),
            p1: [0.3, -0.2, 1.0],
            p2: [0.9, 0.4, 1.6],
            radius: Some(0.01),
            rect: None,
            material: Material::ggx_fresnel(alpha, view, Some(f0), None).unwrap(),
            texture: None,
        };
        c.validate().unwrap();
        out.push(c);
    }
    out
}

#[test]
fn every_scene_member_reads_back_on_the_gpu_and_in_the_evaluator() {
    let gpu = gpu();
    let cs = configs_with_fresnel();
    let mut kernels = builtin_kernels();
    kernels.push(KernelFile::parse("probe.wgsl", PROBE).unwrap());
    for k in 0..37 {
        let m = resolve(&format!("user.scene_probe@{k}"), &kernels).unwrap();
        let raw = gpu_values(gpu, &m, &cs);
        let cpu = m.cpu_column(&cs, Mode::F32).unwrap();
        for ((c, g), cpu) in cs.iter().zip(raw).zip(cpu) {
            let input = linelight::input::scene::SceneInput::new(c);
            let flat: Vec<f64> = [
                "p1",
                "radius",
                "p2",
                "rect_width",
                "rect_normal",
                "flags",
                "minv",
                "view",
                "alpha_x",
                "tangent",
                "alpha_y",
                "tex_origin",
                "f0",
                "tex_kind",
                "tex_offset",
                "tex_nu",
                "tex_nv",
            ]
            .iter()
            .flat_map(|n| input.member(n).unwrap())
            .collect();
            let want = flat[k] as f32;
            if k == 32 {
                // f0: the material's F0, or 1 (F = 1) without one.
                let f0 = match &c.material {
                    Material::Ggx { f0: Some(f), .. } => *f as f32,
                    _ => 1.0,
                };
                assert_eq!(want, f0, "{}: f0 in the scene", c.id);
            }
            assert_eq!(g, want, "{}: GPU member component {k}", c.id);
            assert_eq!(cpu.unwrap() as f32, want, "{}: evaluator member component {k}", c.id);
        }
    }
}

#[test]
fn ggx_scenes_carry_the_view_and_roughness_in_the_kernels_frame() {
    for c in configs_with_fresnel() {
        let s = linelight::input::scene::SceneInput::new(&c);
        let Material::Ggx { alpha, view, .. } = &c.material else {
            assert_eq!(
                (s.view, s.alpha_x, s.tangent, s.alpha_y),
                ([0.0; 3], 0.0, [0.0; 3], 0.0),
                "{}",
                c.id
            );
            continue;
        };
        let fed = c.material.fed().unwrap();
        // The view lies in the xz-plane of the kernels' frame, with vx ≥ 0, and keeps its
        // angles to the segment: the scene is rotated with it.
        assert!(s.view[1].abs() < 1e-12 && s.view[0] >= 0.0, "{}: {:?}", c.id, s.view);
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        assert!((dot(s.view, s.p1) - dot(*view, c.p1)).abs() < 1e-12);
        assert!(
            (dot(s.tangent, s.view) - view[0]).abs() < 1e-12,
            "{}: αx's axis rotates with the view",
            c.id
        );
        assert_eq!([s.alpha_x, s.alpha_y], alpha.xy());
        assert_eq!(s.minv, fed.minv);
    }
}
