//! Robustness classes 1 and 4 (docs/robustness.md): one guard for every output, one budget and one set of caps for
//! every size. Each test runs the CLI as a hostile user would and asserts the exit code, the
//! message (what is wrong and where) and that nothing outside the intended files changed.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use crate::common;
use common::snapshot::{only_changed, refused, s, snapshot};
use common::{case, eval, linelight, linelight_in, stderr, write};
use common::{CASE, CONFIG};

/// A ggx case small enough for `chain` to run in about a second.
fn ggx() -> String {
    case("g")
        .key("seed", "3")
        .methods(&["line.ltc2017"])
        .key("min_per_bin", "0")
        .material(
            "ggx_iso",
            "ggx",
            3,
            "alpha = { dist = \"log_uniform\", min = 0.1, max = 1.0 }\n\
             view_angle = { dist = \"uniform\", min = 0.0, max = 60.0 }",
        )
        .to_string()
}

fn kernel_source() -> String {
    std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/ci/example/my_line.wgsl")).unwrap()
}

/// `linelight args…`, killed and failed if it runs longer than `limit`: a refusal must come
/// before any work, never after a hang.
fn within(limit: Duration, args: &[&str]) -> Output {
    let started = Instant::now();
    let mut child = Command::new(env!("CARGO_BIN_EXE_linelight"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("linelight runs");
    while child.try_wait().unwrap().is_none() {
        if started.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("linelight {args:?} still running after {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

fn mkfifo(path: &Path) {
    let c = std::ffi::CString::new(s(path)).unwrap();
    // SAFETY: a valid C string; mkfifo only creates a node.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o644) }, 0);
}

/// Saves a baseline of the tiny case into `dir/base` (and its report into `dir/reports`).
fn save_baseline(dir: &Path, case: &Path) -> PathBuf {
    let base = dir.join("base");
    let o = linelight(&[
        "sweep",
        s(case),
        "--out",
        s(&dir.join("reports")),
        "--save-baseline",
        s(&base),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    base
}

#[test]
fn class1_junit_is_checked_with_every_other_output_before_any_work() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let case = write(d, "case.toml", CASE);
    let kernel = write(d, "my_line.wgsl", &kernel_source());
    let case_link = d.join("case_link.toml");
    std::os::unix::fs::symlink(&case, &case_link).unwrap();
    let kernel_link = d.join("kernel_link.wgsl");
    std::os::unix::fs::symlink(&kernel, &kernel_link).unwrap();
    let hard = d.join("hard.toml");
    std::fs::hard_link(&case, &hard).unwrap();
    std::fs::create_dir(d.join("sub")).unwrap();
    let reports = d.join("reports");
    let sweep = |extra: &[&str]| {
        let mut args = vec!["sweep", s(&case), "--out", s(&reports), "--kernel", s(&kernel)];
        args.extend(extra);
        linelight(&args)
    };
    let before = snapshot(d);
    for (junit, input) in [
        (&case, "the case file"),
        (&case_link, "the case file"),
        (&hard, "the case file"),
        (&kernel, "--kernel"),
        (&kernel_link, "--kernel"),
    ] {
        let o = sweep(&["--junit", s(junit)]);
        refused(&o, &["--junit", s(junit), &format!("is the same file as {input}")]);
    }
    // --junit equal to --raw, spelled apart: one would replace the other's rows.
    let raw = d.join("raw.jsonl");
    let o = sweep(&["--raw", s(&raw), "--junit", s(&d.join("sub/../raw.jsonl"))]);
    refused(&o, &["--junit", "--raw", "are the same path"]);
    // A directory, or a path under a file: refused before the report set is written.
    let o = sweep(&["--junit", s(&d.join("sub"))]);
    refused(&o, &["--junit", "is a directory"]);
    let o = sweep(&["--junit", s(&case.join("j.xml"))]);
    refused(&o, &["--junit", "is not a directory"]);
    let o = sweep(&["--save-baseline", s(&case)]);
    refused(&o, &["--save-baseline", "exists and is not a directory"]);
    only_changed(&before, &snapshot(d), &[]);
    assert!(!reports.exists(), "a report was written before a refusal");
}

#[test]
fn class1_diff_output_is_never_an_input() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let case = write(d, "case.toml", CASE);
    let a = write(d, "a.wgsl", &kernel_source());
    let b = write(
        d,
        "b.wgsl",
        &kernel_source().replace("l * l / (d * (d * d + l * l))", "-d / (d * d + l * l)"),
    );
    let b_link = d.join("b_link.wgsl");
    std::os::unix::fs::symlink(&b, &b_link).unwrap();
    let before = snapshot(d);
    let diff = |out: &Path| linelight(&["diff", s(&case), s(&a), s(&b), "--output", s(out)]);
    refused(&diff(&a), &["--output", "a.wgsl", "is the same file as A"]);
    refused(&diff(&b_link), &["--output", "b_link.wgsl", "is the same file as B"]);
    refused(&diff(&case), &["--output", "is the same file as the case file"]);
    // A method spec as A: the case is still an input.
    let o = linelight(&["diff", s(&case), "line.ltc2023", "line.ltc2017", "--output", s(&case)]);
    refused(&o, &["is the same file as the case file"]);
    only_changed(&before, &snapshot(d), &[]);
}

#[test]
fn class1_chain_writes_a_folder_of_its_own() {
    let ggx = ggx();
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let case = write(d, "g.toml", &ggx);
    let tiny = write(d, "case.toml", CASE);
    // A sweep's report folder, and a folder of someone else's with chain.md linked to the case.
    let o = linelight(&["sweep", s(&tiny), "--out", s(&d.join("reports"))]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let theirs = d.join("theirs");
    std::fs::create_dir(&theirs).unwrap();
    std::os::unix::fs::symlink(&case, theirs.join("chain.md")).unwrap();
    let before = snapshot(d);
    let o = linelight(&["chain", s(&case), "--out", s(&d.join("reports/tiny"))]);
    refused(
        &o,
        &[
            "--out",
            "reports/tiny is a report folder (written by `linelight sweep`), not a chain report folder",
        ],
    );
    let o = linelight(&["chain", s(&case), "--out", s(&theirs)]);
    refused(&o, &["--out", "theirs", "not a linelight report folder"]);
    let o = linelight(&["chain", s(&case), "--out", s(&d.join("reports/tiny/chain"))]);
    refused(
        &o,
        &[
            "lies inside",
            "reports/tiny, a report folder that `linelight sweep` replaces whole",
        ],
    );
    only_changed(&before, &snapshot(d), &[]);

    // By default, reports/<case>-chain: a set of its own, replaced whole. A link planted in it
    // goes with the old set; the case it named is untouched.
    let o = linelight_in(d, &["chain", "g.toml"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = d.join("reports/g-chain");
    assert_eq!(std::fs::read_to_string(out.join(".linelight-set")).unwrap(), "chain\n");
    std::os::unix::fs::symlink(&case, out.join("chain.md.link")).unwrap();
    std::fs::remove_file(out.join("chain.md")).unwrap();
    std::os::unix::fs::symlink(&case, out.join("chain.md")).unwrap();
    let before = snapshot(d);
    let o = linelight_in(d, &["chain", "g.toml"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(!std::fs::symlink_metadata(out.join("chain.md"))
        .unwrap()
        .file_type()
        .is_symlink());
    assert!(!out.join("chain.md.link").exists());
    assert!(std::fs::read_to_string(out.join("chain.md"))
        .unwrap()
        .starts_with("# The GGX error chain"));
    only_changed(&before, &snapshot(d), &["reports/g-chain"]);
    assert_eq!(std::fs::read_to_string(&case).unwrap(), ggx);
}

#[test]
fn class1_a_baseline_is_a_folder_of_its_own_saved_whole() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let case = write(d, "case.toml", CASE);
    let reports = d.join("reports");
    let sweep_to = |out: &Path, extra: &[&str]| {
        let mut args = vec!["sweep", s(&case), "--out", s(out)];
        args.extend(extra);
        linelight(&args)
    };
    let sweep = |extra: &[&str]| sweep_to(&reports, extra);
    let base = save_baseline(d, &case);
    assert_eq!(
        std::fs::read_to_string(base.join(".linelight-set")).unwrap(),
        "baseline\n"
    );
    let before = snapshot(d);
    // Inside the report folder this run writes (the next sweep would delete it), or inside one
    // already on disk, or the report folder itself.
    refused(
        &sweep(&["--save-baseline", s(&reports.join("tiny/base"))]),
        &[
            "--save-baseline",
            "lies inside the report folder",
            "reports/tiny this run writes (--out)",
        ],
    );
    refused(
        &sweep_to(&d.join("other"), &["--save-baseline", s(&reports.join("tiny/base"))]),
        &[
            "--save-baseline",
            "a report folder that `linelight sweep` replaces whole",
        ],
    );
    refused(
        &sweep(&["--save-baseline", s(&reports.join("tiny"))]),
        &["--save-baseline", "--out", "are the same path"],
    );
    // The baseline this run compares with is an input; JUnit inside a baseline would be
    // deleted by the next save.
    refused(
        &sweep(&["--baseline", s(&base), "--save-baseline", s(&base)]),
        &["--save-baseline", "holds --baseline"],
    );
    refused(
        &sweep(&["--baseline", s(&base), "--junit", s(&base.join("junit.xml"))]),
        &["--junit", "lies inside", "a baseline folder"],
    );
    // A sweep's report folder is not a baseline, and a baseline is not a report folder.
    refused(
        &sweep_to(&d.join("x"), &["--save-baseline", s(&reports.join("tiny"))]),
        &[
            "--save-baseline",
            "is a report folder (written by `linelight sweep`), not a baseline folder",
        ],
    );
    refused(
        &sweep_to(&base, &["--save-baseline", s(&d.join("b2"))]),
        &[
            "--out",
            "lies inside",
            "a baseline folder that `linelight sweep --save-baseline` replaces whole",
        ],
    );
    only_changed(&before, &snapshot(d), &[]);

    // Saved again: swapped in whole. A killed save's temporary is cleaned up, and a file of a
    // method no longer run is gone with the old set.
    let stale = base.join("errors/gone.method");
    std::fs::create_dir_all(&stale).unwrap();
    write(&stale, "diffuse.txt", "1e-3\n");
    let killed = d.join(".base.tmp-4294967");
    std::fs::create_dir_all(killed.join("errors")).unwrap();
    let o = sweep(&["--save-baseline", s(&base)]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(!stale.exists() && !killed.exists());
    assert!(base.join("baseline.json").is_file() && base.join("errors/line.ltc2023/diffuse.txt").is_file());
    let o = sweep(&["--baseline", s(&base)]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));

    // A baseline folder holding a file the save does not write is never replaced.
    write(&base, "README.md", "our notes");
    let before = snapshot(d);
    refused(
        &sweep(&["--save-baseline", s(&base)]),
        &["--save-baseline", "holds `README.md`", "move it out first"],
    );
    only_changed(&before, &snapshot(d), &[]);
}

#[test]
fn class1_a_sweep_and_a_scan_never_share_a_folder() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let reports = d.join("reports");
    let x = write(d, "x.toml", &CASE.replace("name = \"tiny\"", "name = \"x\""));
    let x_scan = write(d, "x_scan.toml", &CASE.replace("name = \"tiny\"", "name = \"x-scan\""));
    let o = linelight(&["sweep", s(&x_scan), "--out", s(&reports)]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let before = snapshot(d);
    let o = linelight(&["scan", s(&x), "--count", "1000", "--out", s(&reports)]);
    refused(
        &o,
        &[
            "--out",
            "reports/x-scan is a report folder (written by `linelight sweep`), not a scan report folder",
        ],
    );
    only_changed(&before, &snapshot(d), &[]);
    // The other way round.
    let o = linelight(&["scan", s(&x), "--count", "1000", "--out", s(&d.join("r2"))]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let before = snapshot(d);
    let o = linelight(&["sweep", s(&x_scan), "--out", s(&d.join("r2"))]);
    refused(
        &o,
        &["r2/x-scan is a scan report folder (written by `linelight scan`), not a report folder"],
    );
    only_changed(&before, &snapshot(d), &[]);
}

#[test]
fn class1_no_output_of_any_command_lands_in_a_report_folder() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let case = write(d, "case.toml", CASE);
    let input = write(d, "in.jsonl", &format!("{CONFIG}\n"));
    let reports = d.join("reports");
    let o = linelight(&["sweep", s(&case), "--out", s(&reports)]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let set = reports.join("tiny");
    let inside = |name: &str| set.join(name);
    let before = snapshot(d);
    let why = "reports/tiny, a report folder that `linelight sweep` replaces whole";
    let eval = eval(&input, &inside("x.jsonl"), &[]);
    refused(&eval, &["--output", why]);
    let bench = linelight(&["bench", s(&case), "--count", "8", "--json", s(&inside("b.json"))]);
    refused(&bench, &["--json", why]);
    let raw = linelight(&[
        "sweep",
        s(&case),
        "--out",
        s(&d.join("o")),
        "--raw",
        s(&inside("raw.jsonl")),
    ]);
    refused(&raw, &["--raw", why]);
    let shard = linelight(&["sweep", s(&case), "--shard", "0/2", "--out", s(&set)]);
    refused(&shard, &["--shard", why]);
    let scan = linelight(&["scan", s(&case), "--count", "1000", "--out", s(&set)]);
    refused(&scan, &["--out", why]);
    let fit = linelight(&["fit", "--size", "2", "--out", s(&inside("t.csv"))]);
    refused(&fit, &["--out", why]);
    // Shard states kept in a report folder: merging into that folder would delete them.
    let o = linelight(&["sweep", s(&case), "--shard", "0/1", "--out", s(&d.join("sh"))]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    std::fs::rename(d.join("sh/shard-0-of-1.cbor"), set.join("shard-0-of-1.cbor")).unwrap();
    let before_merge = snapshot(d);
    let o = linelight(&["merge", s(&set), "--out", s(&reports)]);
    refused(&o, &["--out", "is replaced whole, and it holds the shard folder"]);
    only_changed(&before_merge, &snapshot(d), &[]);
    std::fs::remove_file(set.join("shard-0-of-1.cbor")).unwrap();
    // A report folder that would hold the case file (replacing it whole would delete it).
    let cases = d.join("cases");
    std::fs::create_dir(&cases).unwrap();
    std::fs::write(cases.join(".linelight-set"), "sweep\n").unwrap();
    let inner = write(
        &cases,
        "case.toml",
        &CASE.replace("name = \"tiny\"", "name = \"cases\""),
    );
    let before_inner = snapshot(d);
    let o = linelight(&["sweep", s(&inner), "--out", s(d)]);
    refused(&o, &["--out", "holds the case file", "cases/case.toml"]);
    only_changed(&before_inner, &snapshot(d), &[]);
    only_changed(&before, &snapshot(d), &["cases", "sh"]);
}

#[test]
fn class4_case_counts_pass_the_same_caps_as_the_command_line() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let before = snapshot(d);
    let huge = write(
        d,
        "huge.toml",
        &CASE.replace("count = 20", "count = 9223372036854775807"),
    );
    let started = Instant::now();
    let o = within(Duration::from_secs(20), &["sweep", s(&huge), "--out", s(&d.join("r"))]);
    refused(
        &o,
        &["huge.toml: `materials[0].count` = 9223372036854775807: more than the 1000000000000 configurations"],
    );
    assert!(started.elapsed() < Duration::from_secs(10), "{:?}", started.elapsed());
    // One past the cap, and every command that loads the case refuses it alike.
    let over = write(d, "over.toml", &CASE.replace("count = 20", "count = 1000000000001"));
    for args in [
        vec!["sweep", s(&over), "--out", s(&d.join("r"))],
        vec!["bench", s(&over), "--count", "8"],
        vec!["scan", s(&over), "--count", "1000", "--out", s(&d.join("r"))],
        vec!["chain", s(&over), "--out", s(&d.join("c"))],
        vec!["diff", s(&over), "line.ltc2023", "line.ltc2017"],
    ] {
        refused(&linelight(&args), &["`materials[0].count` = 1000000000001"]);
    }
    let bins = write(
        d,
        "bins.toml",
        &CASE.replace("seed = 7", "seed = 7\nmin_per_bin = 9223372036854775807"),
    );
    refused(
        &linelight(&["sweep", s(&bins), "--out", s(&d.join("r"))]),
        &["bins.toml: `min_per_bin` = 9223372036854775807: more than"],
    );
    // Bench rounds are capped too: each runs every configuration of every method.
    let case = write(d, "case.toml", CASE);
    refused(
        &linelight(&["bench", s(&case), "--count", "8", "--repeats", "100000000000"]),
        &["--repeats 100000000000: at most 10000"],
    );
    refused(
        &linelight(&["bench", s(&case), "--count", "8", "--warmup", "100000000000"]),
        &["--warmup 100000000000: at most 10000"],
    );
    only_changed(
        &before,
        &snapshot(d),
        &["huge.toml", "over.toml", "bins.toml", "case.toml"],
    );
}

#[test]
fn class4_chain_is_capped_and_in_the_budget() {
    let ggx = ggx();
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let case = write(d, "g.toml", &ggx);
    let out = d.join("c");
    let before = snapshot(d);
    let started = Instant::now();
    let o = within(
        Duration::from_secs(20),
        &["chain", s(&case), "--count", "99999999999999999", "--out", s(&out)],
    );
    refused(
        &o,
        &["--count 99999999999999999: more than the 1000000000000 configurations"],
    );
    // Under the cap, the rows it holds are in the estimate.
    let o = within(
        Duration::from_secs(20),
        &[
            "chain",
            s(&case),
            "--count",
            "10000000",
            "--out",
            s(&out),
            "--max-memory",
            "1G",
        ],
    );
    refused(
        &o,
        &[
            "chain of case `g` needs an estimated",
            "10000000 configurations × 1 methods",
            "--max-memory 1.0 GiB",
        ],
    );
    assert!(started.elapsed() < Duration::from_secs(10), "{:?}", started.elapsed());
    only_changed(&before, &snapshot(d), &[]);
}

/// `n + 1` increasing edges over [lo, hi].
fn edges(n: usize, lo: f64, hi: f64) -> String {
    (0..=n)
        .map(|i| format!("{}", lo + (hi - lo) * i as f64 / n as f64))
        .collect::<Vec<_>>()
        .join(", ")
}

#[test]
fn class4_maps_and_bins_are_in_the_memory_budget() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let map = format!(
        "{CASE}[[maps]]\nx = {{ axis = \"elevation\", edges = [{}] }}\ny = {{ axis = \"tilt\", edges = [{}] }}\n",
        edges(2000, 10.0, 90.0),
        edges(2000, 0.0, 180.0)
    );
    let map = write(d, "map.toml", &map);
    let bins = format!(
        "{CASE}[[bins]]\naxis = \"elevation\"\nedges = [{}]\n",
        edges(200_000, 10.0, 90.0)
    );
    let bins = write(d, "bins.toml", &bins);
    let before = snapshot(d);
    let started = Instant::now();
    let o = within(
        Duration::from_secs(30),
        &["sweep", s(&map), "--out", s(&d.join("r")), "--max-memory", "2G"],
    );
    refused(
        &o,
        &[
            "case `tiny` with 20 configurations needs an estimated",
            "statistics of 0 bins and 4000000 map cells, per method and material",
            "--max-memory 2.0 GiB",
        ],
    );
    let o = within(
        Duration::from_secs(30),
        &["sweep", s(&bins), "--out", s(&d.join("r")), "--max-memory", "300M"],
    );
    refused(
        &o,
        &["statistics of 200000 bins and 0 map cells", "--max-memory 300.0 MiB"],
    );
    // bench and diff run the same stages and pass the same budget.
    let o = within(
        Duration::from_secs(30),
        &["bench", s(&bins), "--count", "8", "--max-memory", "300M"],
    );
    refused(&o, &["statistics of 200000 bins"]);
    let o = within(
        Duration::from_secs(30),
        &["diff", s(&map), "line.ltc2023", "line.ltc2017", "--max-memory", "2G"],
    );
    refused(&o, &["4000000 map cells"]);
    assert!(started.elapsed() < Duration::from_secs(20), "{:?}", started.elapsed());
    only_changed(&before, &snapshot(d), &[]);
}

#[test]
fn class4_the_gate_keeps_its_observations_within_the_budget() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let case = write(d, "case.toml", CASE);
    let before = snapshot(d);
    let o = within(
        Duration::from_secs(20),
        &[
            "sweep",
            s(&case),
            "--out",
            s(&d.join("r")),
            "--count",
            "100000000000",
            "--save-baseline",
            s(&d.join("base")),
        ],
    );
    refused(&o, &["the gate's observations of 100000000000 configurations"]);
    only_changed(&before, &snapshot(d), &[]);
}

#[test]
fn class4_an_eval_line_is_in_the_memory_budget() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    // One 10 MB line (blanks inside the object): held whole while parsed.
    let line = CONFIG.replacen('{', &format!("{{{}", " ".repeat(10 << 20)), 1);
    let input = write(d, "long.jsonl", &format!("{line}\n"));
    let output = d.join("out.jsonl");
    let before = snapshot(d);
    let o = within(
        Duration::from_secs(20),
        &[
            "eval",
            "--input",
            s(&input),
            "--output",
            s(&output),
            "--methods",
            "line.ltc2023",
            "--max-memory",
            "30M",
        ],
    );
    refused(
        &o,
        &[
            "eval of",
            "long.jsonl (1 lines) needs an estimated",
            "the longest 10485",
        ],
    );
    only_changed(&before, &snapshot(d), &[]);
    // A FIFO as the input would be read once of three times: refused, not waited on.
    let fifo = d.join("fifo.jsonl");
    mkfifo(&fifo);
    let o = within(
        Duration::from_secs(20),
        &["eval", "--input", s(&fifo), "--output", s(&output)],
    );
    refused(&o, &["--input", "fifo.jsonl: not a regular file"]);
    assert!(!output.exists());
}

#[test]
fn class4_a_baseline_is_read_only_inside_its_folder_and_only_from_regular_files() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let case = write(d, "case.toml", CASE);
    let base = save_baseline(d, &case);
    let json = std::fs::read_to_string(base.join("baseline.json")).unwrap();
    let errors = "errors/line.ltc2023/diffuse.txt";
    assert!(json.contains(errors), "{json}");
    let secret = write(d, "secret.txt", "the-secret-contents\n");
    let compare = || {
        within(
            Duration::from_secs(30),
            &[
                "sweep",
                s(&case),
                "--out",
                s(&d.join("reports")),
                "--baseline",
                s(&base),
            ],
        )
    };
    // The errors path out of the folder: `..`, absolute, or a symlink out.
    for bad in ["../secret.txt", s(&secret), "errors/../../secret.txt"] {
        std::fs::write(base.join("baseline.json"), json.replace(errors, bad)).unwrap();
        let before = snapshot(d);
        let o = compare();
        refused(
            &o,
            &[
                "baseline.json",
                "`line.ltc2023` on `diffuse`: errors file",
                "is not inside the baseline folder",
            ],
        );
        assert!(!stderr(&o).contains("the-secret-contents"), "{}", stderr(&o));
        only_changed(&before, &snapshot(d), &[]);
    }
    std::fs::write(base.join("baseline.json"), &json).unwrap();
    let file = base.join(errors);
    let saved = std::fs::read(&file).unwrap();
    std::fs::remove_file(&file).unwrap();
    std::os::unix::fs::symlink(&secret, &file).unwrap();
    let o = compare();
    refused(&o, &["is not inside the baseline folder"]);
    assert!(!stderr(&o).contains("the-secret-contents"));
    // A FIFO as the errors file (or as baseline.json): refused at once, never waited on.
    std::fs::remove_file(&file).unwrap();
    mkfifo(&file);
    let before = snapshot(d);
    refused(
        &compare(),
        &["baseline errors file", "diffuse.txt is not a regular file"],
    );
    only_changed(&before, &snapshot(d), &[]);
    std::fs::remove_file(&file).unwrap();
    // Larger than its configurations' lines can be: refused before it is read.
    std::fs::write(&file, vec![b'1'; 20 * 32 + 33]).unwrap();
    refused(
        &compare(),
        &["baseline errors file", "bytes, more than the 672 it can hold"],
    );
    std::fs::write(&file, &saved).unwrap();
    let json_path = base.join("baseline.json");
    std::fs::remove_file(&json_path).unwrap();
    mkfifo(&json_path);
    refused(&compare(), &["baseline", "baseline.json is not a regular file"]);
}

/// The text of every `.rs` file under `dir`.
fn sources(dir: &Path, out: &mut Vec<(PathBuf, String)>) {
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            sources(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push((p.clone(), std::fs::read_to_string(&p).unwrap()));
        }
    }
}

#[test]
fn no_file_is_written_outside_io() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    sources(&src, &mut files);
    assert!(files.len() > 50, "src/ read: {}", files.len());
    let writes = [
        "fs::write",
        "File::create",
        "OpenOptions",
        "create_dir",
        "fs::rename",
        "remove_file",
        "remove_dir",
        "fs::copy",
        "set_permissions",
    ];
    let mut found = Vec::new();
    for (path, text) in &files {
        if path.ends_with("io.rs") && path.parent() == Some(src.as_path()) {
            continue;
        }
        for (i, line) in text.lines().enumerate() {
            let code = line.split("//").next().unwrap_or_default();
            if let Some(w) = writes.iter().find(|w| code.contains(*w)) {
                found.push(format!("{}:{}: {w}", path.display(), i + 1));
            }
        }
    }
    assert!(
        found.is_empty(),
        "files written outside src/io.rs:\n{}",
        found.join("\n")
    );
}

#[test]
fn class4_every_input_is_read_within_a_bound() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    // A case or kernel file without end: refused at the cap, within seconds.
    let o = within(
        Duration::from_secs(30),
        &["sweep", "/dev/zero", "--out", s(&d.join("r"))],
    );
    refused(&o, &["case file /dev/zero is larger than 67108864 bytes"]);
    let o = within(Duration::from_secs(30), &["check", "/dev/zero"]);
    refused(&o, &["kernel /dev/zero is larger than 67108864 bytes"]);
    let case = write(d, "case.toml", CASE);
    let o = within(
        Duration::from_secs(30),
        &["sweep", s(&case), "--out", s(&d.join("r")), "--kernel", "/dev/zero"],
    );
    refused(&o, &["kernel /dev/zero is larger than"]);
    // A FIFO named like a shard state: refused, never waited on.
    let shards = d.join("shards");
    std::fs::create_dir(&shards).unwrap();
    mkfifo(&shards.join("shard-0-of-1.cbor"));
    let before = snapshot(d);
    let o = within(
        Duration::from_secs(30),
        &["merge", s(&shards), "--out", s(&d.join("r"))],
    );
    refused(&o, &["shard state", "shard-0-of-1.cbor is not a regular file"]);
    only_changed(&before, &snapshot(d), &[]);
}
