//! The CI gate scenario: a baseline saved from a user kernel; the same kernel
//! passes; the kernel with a cheaper polynomial atan fails with a JUnit failure naming it; the
//! 2023 Fwt improves the error's geometric mean but is worse on a tenth of the configurations,
//! which the share rule fails. It runs through `scripts/ci-gate`, the script the CI
//! examples in docs/ci/ run, so they stay honest. Every JUnit file is validated against the
//! Ant JUnit schema (tests/data/junit/).

use crate::common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const CASE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/ci/example/gate.toml");
const KERNEL: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/ci/example/my_line.wgsl");

fn gate(args: &[&str], dir: &Path) -> Output {
    Command::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scripts/ci-gate"))
        .args(args)
        .env("LINELIGHT", env!("CARGO_BIN_EXE_linelight"))
        .env("JUNIT", dir.join("junit.xml"))
        .env("OUT", dir.join("reports"))
        .output()
        .expect("scripts/ci-gate runs")
}

use common::validate_junit;

fn text(o: &Output) -> String {
    format!(
        "exit {:?}\nstdout:\n{}\nstderr:\n{}",
        o.status.code(),
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// The example kernel with one edit (same id: a new revision of the same file).
fn variant(dir: &Path, name: &str, from: &str, to: &str, append: &str) -> PathBuf {
    let base = std::fs::read_to_string(KERNEL).unwrap();
    assert!(base.contains(from), "{from}");
    let path = dir.join(name);
    std::fs::write(&path, base.replace(from, to) + append).unwrap();
    path
}

const FAST_ATAN: &str = "
// A cheaper atan: Rajan, Wang, Inkol & Joyal 2006 (max error about 1.5e-3 rad) on [-1, 1],
// with atan(x) = sign(x) (pi/2 - atan(1/|x|)) outside.
fn fast_atan(x: f32) -> f32 {
    let a = abs(x);
    let t = select(a, 1.0 / a, a > 1.0);
    let p = 0.25 * PI * t - t * (t - 1.0) * (0.2447 + 0.0663 * t);
    return sign(x) * select(p, 0.5 * PI - p, a > 1.0);
}
";

#[test]
fn gate_scenario_same_passes_cheaper_atan_fails_improved_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let baseline = d.join("baseline");
    let b = baseline.to_str().unwrap();

    // The case lists only a built-in: `--kernel` adds the user's method beside it.
    let o = gate(&["--save", CASE, b, "--kernel", KERNEL], d);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let json = std::fs::read_to_string(baseline.join("baseline.json")).unwrap();
    assert!(
        json.contains("\"label\": \"my.line\"") && json.contains("llvmpipe"),
        "{json}"
    );
    // Saved again, the gated files are the same bytes (diff-friendly); only timings.json,
    // which is reported and never gated, may change.
    let again = d.join("again");
    let o = gate(&["--save", CASE, again.to_str().unwrap(), "--kernel", KERNEL], d);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert_eq!(json, std::fs::read_to_string(again.join("baseline.json")).unwrap());
    for f in ["errors/my.line/diffuse.txt", "errors/line.ltc2023_fix/diffuse.txt"] {
        assert_eq!(
            std::fs::read(baseline.join(f)).unwrap(),
            std::fs::read(again.join(f)).unwrap(),
            "{f}"
        );
    }
    assert!(!json.contains("ns_per_eval"), "{json}");
    let timings = std::fs::read_to_string(baseline.join("timings.json")).unwrap();
    assert!(timings.contains("my.line"), "{timings}");
    // minv: none: the diffuse errors are saved, the LTC material is unsupported.
    assert!(baseline.join("errors/my.line/diffuse.txt").is_file());
    assert!(!baseline.join("errors/my.line/ggx_iso.txt").exists());

    // The same kernel: unchanged, exit 0.
    let o = gate(&[CASE, b, "--kernel", KERNEL], d);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(
        String::from_utf8_lossy(&o.stdout).contains("gate: UNCHANGED"),
        "{}",
        text(&o)
    );

    // A cheaper polynomial atan: its error regresses, exit 1, a JUnit failure names it.
    let cheap = variant(d, "cheap.wgsl", "atan(l / d)", "fast_atan(l / d)", FAST_ATAN);
    let o = gate(&[CASE, b, "--kernel", cheap.to_str().unwrap()], d);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("gate: REGRESSED") && stdout.contains("my.line diffuse error"),
        "{}",
        text(&o)
    );
    validate_junit(&d.join("junit.xml"));
    let junit = std::fs::read_to_string(d.join("junit.xml")).unwrap();
    let failure = junit
        .split("<testcase ")
        .find(|t| t.contains("name=\"my.line / diffuse / error\""))
        .unwrap_or_else(|| panic!("no testcase for my.line / diffuse / error:\n{junit}"));
    assert!(
        failure.contains("<failure") && failure.contains("REGRESSED my.line on diffuse [error]"),
        "{failure}"
    );
    // The built-in beside it did not change, and its testcase passes.
    let builtin = junit
        .split("<testcase ")
        .find(|t| t.contains("name=\"line.ltc2023_fix / diffuse / error\""))
        .unwrap();
    assert!(!builtin.contains("<failure"), "{builtin}");

    // The 2023 Fwt (−d/(d²+l²), no cancellation for |l| ≫ d): its error's geometric mean
    // improves, but short lines lose to the cancellation of −d/(d²+l²) − (−d/(d²+l²)) near
    // the foot: worse on about a tenth of the configurations, so the share rule fails it.
    let improved = variant(
        d,
        "improved.wgsl",
        "return l * l / (d * (d * d + l * l));",
        "return -d / (d * d + l * l);",
        "",
    );
    let o = gate(&[CASE, b, "--kernel", improved.to_str().unwrap()], d);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("gate: REGRESSED")
            && stdout.contains("regressed: my.line diffuse share")
            && stdout.contains("error improved: my.line diffuse"),
        "{}",
        text(&o)
    );
    // With a looser allowed share (20 %) it passes as improved.
    let o = gate(
        &[CASE, b, "--kernel", improved.to_str().unwrap(), "--worse-share", "0.2"],
        d,
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(
        String::from_utf8_lossy(&o.stdout).contains("gate: IMPROVED"),
        "{}",
        text(&o)
    );
    validate_junit(&d.join("junit.xml"));
}

/// The kernel's last line, `return I / PI;`, replaced.
fn with_result(dir: &Path, name: &str, result: &str) -> PathBuf {
    variant(dir, name, "    return I / PI;", result, "")
}

#[test]
fn a_better_p99_does_not_hide_a_large_share_that_got_worse() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let baseline = d.join("baseline");
    let b = baseline.to_str().unwrap();
    // The baseline: the kernel ×1000 on its longest lines (clipped length > 30, a few % of the
    // configurations: a heavy tail), and 1e-3 too bright where p1.x > 0.
    let tail = with_result(
        d,
        "tail.wgsl",
        "    return select(I / PI, 1000.0 * I / PI, l2 - l1 > 30.0) * select(1.0, 1.001, p1_in.x > 0.0);",
    );
    let o = gate(&["--save", CASE, b, "--kernel", tail.to_str().unwrap()], d);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    // The change: the tail fixed, and the bias moved to p1.y > 0. p99 and the geometric mean
    // improve; the fifth of the configurations with p1.y > 0 ≥ p1.x gets worse.
    let biased = with_result(
        d,
        "biased.wgsl",
        "    return I / PI * select(1.0, 1.001, p1_in.y > 0.0);",
    );
    let o = gate(&[CASE, b, "--kernel", biased.to_str().unwrap()], d);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let stderr = String::from_utf8_lossy(&o.stderr);
    let rule = |name: &str| {
        stderr
            .lines()
            .find(|l| l.contains(&format!("my.line on diffuse [{name}]")))
            .unwrap_or_else(|| panic!("no {name} rule:\n{}", text(&o)))
            .to_string()
    };
    // The quantile rule alone would pass it as improved: p99 is far lower.
    let error = rule("error");
    assert!(error.trim_start().starts_with("improved"), "{error}");
    let p99: f64 = error
        .split("p99 ×")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("{error}"));
    assert!(p99 < 0.5, "p99 improves: {error}");
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("regressed: my.line diffuse share") && stdout.contains("error improved: my.line diffuse"),
        "{}",
        text(&o)
    );
    // The share rule fails it, naming the material and bins beyond the allowed share.
    let share = rule("share");
    assert!(share.trim_start().starts_with("regressed"), "{share}");
    let worse: usize = share
        .split("worse on ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("{share}"));
    assert!(worse > 200, "{share}");
    assert!(share.contains("beyond it: all"), "{share}");
    // The report says so, and the worse configurations replay through eval.
    let report = std::fs::read_to_string(d.join("reports/gate/report.md")).unwrap();
    assert!(
        report.contains("## Against the baseline") && report.contains("| my.line | diffuse | share | **regressed** |"),
        "{report}"
    );
    let replay = d.join("reports/gate/regressed.jsonl");
    let lines = std::fs::read_to_string(&replay).unwrap();
    // Exactly the worse ones (no NaN or false light here), each once.
    assert_eq!(lines.lines().count(), worse, "{share}");
    let out = d.join("replayed.jsonl");
    let o = Command::new(env!("CARGO_BIN_EXE_linelight"))
        .args(["eval", "--methods", "my.line", "--kernel"])
        .arg(&biased)
        .arg("--input")
        .arg(&replay)
        .arg("--output")
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert_eq!(std::fs::read_to_string(&out).unwrap().lines().count(), worse);
    validate_junit(&d.join("junit.xml"));
    let junit = std::fs::read_to_string(d.join("junit.xml")).unwrap();
    assert!(junit.contains("REGRESSED my.line on diffuse [share]"), "{junit}");
}

#[test]
fn ci_gate_writes_only_where_told() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let baseline = tempfile::tempdir().unwrap();
    let b = baseline.path().join("b");
    // Run from an empty "engine" folder with neither JUNIT nor OUT: nothing appears there.
    let run = |args: &[&str]| {
        Command::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scripts/ci-gate"))
            .args(args)
            .current_dir(d)
            .env("LINELIGHT", env!("CARGO_BIN_EXE_linelight"))
            .env_remove("JUNIT")
            .env_remove("OUT")
            .output()
            .unwrap()
    };
    let o = run(&[
        "--save",
        CASE,
        b.to_str().unwrap(),
        "--kernel",
        KERNEL,
        "--count",
        "200",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let o = run(&[CASE, b.to_str().unwrap(), "--kernel", KERNEL, "--count", "200"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("OUT is not set"),
        "{}",
        text(&o)
    );
    let left: Vec<_> = std::fs::read_dir(d).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert!(left.is_empty(), "ci-gate left {left:?} in the working folder");
}

#[test]
fn baseline_from_other_configurations_is_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let baseline = d.join("baseline");
    let b = baseline.to_str().unwrap();
    let o = gate(&["--save", CASE, b, "--count", "100"], d);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    std::fs::remove_file(d.join("junit.xml")).unwrap();
    // Unpaired: another --count. Exit 2, the message names the baseline, nothing written.
    let o = gate(&[CASE, b, "--count", "200"], d);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("baseline.json") && err.contains("paired"), "{err}");
    assert!(!d.join("junit.xml").exists());
    // A baseline of another format version is refused with the command that saves it again;
    // one saved before the surface views and f32-input references (format 1), or before the
    // per-configuration streams (format 2), says why.
    let json_path = baseline.join("baseline.json");
    let json = std::fs::read_to_string(&json_path).unwrap();
    assert!(json.contains("\"format\": 3,"), "{json}");
    for old in [0, 1, 2] {
        std::fs::write(
            &json_path,
            json.replace("\"format\": 3,", &format!("\"format\": {old},")),
        )
        .unwrap();
        let o = gate(&[CASE, b, "--count", "100"], d);
        assert_eq!(o.status.code(), Some(2), "{}", text(&o));
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            err.contains(&format!("baseline format {old}"))
                && err.contains("what the surface receives")
                && err.contains("f32-rounded inputs")
                && err.contains("counter-based stream")
                && err.contains("save it again")
                && err.contains("--save-baseline"),
            "{err}"
        );
        assert!(!d.join("junit.xml").exists());
    }
    std::fs::write(&json_path, json).unwrap();
    // A corrupt errors file names its file and line.
    let file = baseline.join("errors/line.ltc2023_fix/diffuse.txt");
    let t = std::fs::read_to_string(&file).unwrap().replacen('\n', "\nbogus\n", 1);
    std::fs::write(&file, t).unwrap();
    let o = gate(&[CASE, b, "--count", "100"], d);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("diffuse.txt:2: `bogus`"),
        "{}",
        text(&o)
    );
}

/// The `scripts/ci-gate …` command of a CI example (the line after `# linelight-gate:`).
fn workflow_command(file: &str) -> Vec<String> {
    let text = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join(file)).unwrap();
    let line = text
        .lines()
        .skip_while(|l| !l.contains("# linelight-gate:"))
        .nth(1)
        .unwrap_or_else(|| panic!("{file}: no line after `# linelight-gate:`"));
    let command = line.trim().trim_start_matches("- ").trim_start_matches("run: ");
    let words = shell_words::split(command).unwrap();
    assert_eq!(words[0], "scripts/ci-gate", "{file}: {line}");
    words
}

#[test]
fn ci_examples_run_the_gate_on_the_committed_baseline() {
    let github = workflow_command("docs/ci/github-actions.yml");
    assert_eq!(
        github,
        workflow_command("docs/ci/gitlab-ci.yml"),
        "the two CI examples differ"
    );
    let dir = tempfile::tempdir().unwrap();
    let o = Command::new(&github[0])
        .args(&github[1..])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("LINELIGHT", env!("CARGO_BIN_EXE_linelight"))
        .env("JUNIT", dir.path().join("junit.xml"))
        .env("OUT", dir.path().join("reports"))
        .output()
        .unwrap();
    // The committed example baseline matches the committed example kernel.
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.lines().any(|l| l.starts_with("gate: UNCHANGED")), "{}", text(&o));
    assert!(dir.path().join("junit.xml").is_file());
}

#[test]
fn diff_two_revisions_of_one_kernel_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let improved = variant(
        d,
        "improved.wgsl",
        "return l * l / (d * (d * d + l * l));",
        "return -d / (d * d + l * l);",
        "",
    );
    let replay = d.join("disagreements.jsonl");
    let o = Command::new(env!("CARGO_BIN_EXE_linelight"))
        .args(["diff", CASE, KERNEL, improved.to_str().unwrap()])
        .arg("--output")
        .arg(&replay)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("A worse on diffuse") && stdout.contains("B worse on diffuse"),
        "{}",
        text(&o)
    );
    assert!(stdout.contains("ggx_iso: not compared"), "{}", text(&o));
    // As the gate found: the 2023 Fwt is the more accurate revision.
    assert_eq!(
        stdout.lines().last(),
        Some("verdict: B is more accurate than A"),
        "{}",
        text(&o)
    );
    // The disagreements replay through eval.
    let out = d.join("replayed.jsonl");
    let o = Command::new(env!("CARGO_BIN_EXE_linelight"))
        .args(["eval", "--methods", "line.ltc2017"])
        .arg("--input")
        .arg(&replay)
        .arg("--output")
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    // The other way round B is the less accurate revision: a regression, exit 1 as the gate's.
    let o = Command::new(env!("CARGO_BIN_EXE_linelight"))
        .args(["diff", CASE, improved.to_str().unwrap(), KERNEL])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert_eq!(
        String::from_utf8_lossy(&o.stdout).lines().last(),
        Some("verdict: B is less accurate than A"),
        "{}",
        text(&o)
    );
    // The same file twice is bad input.
    let o = Command::new(env!("CARGO_BIN_EXE_linelight"))
        .args(["diff", CASE, KERNEL, KERNEL])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
}

/// A baseline saved from other configurations (another sampling scheme, say) is refused with
/// exit 2 before any report is written: the comparison pairs configuration by configuration.
#[test]
fn a_baseline_of_other_configurations_is_refused_before_any_report() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().unwrap();
    let baseline = dir.path().join("baseline");
    std::fs::create_dir_all(baseline.join("errors")).unwrap();
    let from = root.join("docs/ci/example/baseline");
    for entry in walk(&from) {
        let rel = entry.strip_prefix(&from).unwrap();
        std::fs::create_dir_all(baseline.join(rel).parent().unwrap()).unwrap();
        std::fs::copy(&entry, baseline.join(rel)).unwrap();
    }
    let json = std::fs::read_to_string(baseline.join("baseline.json")).unwrap();
    let mut value: serde_json::Value = serde_json::from_str(&json).unwrap();
    let saved = value["sample_sha256"]
        .as_str()
        .expect("a format-3 baseline records its sample")
        .to_string();
    assert_eq!(saved.len(), 64, "{saved}");
    value["sample_sha256"] = serde_json::Value::String("0".repeat(64));
    std::fs::write(
        baseline.join("baseline.json"),
        serde_json::to_string_pretty(&value).unwrap(),
    )
    .unwrap();
    let out = dir.path().join("reports");
    let o = Command::new(env!("CARGO_BIN_EXE_linelight"))
        .args([
            "sweep",
            "docs/ci/example/gate.toml",
            "--kernel",
            "docs/ci/example/my_line.wgsl",
            "--baseline",
        ])
        .arg(&baseline)
        .arg("--out")
        .arg(&out)
        .current_dir(root)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("saved from other configurations") && stderr.contains(&saved),
        "{}",
        text(&o)
    );
    assert!(!out.exists(), "a report was written before the refusal");
}

fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else {
            out.push(p);
        }
    }
    out
}
