//! Promises of the README's exit table and docs/robustness.md that no other test kept: each
//! runs the CLI and asserts the exit code, the message, and that nothing outside the intended
//! files changed.

mod common;

use common::snapshot::{only_changed, snapshot};
use common::{stderr, write};
use std::path::Path;
use std::process::{Command, Output};

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Runs `linelight` with `env` set.
fn linelight_with(env: &[(&str, &str)], args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_linelight"))
        .args(args)
        .envs(env.iter().copied())
        .output()
        .expect("linelight runs")
}

const CONFIG: &str = r#"{"id":"a","p1":[0.3,-0.2,1.0],"p2":[0.9,0.4,1.6],"material":{"kind":"diffuse"}}"#;

const CASE: &str = r#"
name = "tiny"
title = "tiny"
seed = 7
methods = ["line.ltc2017", "line.numeric@16"]
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

/// The test-only hook in the GPU runner (src/measure/gpu/runner.rs): every dispatch after the
/// first N of the process fails as a lost device would. N = 1 lets the driver's loop-limit
/// probe through, so the first method's dispatch fails.
const FAIL_DISPATCH: &str = "LINELIGHT_TEST_FAIL_DISPATCH";

// ---------------------------------------------------------------------------------------------
// Messages stay bounded (README: "stays bounded in length"; app::bounded: 400 characters a
// line, 40 lines).

#[test]
fn bounded_cuts_long_lines_and_counts_the_lines_past_forty() {
    use linelight::app::bounded;
    let long = "é".repeat(1000);
    let out = bounded(&long);
    let first = out.lines().next().unwrap();
    assert_eq!(first.chars().filter(|&c| c == 'é').count(), 400, "{first}");
    // 600 two-byte characters left out.
    assert!(first.ends_with("… (1200 more bytes)"), "{first}");
    let many: Vec<String> = (0..50).map(|i| format!("line {i}")).collect();
    let out = bounded(&many.join("\n"));
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), 41, "{out}");
    assert_eq!(lines[39], "line 39");
    assert_eq!(lines[40], "… and 10 more lines");
    // Short messages pass unchanged.
    assert_eq!(bounded("a\nb"), "a\nb");
    let exact = "x".repeat(400);
    assert_eq!(bounded(&exact), exact);
}

#[test]
fn a_message_naming_a_huge_field_is_bounded_end_to_end() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    // An unknown field whose name is 100,000 characters: the error names it, and the
    // message is cut (an id that long is shortened by eval itself).
    let key = "k".repeat(100_000);
    let line = CONFIG.replace("\"id\":\"a\"", &format!("\"id\":\"a\",\"{key}\":1"));
    let input = write(d, "in.jsonl", &format!("{line}\n"));
    let before = snapshot(d);
    let o = linelight_with(
        &[],
        &["eval", "--input", s(&input), "--output", s(&d.join("out.jsonl"))],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("unknown field") && e.contains("more bytes)"),
        "not cut: {} bytes",
        e.len()
    );
    assert!(e.lines().count() <= 41, "{e}");
    for l in e.lines() {
        // 400 characters, the "error: " prefix and the "… (N more bytes)" suffix.
        assert!(
            l.chars().count() <= 400 + 7 + 30,
            "a line of {} characters",
            l.chars().count()
        );
    }
    only_changed(&before, &snapshot(d), &[]);
}

// ---------------------------------------------------------------------------------------------
// Exit 4: the GPU failed at run time, and nothing new is written.

#[test]
fn an_injected_dispatch_failure_ends_eval_with_exit_4_and_writes_nothing() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let input = write(d, "in.jsonl", &format!("{CONFIG}\n"));
    let output = write(d, "out.jsonl", "old\n");
    let before = snapshot(d);
    let args = [
        "eval",
        "--input",
        s(&input),
        "--output",
        s(&output),
        "--methods",
        "line.ltc2017",
    ];
    let o = linelight_with(&[(FAIL_DISPATCH, "1")], &args);
    assert_eq!(o.status.code(), Some(4), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("GPU run of line.ltc2017 failed") && e.contains(FAIL_DISPATCH),
        "{e}"
    );
    only_changed(&before, &snapshot(d), &[]);
    // The same command without the hook succeeds and replaces the output.
    let o = linelight_with(&[], &args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(std::fs::read_to_string(&output).unwrap().starts_with(r#"{"id":"a""#));
}

#[test]
fn an_injected_dispatch_failure_ends_a_sweep_with_exit_4_and_keeps_the_earlier_reports() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let case = write(d, "case.toml", CASE);
    let reports = d.join("reports");
    let raw = d.join("raw.jsonl");
    let args = ["sweep", s(&case), "--out", s(&reports), "--raw", s(&raw)];
    let o = linelight_with(&[], &args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(reports.join("tiny/report.md").is_file() && raw.is_file());
    let before = snapshot(d);
    // The first method's dispatch, and later the second's: either way exit 4, nothing touched.
    for n in ["1", "2"] {
        let o = linelight_with(&[(FAIL_DISPATCH, n)], &args);
        assert_eq!(o.status.code(), Some(4), "{n}: {}", stderr(&o));
        assert!(stderr(&o).contains("GPU run of"), "{}", stderr(&o));
        only_changed(&before, &snapshot(d), &[]);
    }
}

// ---------------------------------------------------------------------------------------------
// Exit 0 for the commands that only report.

#[test]
fn help_version_and_adapters_exit_0() {
    for args in [&["--help"][..], &["--version"], &["adapters"], &["sweep", "--help"]] {
        let o = linelight_with(&[], args);
        assert_eq!(o.status.code(), Some(0), "{args:?}: {}", stderr(&o));
        let out = String::from_utf8_lossy(&o.stdout);
        assert!(!out.trim().is_empty(), "{args:?} printed nothing");
    }
    let version = linelight_with(&[], &["--version"]);
    let v = String::from_utf8_lossy(&version.stdout);
    assert_eq!(v.trim(), format!("linelight {}", env!("CARGO_PKG_VERSION")));
    let adapters = linelight_with(&[], &["adapters"]);
    assert!(String::from_utf8_lossy(&adapters.stdout).contains("llvmpipe"));
}
