//! The kernel contract (kernels/README.md): the `Scene` grew the ggx view and roughness by
//! adding members at its end, so a kernel written to the contract before that keeps working.
//! `tests/data/old_contract.wgsl` is such a kernel (it reads every old member and calls every
//! old prelude helper); its values on the GPU and in the CPU evaluator (f32 and f64) were
//! recorded with the contract as it stood before (`record_old_contract_values`, run once on
//! that commit) and must come out bit for bit the same. The layout test reads every member,
//! old and new, back through a kernel on both paths.

use linelight::gpu::Gpu;
use linelight::interp::Mode;
use linelight::kernel::{builtin_kernels, KernelFile};
use linelight::methods::{resolve, Method};
use linelight::scene::{Config, GpuScene, Material, Rect, Roughness};

const OLD: &str = include_str!("data/old_contract.wgsl");
const RECORDED: &str = "tests/data/old_contract_values.json";

fn gpu() -> Gpu {
    linelight::gpu::quiet_driver_environment();
    Gpu::new(None).expect("lavapipe is installed (scripts/ensure-vulkan)")
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

/// Run once, on the commit before the contract changed, to write the recorded values:
/// `cargo test --release --test scene_contract -- --ignored record`.
#[test]
#[ignore]
fn record_old_contract_values() {
    let r = evaluate(&gpu());
    std::fs::write(RECORDED, serde_json::to_string_pretty(&r).unwrap() + "\n").unwrap();
}
