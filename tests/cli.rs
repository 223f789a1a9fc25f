//! The command line as a user meets it: bad input gets a clear message naming what and
//! where, a non-zero exit, and nothing written; good input gives reports and results.

use crate::common;
use common::case::{CROSSING, LENGTH_BINS, LTC_ALPHA};
use common::{case, eval, linelight, stderr, write};

/// Two methods compared on diffuse and LTC lights, one bin, and a tolerance that tests the
/// mechanism, not the method's quality: no NaN, nothing off by 100 %.
fn tiny() -> String {
    case("tiny")
        .methods(&["line.ltc2023", "line.ltc2017"])
        .compare("line.ltc2017", "line.ltc2023")
        .axis("elevation", CROSSING)
        .diffuse(300)
        .material("iso", "ltc_sparse", 300, LTC_ALPHA)
        .table(LENGTH_BINS)
        .table("[tolerances.\"line.ltc2023\"]\nmax = 1.0\nnan = 0")
        .to_string()
}

#[test]
fn sweep_writes_reports_and_a_verdict() {
    let dir = tempfile::tempdir().unwrap();
    let case = write(dir.path(), "tiny.toml", &tiny());
    let out = dir.path().join("reports");
    let raw = dir.path().join("raw.jsonl");
    let o = linelight(&[
        "sweep",
        case.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--raw",
        raw.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("verdict: PASS"), "{stdout}");
    assert!(stderr(&o).contains("adapter: "), "the adapter is printed");
    assert!(
        !stderr(&o).contains("XDG_RUNTIME_DIR"),
        "driver noise reached the user: {}",
        stderr(&o)
    );
    for f in ["report.md", "summary.json", "stats.csv", "comparisons.csv"] {
        assert!(out.join("tiny").join(f).is_file(), "{f} missing");
    }
    let report = std::fs::read_to_string(out.join("tiny/report.md")).unwrap();
    assert!(report.contains("**Verdict: PASS**") && report.contains("`line.ltc2017` against `line.ltc2023`"));
    // The natural sample, then the configurations drawn to fill thin bins, each marked.
    let rows: Vec<serde_json::Value> = std::fs::read_to_string(&raw)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let natural = rows
        .iter()
        .filter(|r| r["strata"].as_array().unwrap().is_empty())
        .count();
    assert_eq!(natural, 600);
    assert!(rows.len() > natural && report.contains("## Sampling"));
}

#[test]
fn failing_tolerance_gives_exit_1_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    // A tolerance no f32 evaluation can meet.
    let case = write(
        dir.path(),
        "strict.toml",
        &tiny().replace("max = 1.0\nnan = 0", "max = 1e-30\nnan = 0"),
    );
    let out = dir.path().join("reports");
    let o = linelight(&[
        "sweep",
        case.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--count",
        "50",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let report = std::fs::read_to_string(out.join("tiny/report.md")).unwrap();
    assert!(
        report.contains("**Verdict: FAIL**") && report.contains("FAIL `line.ltc2023` on `diffuse`: max rel. error"),
        "{report}"
    );
}

#[test]
fn malformed_case_file_names_file_and_line_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("reports");
    let case = write(
        dir.path(),
        "bad.toml",
        &tiny().replace("seed = 7", "seed = 7\nroughness = 0.5"),
    );
    let o = linelight(&["sweep", case.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(
        e.contains("bad.toml") && e.contains("roughness") && e.contains("line 4"),
        "{e}"
    );
    assert!(!out.exists(), "nothing may be written on bad input");

    let case = write(dir.path(), "broken.toml", "name = \"x\"\nseed = [\n");
    let o = linelight(&["sweep", case.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("broken.toml") && stderr(&o).contains("malformed"),
        "{}",
        stderr(&o)
    );

    let case = write(
        dir.path(),
        "unknown.toml",
        &tiny().replace("\"line.ltc2017\"]", "\"line.ltc2017\", \"line.ltc2099\"]"),
    );
    let o = linelight(&["sweep", case.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("unknown method `line.ltc2099`"), "{}", stderr(&o));
}

#[test]
fn kernel_with_wgsl_error_names_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let kernel = write(
        dir.path(),
        "broken.wgsl",
        "//! id: line.broken\n//! target: line\n\nfn method(scene: Scene) -> f32 {\n    let a = scene.p1;\n    let b = scene.p2;\n    return lenght(a - b);\n}\n",
    );
    let o = linelight(&["check", kernel.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(e.contains("broken.wgsl:7:"), "{e}");
    assert!(e.contains("lenght"), "{e}");

    // The same kernel through eval: refused before anything is written.
    let input = write(
        dir.path(),
        "in.jsonl",
        r#"{"id":"a","p1":[0,0,1],"p2":[1,0,1],"material":{"kind":"diffuse"}}"#,
    );
    let output = dir.path().join("out.jsonl");
    let o = eval(
        &input,
        &output,
        &["--kernel", kernel.to_str().unwrap(), "--methods", "line.broken"],
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("broken.wgsl:7:"), "{}", stderr(&o));
    assert!(!output.exists());
}

#[test]
fn eval_rejects_bad_lines_without_touching_the_output() {
    let dir = tempfile::tempdir().unwrap();
    let output = write(dir.path(), "out.jsonl", "previous results\n");
    let input = write(
        dir.path(),
        "in.jsonl",
        concat!(
            r#"{"id":"ok","p1":[0,0,1],"p2":[1,0,1],"material":{"kind":"diffuse"}}"#,
            "\n",
            r#"{"id":"typo","p1":[0,0,1],"p2":[1,0,1],"radus":0.1,"material":{"kind":"diffuse"}}"#,
            "\n",
            r#"{"id":"through","p1":[-1,0,0],"p2":[1,0,0],"material":{"kind":"diffuse"}}"#,
            "\n",
            r#"{"id":"tube","p1":[-1,0,0.05],"p2":[1,0,0.05],"radius":0.1,"material":{"kind":"diffuse"}}"#,
            "\n",
        ),
    );
    let o = eval(&input, &output, &[]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(e.contains("in.jsonl:2:") && e.contains("radus"), "{e}");
    assert!(e.contains("in.jsonl:3:") && e.contains("on the light segment"), "{e}");
    assert!(e.contains("in.jsonl:4:") && e.contains("inside the tube"), "{e}");
    assert_eq!(std::fs::read_to_string(&output).unwrap(), "previous results\n");
}

#[test]
fn eval_writes_nan_as_a_string_and_keeps_order() {
    let dir = tempfile::tempdir().unwrap();
    let kernel = write(
        dir.path(),
        "nan.wgsl",
        "//! id: line.nan\n//! target: line\nfn method(scene: Scene) -> f32 {\n    let z = scene.radius;\n    return z / z;\n}\n",
    );
    let input = write(
        dir.path(),
        "in.jsonl",
        concat!(
            r#"{"id":"b","p1":[0,0,1],"p2":[1,0,1],"material":{"kind":"diffuse"}}"#,
            "\n",
            r#"{"id":"a","p1":[0.3,-0.2,1.0],"p2":[0.9,0.4,1.6],"material":{"kind":"diffuse"}}"#,
            "\n",
        ),
    );
    let output = dir.path().join("out.jsonl");
    let o = eval(
        &input,
        &output,
        &[
            "--kernel",
            kernel.to_str().unwrap(),
            "--methods",
            "line.nan,line.ltc2023",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let rows: Vec<serde_json::Value> = std::fs::read_to_string(&output)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(rows.len(), 2);
    assert_eq!(rows[0]["id"], "b");
    assert_eq!(rows[0]["methods"]["line.nan"]["f32"], "NaN");
    // A user kernel gets its f64 and cpu_f32 values from the CPU evaluator too.
    assert_eq!(rows[0]["methods"]["line.nan"]["f64"], "NaN");
    assert_eq!(rows[0]["methods"]["line.nan"]["cpu_f32"], "NaN");
    // Values, not only their presence: the 2023 listing in f64 is the reference up to its
    // INV_PI (2.6e-10 relative), and the reference's error estimate is small and positive
    // (measured 1.9e-15 on a reference of 0.201).
    let reference = rows[1]["reference"]["line"].as_f64().unwrap();
    assert!((reference - 0.2010102516814).abs() < 1e-12, "{reference}");
    let f64_value = rows[1]["methods"]["line.ltc2023"]["f64"].as_f64().unwrap();
    assert!(
        (f64_value - reference).abs() <= 1e-9 * reference,
        "{f64_value} vs {reference}"
    );
    let error = rows[1]["reference_error"]["line"].as_f64().unwrap();
    assert!(error > 0.0 && error < 1e-12 * reference, "{error}");
}

#[test]
fn unknown_adapter_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let input = write(
        dir.path(),
        "in.jsonl",
        r#"{"id":"a","p1":[0,0,1],"p2":[1,0,1],"material":{"kind":"diffuse"}}"#,
    );
    let output = dir.path().join("out.jsonl");
    let o = eval(&input, &output, &["--adapter", "NoSuchGPU-42"]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(e.contains("NoSuchGPU-42") && e.contains("llvmpipe"), "{e}");
    assert!(!output.exists());
}

/// `linelight fit` off a terminal (stderr a pipe, as in a CI log) prints the plain progress
/// lines every long command prints; LINELIGHT_PROGRESS_SECONDS sets their interval, and a value
/// that is no interval is refused before any work.
#[test]
fn fit_prints_plain_progress_lines_off_a_terminal() {
    let t = tempfile::tempdir().unwrap();
    let table = t.path().join("t.csv");
    let run = |interval: &str| {
        std::process::Command::new(env!("CARGO_BIN_EXE_linelight"))
            .args(["fit", "--size", "3", "--out", table.to_str().unwrap()])
            .env("LINELIGHT_PROGRESS_SECONDS", interval)
            .output()
            .unwrap()
    };
    for bad in ["0", "-1", "NaN", "inf", "ten"] {
        let o = run(bad);
        assert_eq!(o.status.code(), Some(2), "{bad}: {}", stderr(&o));
        assert!(
            stderr(&o).contains(&format!("LINELIGHT_PROGRESS_SECONDS=`{bad}`")),
            "{}",
            stderr(&o)
        );
        assert!(!table.exists(), "refused before any work");
    }
    // Nine fits of about a quarter of a second each: lines every 20 ms.
    let o = run("0.02");
    assert!(o.status.success(), "{}", stderr(&o));
    let lines: Vec<&str> = std::str::from_utf8(&o.stderr)
        .unwrap()
        .lines()
        .filter(|l| l.starts_with("fit: ") && l.contains("/9 ("))
        .collect();
    assert!(!lines.is_empty(), "no plain progress line: {}", stderr(&o));
    assert!(table.is_file() && table.with_extension("run.json").is_file());
}
