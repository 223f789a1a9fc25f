//! Every path bounded and checked before any work: claim expressions run under operation and
//! size limits, a claim on a bin that does not exist is bad input.

use crate::common;
use common::{stderr, sweep, CASE};
use std::time::{Duration, Instant};

/// `CASE` with one `[[bins]]` axis and the claim `expect` (id `id`).
fn with_claim(id: &str, expect: &str) -> String {
    format!(
        "{CASE}\n[[bins]]\naxis = \"elevation\"\nedges = [10.0, 45.0, 90.0]\n\n[[claims]]\nid = \"{id}\"\nexpect = '{expect}'\ntext = \"t\"\n"
    )
}

#[test]
fn a_claim_that_loops_or_builds_a_huge_string_is_bad_input_naming_it() {
    for (id, expect, limit) in [
        ("spins", "(|| loop { 1 }).call()", "operations"),
        ("grows", r#""x".pad(2000000000, "y") == """#, "bytes"),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let t = Instant::now();
        let o = sweep(dir.path(), &with_claim(id, expect), &[]);
        assert!(
            t.elapsed() < Duration::from_secs(30),
            "{id}: stopped in {:?}",
            t.elapsed()
        );
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{id}: {e}");
        assert!(e.contains(&format!("claim `{id}`")) && e.contains(limit), "{id}: {e}");
        assert!(!dir.path().join("reports").exists(), "{id}: nothing is written");
    }
}

#[test]
fn a_claim_on_a_bin_lower_edge_that_does_not_exist_is_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    // 90 is the axis's upper edge, not a bin's lower edge; 30 is no edge at all.
    for lo in ["30.0", "90.0"] {
        let expect = format!(r#"bin_p99("line.ltc2023", "diffuse", "elevation", {lo}) < 1.0"#);
        let o = sweep(dir.path(), &with_claim("edge", &expect), &[]);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{lo}: {e}");
        assert!(
            e.contains("claim `edge`") && e.contains("lower edge") && e.contains("10, 45"),
            "{lo}: {e}"
        );
    }
    // An edge that exists is measured (the claim holds or is stale, never bad input).
    let expect = r#"bin_count("line.ltc2023", "diffuse", "elevation", 45.0) >= 0.0"#;
    let o = sweep(dir.path(), &with_claim("edge", expect), &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

/// Every file of a report folder, by name, with its bytes, and the folder's inode (a set
/// swapped in is a new folder).
fn snapshot(dir: &std::path::Path) -> (u64, Vec<(String, Vec<u8>)>) {
    use std::os::unix::fs::MetadataExt;
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            (
                e.file_name().into_string().unwrap(),
                std::fs::read(e.path()).unwrap_or_default(),
            )
        })
        .collect();
    files.sort();
    (std::fs::metadata(dir).unwrap().ino(), files)
}

#[test]
fn an_output_that_cannot_be_a_file_is_refused_before_any_work_and_any_swap() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let o = sweep(d, CASE, &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let set = d.join("reports/tiny");
    let before = snapshot(&set);
    std::fs::create_dir(d.join("existing")).unwrap();
    let raw_dir = d.join("raw_out/");
    let existing = d.join("existing");
    let dot = d.join("existing/.");
    for (flag, path) in [
        ("--raw", format!("{}/", d.join("raw_out").display())),
        ("--junit", format!("{}/", d.join("junit_out").display())),
        ("--raw", existing.display().to_string()),
        ("--junit", dot.display().to_string()),
        // A parent that cannot be made: the case file stands where a folder would be.
        ("--raw", d.join("case.toml/raw.jsonl").display().to_string()),
    ] {
        let o = sweep(d, CASE, &[flag, &path]);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{flag} {path}: {e}");
        assert!(
            e.contains(&format!("{flag} {path}")) && e.contains("directory"),
            "{flag} {path}: {e}"
        );
        assert!(!e.contains("adapter"), "refused before any work: {e}");
        assert_eq!(snapshot(&set), before, "{flag} {path}: the old report set is untouched");
    }
    assert!(!raw_dir.exists() && !d.join("junit_out").exists());
    // eval refuses the same before it evaluates anything.
    let input = common::write(d, "in.jsonl", &format!("{}\n", common::CONFIG));
    let out = format!("{}/", d.join("eval_out").display());
    let o = common::eval(&input, std::path::Path::new(&out), &["--methods", "line.ltc2023"]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains(&format!("--output {out}")) && e.contains("directory"), "{e}");
    assert!(!d.join("eval_out").exists());
}

#[test]
fn a_quantile_of_one_configuration_gives_no_verdict_not_a_pass() {
    let one = CASE.replace("count = 20", "count = 1");
    // A p99 limit that passes and one that fails alike give no verdict from one configuration.
    for limit in ["1e6", "1e-12"] {
        let dir = tempfile::tempdir().unwrap();
        let case = format!("{one}\n[tolerances.\"line.ltc2023\"]\np99 = {limit}\n");
        let o = sweep(dir.path(), &case, &[]);
        let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
        assert_eq!(o.status.code(), Some(0), "p99 = {limit}: {stdout}{}", stderr(&o));
        assert!(
            stdout.contains("verdict: no verdict") && !stdout.contains("PASS") && !stdout.contains("FAIL"),
            "p99 = {limit}: {stdout}"
        );
        assert!(
            stdout.contains("from 1 configurations, fewer than the 300"),
            "p99 = {limit}: {stdout}"
        );
        let report = std::fs::read_to_string(dir.path().join("reports/tiny/report.md")).unwrap();
        assert!(
            report.contains("**No verdict**") && report.contains("NO VERDICT `line.ltc2023` on `diffuse`"),
            "{report}"
        );
        let summary = common::json(&dir.path().join("reports/tiny/summary.json"));
        assert_eq!(summary["analysis"]["verdict"], "no_verdict");
    }
    // A maximum is what was seen, judged from any number: one configuration fails it.
    let dir = tempfile::tempdir().unwrap();
    let o = sweep(
        dir.path(),
        &format!("{one}\n[tolerances.\"line.ltc2023\"]\nmax = 1e-12\n"),
        &[],
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
}

#[test]
fn diff_of_one_configuration_gives_no_verdict_and_no_interval() {
    let dir = tempfile::tempdir().unwrap();
    let case = common::write(dir.path(), "case.toml", CASE);
    let o = common::linelight(&[
        "diff",
        case.to_str().unwrap(),
        "line.ltc2017",
        "line.ltc2023",
        "--count",
        "1",
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    assert_eq!(o.status.code(), Some(0), "{stdout}{}", stderr(&o));
    assert!(
        stdout.contains("diffuse: no verdict: 1 paired configurations, fewer than the 300"),
        "{stdout}"
    );
    assert!(stdout.contains("verdict: none"), "{stdout}");
    assert!(
        !stdout.contains("bootstrap") && !stdout.contains("accurate"),
        "no interval and no verdict from one value: {stdout}"
    );
}
