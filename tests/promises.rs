//! Promises of the README's exit table and docs/robustness.md that no other test kept: each
//! runs the CLI and asserts the exit code, the message, and that nothing outside the intended
//! files changed.

mod common;
use common::CONFIG;

use common::snapshot::{only_changed, s, snapshot};
use common::{stderr, write};
use std::process::{Command, Output};

/// Runs `linelight` with `env` set.
fn linelight_with(env: &[(&str, &str)], args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_linelight"))
        .args(args)
        .envs(env.iter().copied())
        .output()
        .expect("linelight runs")
}

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

// ---------------------------------------------------------------------------------------------
// Exit 2: an I/O failure while writing, bad case values, numbers past 2^60, many bad lines.

#[test]
fn an_io_failure_while_writing_is_exit_2_naming_the_file() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let input = write(d, "in.jsonl", &format!("{CONFIG}\n"));
    let before = snapshot(d);
    // /dev/full accepts the open and fails every write (ENOSPC): a device is written through.
    let o = linelight_with(
        &[],
        &[
            "eval",
            "--input",
            s(&input),
            "--output",
            "/dev/full",
            "--methods",
            "line.ltc2017",
        ],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("cannot write /dev/full") && stderr(&o).contains("No space left"),
        "{}",
        stderr(&o)
    );
    only_changed(&before, &snapshot(d), &[]);
}

#[test]
fn case_values_are_checked_naming_the_key_and_the_value() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let ltc = |aspect: &str, peak: &str| {
        format!(
            "{CASE}[[materials]]\nname = \"l\"\nkind = \"ltc_full\"\ncount = 5\n\
             alpha = {{ dist = \"fixed\", value = 0.3 }}\naspect = {aspect}\npeak = {peak}\n\
             shear = {{ dist = \"fixed\", value = 0.0 }}\nrotation = {{ dist = \"fixed\", value = 0.0 }}\n"
        )
    };
    let fixed = |v: &str| format!("{{ dist = \"fixed\", value = {v} }}");
    let two = CASE.replace(
        "methods = [\"line.ltc2017\", \"line.numeric@16\"]",
        "methods = [\"line.ltc2017\", \"line.numeric@16\"]\ncompare = [[\"line.ltc2017\", \"line.numeric@16\"]]",
    );
    let cases = [
        (
            ltc(&fixed("0.0"), &fixed("0.0")),
            "`materials[1].aspect` = fixed 0: must draw only values > 0",
        ),
        (
            ltc(&fixed("1.0"), "{ dist = \"uniform\", min = -90.0, max = 10.0 }"),
            "`materials[1].peak` = uniform [-90, 10]: the lobe's peak must stay within (-90, 90)",
        ),
        (
            CASE.replace(
                "center = ",
                "rect_width = { dist = \"uniform\", min = -0.1, max = 0.1 }\ncenter = ",
            ),
            "`geometry.rect_width` = uniform [-0.1, 0.1]: must draw only values > 0",
        ),
        (
            format!("{CASE}[search]\nmethods = [\"line.ltc2017\"]\nrestarts = 1\nsteps = 20000\npopulation = 2\n"),
            "`search.steps` = 20000: at most 10000",
        ),
        (
            format!("{CASE}[search]\nmethods = [\"line.ltc2017\"]\nrestarts = 1\nsteps = 2\npopulation = 0\n"),
            "`search.restarts` = 1, `search.population` = 0: both must be at least 1",
        ),
        (
            format!("{two}[disagreements]\nepsilon = 0.0\n"),
            "`disagreements.epsilon` = 0: the smallest error a ratio divides by must be a finite number > 0",
        ),
        (
            CASE.replace(
                "methods = [\"line.ltc2017\", \"line.numeric@16\"]",
                "methods = [\"line.ltc2017\", \"line.numeric@16\"]\ncompare = [[\"line.ltc2017\", \"line.ltc2017\"]]",
            ),
            "`compare[0]` = [\"line.ltc2017\", \"line.ltc2017\"]: a method compared with itself",
        ),
    ];
    for (case, what) in cases {
        let path = write(d, "case.toml", &case);
        let before = snapshot(d);
        let o = linelight_with(&[], &["sweep", s(&path), "--out", s(&d.join("reports"))]);
        assert_eq!(o.status.code(), Some(2), "{what}: {}", stderr(&o));
        assert!(
            stderr(&o).contains(&format!("case.toml: {what}")),
            "{what}: {}",
            stderr(&o)
        );
        only_changed(&before, &snapshot(d), &[]);
    }
    assert!(!d.join("reports").exists());
}

#[test]
fn radius_and_width_past_2_to_the_60_are_refused_naming_the_value() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let limit = 2f64.powi(60);
    for (field, name) in [
        (r#""radius":1e19,"#, "radius = 1e19"),
        (r#""rect":{"normal":[0,0,1],"width":1e19},"#, "rect.width = 1e19"),
    ] {
        let line = CONFIG.replace("\"material\"", &format!("{field}\"material\""));
        let input = write(d, "in.jsonl", &format!("{line}\n"));
        let before = snapshot(d);
        let o = linelight_with(
            &[],
            &["eval", "--input", s(&input), "--output", s(&d.join("out.jsonl"))],
        );
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(
            stderr(&o).contains(&format!("{name} exceeds {limit:e}")),
            "{}",
            stderr(&o)
        );
        only_changed(&before, &snapshot(d), &[]);
    }
    // Just below the limit is a configuration like any other.
    let line = CONFIG.replace("\"material\"", r#""radius":1e-3,"material""#);
    let input = write(d, "in.jsonl", &format!("{line}\n"));
    let o = linelight_with(
        &[],
        &[
            "eval",
            "--input",
            s(&input),
            "--output",
            s(&d.join("out.jsonl")),
            "--methods",
            "caps.point",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

#[test]
fn at_most_20_bad_eval_lines_are_listed_then_counted() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let lines: String = (0..25)
        .map(|i| format!("{{\"id\":\"b{i}\",\"p1\":[0,0,1],\"p2\":[0,0,1],\"material\":{{\"kind\":\"diffuse\"}}}}\n"))
        .collect();
    let input = write(d, "in.jsonl", &lines);
    let before = snapshot(d);
    let o = linelight_with(
        &[],
        &["eval", "--input", s(&input), "--output", s(&d.join("out.jsonl"))],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains("error: 25 bad line(s) in "), "{e}");
    let listed = e.lines().filter(|l| l.contains("is degenerate")).count();
    assert_eq!(listed, 20, "{e}");
    assert!(
        e.contains("in.jsonl:20: configuration `b19`") && !e.contains("`b20`"),
        "{e}"
    );
    assert!(e.trim_end().ends_with("… and 5 more"), "{e}");
    only_changed(&before, &snapshot(d), &[]);
}

// ---------------------------------------------------------------------------------------------
// What a sweep writes on exits 1 and 3; outputs that are directories or inputs; permissions.

#[test]
fn raw_is_written_on_exit_1_and_on_exit_3() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let failing_tolerance = format!("{CASE}[tolerances.\"line.ltc2017\"]\np99 = 1e-12\n");
    let stale_claim = format!(
        "{CASE}[[claims]]\nid = \"never\"\nexpect = 'p99(\"line.ltc2017\", \"diffuse\") < 1e-12'\ntext = \"never\"\n"
    );
    for (case, code) in [(failing_tolerance, 1), (stale_claim, 3)] {
        let path = write(d, "case.toml", &case);
        let raw = d.join(format!("raw{code}.jsonl"));
        let o = linelight_with(
            &[],
            &["sweep", s(&path), "--out", s(&d.join("reports")), "--raw", s(&raw)],
        );
        assert_eq!(o.status.code(), Some(code), "{}", stderr(&o));
        // 20 configurations, one line each, with both methods' values.
        let text = std::fs::read_to_string(&raw).unwrap_or_default();
        assert_eq!(
            text.lines().count(),
            20,
            "exit {code}: --raw has {} lines",
            text.lines().count()
        );
        assert!(
            text.contains("line.ltc2017") && text.contains("line.numeric@16"),
            "exit {code}"
        );
        assert!(d.join("reports/tiny/report.md").is_file(), "exit {code}: no report");
    }
}

#[test]
fn outputs_that_are_directories_or_inputs_are_refused_and_permissions_are_kept() {
    use std::os::unix::fs::PermissionsExt;
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let input = write(d, "in.jsonl", &format!("{CONFIG}\n"));
    let kernel = write(
        d,
        "k.wgsl",
        "//! id: user.k\n//! target: line\nfn method(scene: Scene) -> f32 { return scene.p1.z; }\n",
    );
    std::fs::create_dir(d.join("dir")).unwrap();
    let before = snapshot(d);
    for (output, what) in [(d.join("dir"), "directory"), (kernel.clone(), "same file as --kernel")] {
        let o = linelight_with(
            &[],
            &[
                "eval",
                "--input",
                s(&input),
                "--output",
                s(&output),
                "--kernel",
                s(&kernel),
                "--methods",
                "user.k",
            ],
        );
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(stderr(&o).contains(what), "`{what}` not in {}", stderr(&o));
        only_changed(&before, &snapshot(d), &[]);
    }
    // An output replaced keeps its permission bits.
    let output = write(d, "out.jsonl", "old\n");
    std::fs::set_permissions(&output, std::fs::Permissions::from_mode(0o640)).unwrap();
    let o = linelight_with(
        &[],
        &[
            "eval",
            "--input",
            s(&input),
            "--output",
            s(&output),
            "--methods",
            "line.ltc2017",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let mode = std::fs::metadata(&output).unwrap().permissions().mode() & 0o7777;
    assert_eq!(mode, 0o640, "{mode:o}");
    assert!(std::fs::read_to_string(&output).unwrap().starts_with(r#"{"id":"a""#));
}

#[test]
fn a_killed_sweep_leaves_the_earlier_outputs_whole() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let case = write(d, "case.toml", CASE);
    let reports = d.join("reports");
    let raw = d.join("raw.jsonl");
    let args = ["sweep", s(&case), "--out", s(&reports), "--raw", s(&raw)];
    let o = linelight_with(&[], &args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let before = snapshot(d);
    // Killed at several points of a longer run (its count, not the case, makes it longer):
    // whatever it had done, the earlier report set and --raw are as they were. A killed run
    // may leave its temporaries (`.<name>.tmp-<pid>`), which the next run removes.
    for ms in [50, 300, 1000] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_linelight"))
            .args(args)
            .args(["--count", "200000"])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(std::time::Duration::from_millis(ms));
        child.kill().unwrap();
        child.wait().unwrap();
        let after: std::collections::BTreeMap<_, _> = snapshot(d)
            .into_iter()
            .filter(|(p, _)| {
                !p.components()
                    .any(|c| c.as_os_str().to_string_lossy().contains(".tmp-"))
            })
            .collect();
        only_changed(&before, &after, &[]);
    }
    // The next run cleans up and writes its set.
    let o = linelight_with(&[], &args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let left: Vec<_> = snapshot(d)
        .into_keys()
        .filter(|p| p.to_string_lossy().contains(".tmp-"))
        .collect();
    assert!(left.is_empty(), "temporaries left: {left:?}");
}
