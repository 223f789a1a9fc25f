//! What the tests share: running the binary, its stderr, writing an input file, the GPU.
#![allow(dead_code)] // each test binary uses its own share of these

pub mod case;
pub mod independent;
pub mod snapshot;

pub use case::case;
use linelight::input::scene::{Config, Material};
use snapshot::s;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A valid eval line (docs/eval-format.md), for the bad-input tests.
pub const CONFIG: &str = r#"{"id":"a","p1":[0.3,-0.2,1.0],"p2":[0.9,0.4,1.6],"material":{"kind":"diffuse"}}"#;

/// The smallest sweep case the bad-input tests start from.
pub const CASE: &str = r#"
name = "tiny"
title = "tiny"
seed = 7
methods = ["line.ltc2023"]
[geometry]
elevation = { dist = "uniform", min = 10.0, max = 90.0 }
tilt_angle = { dist = "uniform", min = 0.0, max = 180.0 }
length = { dist = "log_uniform", min = 0.1, max = 10.0 }
center = { dist = "uniform", min = -1.0, max = 1.0 }
[[materials]]
name = "diffuse"
kind = "diffuse"
count = 20
"#;

/// Runs `linelight` with `args` from the test's working directory.
pub fn linelight(args: &[&str]) -> Output {
    linelight_with(&[], args)
}

/// Runs `linelight` with `args` and the environment variables `env` set for it (never for
/// this process, whose tests run in parallel threads).
pub fn linelight_with(env: &[(&str, &str)], args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_linelight"))
        .args(args)
        .envs(env.iter().copied())
        .output()
        .expect("linelight runs")
}

/// `linelight eval --input input --output output args…`.
pub fn eval(input: &Path, output: &Path, args: &[&str]) -> Output {
    eval_with(&[], input, output, args)
}

/// [`eval`] with the environment variables `env` set for it.
pub fn eval_with(env: &[(&str, &str)], input: &Path, output: &Path, args: &[&str]) -> Output {
    let mut all = vec!["eval", "--input", s(input), "--output", s(output)];
    all.extend(args);
    linelight_with(env, &all)
}

/// `linelight sweep` of `case` (written to `dir/case.toml`) into `dir/reports`, with `extra`.
pub fn sweep(dir: &Path, case: &str, extra: &[&str]) -> Output {
    let case = write(dir, "case.toml", case);
    let out = dir.join("reports");
    let mut args = vec!["sweep", s(&case), "--out", s(&out)];
    args.extend(extra);
    linelight(&args)
}

/// Runs `linelight` with `args` from the folder `dir` (for the default output folders).
pub fn linelight_in(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_linelight"))
        .current_dir(dir)
        .args(args)
        .output()
        .expect("linelight runs")
}

/// A JSON file (a summary, a record), parsed.
pub fn json(path: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// A segment light from `p1` to `p2` lit onto `material`: no radius, rectangle or texture.
pub fn segment(id: impl Into<String>, p1: [f64; 3], p2: [f64; 3], material: Material) -> Config {
    Config {
        id: id.into(),
        p1,
        p2,
        radius: None,
        rect: None,
        material,
        texture: None,
    }
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Writes `text` to `dir/name` and returns the path.
pub fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// The one GPU (lavapipe by default) of a test binary, opened once with the driver quiet.
pub fn gpu() -> &'static linelight::measure::gpu::Gpu {
    static GPU: std::sync::OnceLock<linelight::measure::gpu::Gpu> = std::sync::OnceLock::new();
    GPU.get_or_init(|| {
        linelight::measure::gpu::quiet_driver_environment();
        linelight::measure::gpu::Gpu::new(None)
            .unwrap_or_else(|e| panic!("lavapipe is installed (scripts/ensure-vulkan): {e}"))
    })
}

/// `method`'s f32 values on the shared GPU for `configs`, their textures and LTC tables bound.
pub fn gpu_values(method: &linelight::kernel::methods::Method, configs: &[Config]) -> Vec<f32> {
    let gpu = gpu();
    let (scenes, texels) = linelight::input::scene::gpu_scenes(configs);
    let pipeline = gpu.pipeline(method).unwrap();
    gpu.run_textured(&pipeline, &scenes, &texels, 0, &mut |_| {})
        .unwrap()
        .values
}

/// A test that cannot run its check here (another GPU than the one its values were recorded
/// on, a missing privilege): under CI (`CI=true`, as GitHub Actions, GitLab CI and .ci/run set
/// it) a failure, since a skip there hides that the check never ran; elsewhere a visible line.
pub fn skip_or_fail(test: &str, why: &str) {
    let ci = std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "0" && v != "false");
    assert!(!ci, "{test}: not checked under CI: {why}");
    eprintln!("SKIPPED (a failure under CI=true) {test}: {why}");
}

/// Validates a JUnit file against the Ant JUnit schema with `xmllint --schema` (libxml2-utils;
/// .ci/run installs it): absent, a failure under CI and a visible skip elsewhere.
pub fn validate_junit(path: &Path) {
    let schema = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/junit/JUnit.xsd");
    let o = match Command::new("xmllint")
        .args(["--noout", "--schema", schema])
        .arg(path)
        .output()
    {
        Ok(o) => o,
        Err(e) => {
            skip_or_fail(
                "validate_junit",
                &format!("xmllint cannot run ({e}): install libxml2-utils"),
            );
            return;
        }
    };
    assert!(
        o.status.success(),
        "{} does not validate against {schema}:\n{}\n{}",
        path.display(),
        String::from_utf8_lossy(&o.stderr),
        std::fs::read_to_string(path).unwrap_or_default()
    );
}
