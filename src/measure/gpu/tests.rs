//! These run on lavapipe: without it they fail, they do not skip.

use super::*;
use crate::input::scene::GpuScene;
use crate::kernel::methods::Method;
use crate::kernel::{compose, KernelFile};

fn gpu() -> &'static Gpu {
    crate::measure::gpu::test_gpu()
}

/// A method without an inner line method, params as given (resolve would refuse 0).
fn method(k: &KernelFile, params: &[u32]) -> Method {
    Method {
        label: k.id.clone(),
        kernel: k.clone(),
        params: params.iter().map(|&p| f64::from(p)).collect(),
        inner: None,
        judged: None,
    }
}

fn kernel(path: &str, header: &str, body: &str) -> KernelFile {
    KernelFile::parse(path, &format!("//! id: test.k\n//! target: line\n{header}{body}")).unwrap()
}

fn scene(p1x: f32, p2x: f32) -> GpuScene {
    GpuScene {
        p1: [p1x, 0.0, 1.0],
        p2: [p2x, 0.0, 1.0],
        ..Default::default()
    }
}

#[test]
fn gpu_trivial_kernel_across_chunks() {
    // Reads the scene's M⁻¹ and the prelude's global `Minv` the entry point sets from it,
    // at transposed entries so a row/column mix-up shows.
    let k = kernel(
        "trivial.wgsl",
        "",
        "fn method(scene: Scene) -> f32 { return scene.p1.x + 2.0 * scene.minv[0][1] + 4.0 * Minv[1][0]; }\n",
    );
    let g = gpu();
    let pipeline = g.pipeline(&method(&k, &[])).unwrap();
    let scenes: Vec<GpuScene> = (0..300)
        .map(|i| {
            let mut s = scene(i as f32, 1.0);
            s.minv_cols[0][1] = 0.25 * i as f32;
            s.minv_cols[1][0] = 1000.0 + i as f32;
            s
        })
        .collect();
    let mut done = Vec::new();
    let out = g.run(&pipeline, &scenes, 128, &mut |n| done.push(n)).unwrap();
    assert_eq!(done, vec![128, 256, 300]);
    let expected: Vec<f32> = (0..300).map(|i| i as f32 * 1.5 + 4.0 * (1000.0 + i as f32)).collect();
    assert_eq!(out.values, expected);
}

#[test]
fn gpu_nan_and_infinity_are_kept() {
    let k = kernel(
        "div.wgsl",
        "",
        "fn method(scene: Scene) -> f32 { return scene.p1.x / scene.p2.x; }\n",
    );
    let g = gpu();
    let scenes = [scene(1.0, 0.0), scene(-1.0, 0.0), scene(0.0, 0.0), scene(1.0, 2.0)];
    let out = g
        .run(&g.pipeline(&method(&k, &[])).unwrap(), &scenes, 0, &mut |_| {})
        .unwrap();
    assert_eq!(out.values[0], f32::INFINITY);
    assert_eq!(out.values[1], f32::NEG_INFINITY);
    assert!(out.values[2].is_nan(), "{:?}", out.values);
    assert_eq!(out.values[3], 0.5);
}

#[test]
fn gpu_override_param_changes_output() {
    let k = kernel(
        "param.wgsl",
        "//! params: SCALE=2 OFFSET=1\n",
        "override SCALE: u32 = 7u;\noverride OFFSET: u32;\n\
         fn method(scene: Scene) -> f32 { return f32(SCALE) * scene.p1.x + f32(OFFSET); }\n",
    );
    let g = gpu();
    let scenes = [scene(1.0, 2.0), scene(3.0, 2.0)];
    let run = |params: &[u32]| {
        g.run(&g.pipeline(&method(&k, params)).unwrap(), &scenes, 0, &mut |_| {})
            .unwrap()
            .values
    };
    assert_eq!(run(&[]), vec![3.0, 7.0]);
    assert_eq!(run(&[5]), vec![6.0, 16.0]);
    assert_eq!(run(&[5, 10]), vec![15.0, 25.0]);
    let e = g.pipeline(&method(&k, &[1, 2, 3])).err().unwrap().to_string();
    assert!(e.contains("param.wgsl") && e.contains("SCALE, OFFSET"), "{e}");
}

#[test]
fn gpu_float_param_from_the_spec() {
    let k = kernel(
        "float.wgsl",
        "//! params: SCALE=0.5 N=2\n",
        "override SCALE: f32 = 1.0;\noverride N: u32;\n\
         fn method(scene: Scene) -> f32 { return SCALE * scene.p1.x + f32(N); }\n",
    );
    let g = gpu();
    let scenes = [scene(1.0, 2.0), scene(3.0, 2.0)];
    let run = |spec: &str| {
        let m = crate::kernel::methods::resolve(spec, std::slice::from_ref(&k)).unwrap();
        g.run(&g.pipeline(&m).unwrap(), &scenes, 0, &mut |_| {}).unwrap().values
    };
    assert_eq!(run("test.k"), vec![2.5, 3.5]);
    assert_eq!(run("test.k@-1.25x3"), vec![1.75, -0.75]);
    let e = crate::kernel::methods::resolve("test.k@1x2.5", std::slice::from_ref(&k)).unwrap_err();
    assert!(e.to_string().contains("`2.5` is not a positive integer"), "{e}");
    // A float in the header needs an f32 override: the error names the override's line.
    let bad = kernel(
        "float_u32.wgsl",
        "//! params: SCALE=0.5\n",
        "override SCALE: u32 = 1u;\nfn method(scene: Scene) -> f32 { return f32(SCALE); }\n",
    );
    let e = compose(&bad).unwrap_err();
    assert_eq!(e.location.map(|l| l.0), Some(4), "{e}");
    assert!(e.to_string().contains("must be `f32`"), "{e}");
}

#[test]
fn gpu_kernel_error_names_its_file_and_line() {
    let k = kernel(
        "user/bad.wgsl",
        "",
        "// a comment\n// another\n\nfn method(scene: Scene) -> f32 {\n    return scene.p1.x + undefined_thing;\n}\n",
    );
    let e = compose(&k).unwrap_err();
    let text = e.to_string();
    assert!(text.contains("user/bad.wgsl:7:"), "{text}");
    assert!(
        text.contains("no definition in scope for identifier: `undefined_thing`"),
        "{text}"
    );
    assert!(text.contains("return scene.p1.x + undefined_thing;"), "{text}");
    assert!(text.contains('^'), "{text}");
    assert_eq!(e.location, Some((7, 25)));
    // The same error through the device path.
    assert_eq!(gpu().pipeline(&method(&k, &[])).err().unwrap().to_string(), text);
}

#[test]
fn gpu_unknown_adapter_lists_the_adapters_found() {
    gpu();
    let e = Gpu::new(Some("no-such-adapter-xyz")).err().unwrap().to_string();
    assert!(e.contains("`no-such-adapter-xyz`") && e.contains("llvmpipe"), "{e}");
    assert!(list_adapters().iter().any(|a| a.name.contains("llvmpipe")));
    assert!(
        gpu().adapter.to_string().contains(" — Vulkan, Cpu, driver llvmpipe"),
        "{}",
        gpu().adapter
    );
}

#[test]
fn gpu_no_adapter_message_names_the_package() {
    let e = GpuError::NoAdapter {
        requested: None,
        found: Vec::new(),
    }
    .to_string();
    assert!(e.contains("apt-get install mesa-vulkan-drivers"), "{e}");
}

/// Opening the device prints nothing on stderr, even with `XDG_RUNTIME_DIR` unset: the
/// test re-runs itself as a child process and reads the child's stderr.
#[test]
fn gpu_driver_is_quiet() {
    if std::env::var_os("LINELIGHT_QUIET_CHILD").is_some() {
        quiet_driver_environment();
        Gpu::new(None).unwrap();
        return;
    }
    let out = std::process::Command::new(std::env::current_exe().unwrap())
        .args(["--exact", "gpu::tests::gpu_driver_is_quiet", "--test-threads=1"])
        .env("LINELIGHT_QUIET_CHILD", "1")
        .env_remove("XDG_RUNTIME_DIR")
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stdout));
    assert_eq!(String::from_utf8_lossy(&out.stderr), "");
}

#[test]
fn gpu_kernel_directives_are_hoisted_and_keep_line_numbers() {
    let k = kernel(
        "dir.wgsl",
        "",
        "diagnostic(off, derivative_uniformity);\n\nfn method(scene: Scene) -> f32 {\n    return nope;\n}\n",
    );
    let e = compose(&k).unwrap_err();
    assert_eq!((e.path.as_str(), e.location), ("dir.wgsl", Some((6, 12))), "{e}");

    let g = gpu();
    assert!(
        g.device().features().contains(wgpu::Features::SHADER_F16),
        "lavapipe offers f16"
    );
    let k = kernel(
        "half.wgsl",
        "",
        "enable f16;\nfn method(scene: Scene) -> f32 { return f32(f16(scene.p1.x) * 2.0h); }\n",
    );
    let out = g
        .run(
            &g.pipeline(&method(&k, &[])).unwrap(),
            &[scene(1.5, 0.0)],
            0,
            &mut |_| {},
        )
        .unwrap();
    assert_eq!(out.values, vec![3.0]);
}

#[test]
fn gpu_pipeline_errors_from_wgpu_are_values() {
    let k = kernel(
        "div0.wgsl",
        "//! params: DIV=1\n",
        "override DIV: u32 = 1u;\noverride Q: u32 = 10u / DIV;\n\
         fn method(scene: Scene) -> f32 { return f32(Q); }\n",
    );
    let g = gpu();
    let ok = g
        .run(
            &g.pipeline(&method(&k, &[2])).unwrap(),
            &[scene(0.0, 1.0)],
            0,
            &mut |_| {},
        )
        .unwrap();
    assert_eq!(ok.values, vec![5.0]);
    let e = g.pipeline(&method(&k, &[0])).err().unwrap();
    assert_eq!(e.path, "div0.wgsl");
    assert!(
        e.to_string()
            .starts_with("div0.wgsl: wgpu rejected the kernel with DIV=0: "),
        "{e}"
    );
    assert!(e.to_string().contains("Division by zero"), "{e}");
}

#[test]
fn gpu_builtin_kernels_compose_and_compile() {
    let g = gpu();
    for k in crate::kernel::builtin_kernels() {
        compose(&k).unwrap_or_else(|e| panic!("{e}"));
        g.pipeline(&method(&k, &[])).unwrap_or_else(|e| panic!("{e}"));
    }
}
