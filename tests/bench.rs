//! `linelight bench` as a user meets it (on lavapipe: without it these fail, they do not
//! skip). Speed is measured, never asserted: these check what is printed and written,
//! not how fast anything ran.

use crate::common;
use std::process::Output;

/// Runs `linelight` from the checkout (the cases' and data's relative paths).
fn linelight(args: &[&str]) -> Output {
    crate::common::linelight_in(std::path::Path::new(env!("CARGO_MANIFEST_DIR")), args)
}

#[test]
fn bench_prints_both_methods_and_their_ratio_and_writes_json() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("costs.json");
    let o = linelight(&[
        "bench",
        "--count",
        "1024",
        "--repeats",
        "3",
        "--warmup",
        "1",
        "--methods",
        "line.ltc2017,line.ltc2023",
        "--json",
        json.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        o.status.success(),
        "exit {:?}\nstdout:\n{stdout}\nstderr:\n{stderr}",
        o.status
    );
    assert!(stdout.starts_with("adapter: llvmpipe"), "{stdout}");
    assert!(stdout.contains("1024 configurations per dispatch"), "{stdout}");
    let row = |label: &str| stdout.lines().find(|l| l.starts_with(&format!("{label} ")));
    for label in ["line.ltc2017", "line.ltc2023"] {
        let row = row(label).unwrap_or_else(|| panic!("no row for {label}:\n{stdout}"));
        assert!(row.ends_with(char::is_numeric), "the row ends with the op count: {row}");
    }
    let ratio = stdout
        .lines()
        .find(|l| l.trim_start().starts_with("line.ltc2017 / line.ltc2023: GPU "))
        .unwrap_or_else(|| panic!("no ratio line:\n{stdout}"));
    assert!(ratio.contains("over 3 rounds") && ratio.contains("CPU f32 "), "{ratio}");

    let costs = common::json(&json);
    let costs = costs.as_array().unwrap();
    assert_eq!(costs.len(), 2);
    for (c, label) in costs.iter().zip(["line.ltc2017", "line.ltc2023"]) {
        assert_eq!(c["label"], label);
        assert_eq!(c["clock"], "gpu-timestamp");
        assert_eq!(c["configurations"], 1024);
        assert_eq!(c["repeats"], 3);
        let gpu = c["gpu_ns_per_eval"].as_array().unwrap();
        assert_eq!(gpu.len(), 3);
        assert!(
            gpu.iter().all(|t| t.as_f64().is_some_and(|t| t > 0.01 && t < 1e6)),
            "{c}"
        );
        // A time, not only a number: the CPU evaluator takes 200–250 ns per evaluation on this
        // machine (README); anything from 1 ns to 1 ms per evaluation is a plausible machine.
        let cpu = c["cpu_f32_ns_per_eval"].as_f64().unwrap_or(f64::NAN);
        assert!((1.0..1e6).contains(&cpu), "{c}");
        // The naga operation counts are 267 and 238 (README); a kernel change may move them
        // a little, an op count that lost or doubled the kernel may not.
        assert!(
            c["ops"]["total"].as_u64().is_some_and(|t| (150..400).contains(&t)),
            "{c}"
        );
    }
}

#[test]
fn bench_refuses_bad_input_before_measuring() {
    let o = linelight(&["bench", "--count", "64", "--methods", "line.nope"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("unknown method `line.nope`"), "{stderr}");

    // The line case samples no radius: a cylinder method cannot be timed on it.
    let dir = tempfile::tempdir().unwrap();
    let kernel = dir.path().join("cyl.wgsl");
    std::fs::write(
        &kernel,
        "//! id: user.cyl\n//! target: cylinder\nfn method(scene: Scene) -> f32 { return scene.radius; }\n",
    )
    .unwrap();
    let kernel = kernel.to_str().unwrap();
    let o = linelight(&["bench", "--count", "64", "--kernel", kernel, "--methods", "user.cyl"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("user.cyl (target cylinder) does not apply to 64 of case `line_fwt`'s configurations"),
        "{stderr}"
    );
    assert!(o.stdout.is_empty(), "nothing measured, nothing printed");

    let o = linelight(&["bench", "--repeats", "0"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--repeats must be at least 1"));
}

/// `bench --envelope N`: the envelope's ns per configuration per method beside the
/// CPU f32 column, in the same rounds, printed and in the JSON; without it, the JSON has no
/// envelope keys (a bench's output is unchanged).
#[test]
fn bench_times_the_envelope_beside_the_cpu_column() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("costs.json");
    let o = linelight(&[
        "bench",
        "--count",
        "512",
        "--repeats",
        "3",
        "--warmup",
        "0",
        "--methods",
        "line.ltc2017,line.ltc2023",
        "--envelope",
        "16",
        "--json",
        json.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        stdout.contains("Envelope (docs/envelope.md)") && stdout.contains("on 16 configurations"),
        "{stdout}"
    );
    for label in ["line.ltc2017", "line.ltc2023"] {
        let line = stdout
            .lines()
            .find(|l| l.trim_start().starts_with(&format!("{label}: ")))
            .unwrap_or_else(|| panic!("no envelope line for {label}:\n{stdout}"));
        assert!(
            line.contains("ns per configuration") && line.contains("× the CPU f32 column"),
            "{line}"
        );
    }
    let costs = common::json(&json);
    for c in costs.as_array().unwrap() {
        assert_eq!(c["envelope_configurations"], 16, "{c}");
        assert_eq!(
            c["envelope_ns_per_config_runs"].as_array().map(Vec::len),
            Some(3),
            "{c}"
        );
        let [median, min, max] = [0, 1, 2].map(|i| c["envelope_ns_per_config"][i].as_f64().unwrap());
        assert!(min <= median && median <= max, "{c}");
        // A time, not only a number: an interval walk per configuration of at least 1 ns and
        // at most a second.
        assert!((1.0..1e9).contains(&median), "{c}");
        assert!(c["envelope_over_cpu_f32"].as_f64().is_some_and(|r| r > 0.0), "{c}");
    }

    let o = linelight(&["bench", "--count", "64", "--repeats", "1", "--envelope", "65"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--envelope 65"));
    let o = linelight(&[
        "bench",
        "--count",
        "64",
        "--repeats",
        "1",
        "--methods",
        "line.ltc2017",
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(o.status.success());
    let text = std::fs::read_to_string(&json).unwrap();
    assert!(!text.contains("envelope"), "{text}");
}
