//! The CI gate scenario (issue 12): a baseline saved from a user kernel; the same kernel
//! passes; the kernel with a cheaper polynomial atan fails with a JUnit failure naming it; an
//! improved kernel (the 2023 Fwt) passes and is reported improved. It runs through
//! `scripts/ci-gate`, the script the CI examples in docs/ci/ run, so they stay honest.

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

    // The 2023 Fwt (−d/(d²+l²), no cancellation for |l| ≫ d): improved, exit 0.
    let improved = variant(
        d,
        "improved.wgsl",
        "return l * l / (d * (d * d + l * l));",
        "return -d / (d * d + l * l);",
        "",
    );
    let o = gate(&[CASE, b, "--kernel", improved.to_str().unwrap()], d);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("gate: IMPROVED") && stdout.contains("error improved: my.line diffuse"),
        "{}",
        text(&o)
    );
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
