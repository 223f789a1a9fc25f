//! "Never silently wrong, never destructive" (docs/robustness.md): one test per class of defect, each
//! running the CLI as a hostile user would and asserting three things: the exit code, the
//! message, and that nothing outside the intended files changed (a snapshot of the
//! temporary directory before and after, FIFOs, symlinks and device nodes included).

use crate::common;
use common::snapshot::{only_changed, refused, s, snapshot};
use common::{eval, linelight, stderr, sweep, write};
use common::{CASE, CONFIG};

#[test]
fn class1_outputs_are_written_through_or_refused() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let input = write(d, "in.jsonl", &format!("{CONFIG}\n"));
    let target = write(d, "target.jsonl", "old\n");
    let link = d.join("link.jsonl");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    let input_link = d.join("input_link.jsonl");
    std::os::unix::fs::symlink(&input, &input_link).unwrap();
    let fifo = d.join("fifo");
    let c = std::ffi::CString::new(s(&fifo)).unwrap();
    // SAFETY: a valid C string; mkfifo only creates a node.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o644) }, 0);
    // A character device like /dev/null, made here (needs root; skipped otherwise).
    let null = d.join("null");
    let cn = std::ffi::CString::new(s(&null)).unwrap();
    // SAFETY: as above; mknod of 1:3 (the null device) in a temporary directory.
    let have_device = unsafe { libc::mknod(cn.as_ptr(), libc::S_IFCHR | 0o666, libc::makedev(1, 3)) } == 0;
    let case = write(d, "case.toml", CASE);
    let reports = d.join("reports");

    let before = snapshot(d);
    // An output that is the input, directly or through a link: refused, nothing written.
    for out in [&input, &input_link] {
        let o = eval(&input, out, &["--methods", "line.ltc2023"]);
        refused(&o, &["same file as --input"]);
    }
    // --raw pointed at the case file, or into the report set: refused before any work.
    let o = linelight(&["sweep", s(&case), "--out", s(&reports), "--raw", s(&case)]);
    refused(&o, &["--raw", "the case file"]);
    let o = linelight(&[
        "sweep",
        s(&case),
        "--out",
        s(&reports),
        "--raw",
        s(&reports.join("tiny/report.md")),
    ]);
    refused(&o, &["inside the report folder"]);
    let o = linelight(&["bench", s(&case), "--json", s(&case), "--count", "8"]);
    refused(&o, &["--json", "the case file"]);
    only_changed(&before, &snapshot(d), &[]);

    // A symlink stays a link; the file it names gets the results.
    let o = eval(&input, &link, &["--methods", "line.ltc2023"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::read_to_string(&target).unwrap().starts_with("{\"id\":\"a\""));
    // A FIFO is written through (a reader gets the lines) and stays a FIFO.
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read_to_string(fifo).unwrap())
    };
    let o = eval(&input, &fifo, &["--methods", "line.ltc2023"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(reader.join().unwrap().starts_with("{\"id\":\"a\""));
    if have_device {
        let o = eval(&input, &null, &["--methods", "line.ltc2023"]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    // Only the link's target changed: the FIFO, the device and the link are still what they were.
    only_changed(&before, &snapshot(d), &["target.jsonl"]);
}

#[test]
fn class2_degenerate_distributions_are_refused_naming_the_parameter() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    for (edit, what) in [
        (
            ("center = ", "distance = { dist = \"fixed\", value = 0.0 }\ncenter = "),
            "`geometry.distance` = fixed 0",
        ),
        (("min = 0.1, max = 10.0", "min = -1.0, max = 10.0"), "geometry.length"),
        (
            (
                "center = ",
                "radius = { dist = \"uniform\", min = 0.5, max = 1.5 }\ncenter = ",
            ),
            "`geometry.radius` = uniform [0.5, 1.5]",
        ),
    ] {
        let before = snapshot(d);
        let o = sweep(d, &CASE.replace(edit.0, edit.1), &[]);
        refused(&o, &[what]);
        only_changed(&before, &snapshot(d), &["case.toml"]);
        assert!(!d.join("reports").exists());
    }
    // Draws that are all degenerate (a lobe no f32 kernel can hold): bounded, then refused.
    let lobe = CASE.replace(
        "kind = \"diffuse\"",
        "kind = \"ltc_sparse\"\nalpha = { dist = \"fixed\", value = 1e-300 }",
    );
    let before = snapshot(d);
    let o = sweep(d, &lobe, &[]);
    refused(&o, &["materials `diffuse`", "draws were degenerate", "alpha"]);
    only_changed(&before, &snapshot(d), &["case.toml"]);
}

#[test]
fn class2_the_rejection_rate_is_in_the_report() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let o = sweep(d, CASE, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report = std::fs::read_to_string(d.join("reports/tiny/report.md")).unwrap();
    assert!(report.contains("Degenerate draws: none"), "{report}");
    let summary = common::json(&d.join("reports/tiny/summary.json"));
    assert_eq!(summary["draws"][0]["rejected"], 0);
    assert_eq!(summary["draws"][0]["drawn"], 20);
}

#[test]
fn class2_some_degenerate_draws_are_redrawn_and_reported() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    // Distances down to 7e-19 with a short centred segment (|p| ≈ d): the few below 2^-60
    // have no f32 squares and are redrawn (about 0.5 %, under the 1 % limit).
    let case = CASE
        .replace("count = 20", "count = 2000")
        .replace(
            "{ dist = \"log_uniform\", min = 0.1, max = 10.0 }",
            "{ dist = \"fixed\", value = 0.1 }",
        )
        .replace(
            "center = { dist = \"uniform\", min = -1.0, max = 1.0 }",
            "center = { dist = \"fixed\", value = 0.0 }\ndistance = { dist = \"log_uniform\", min = 7e-19, max = 1.0 }",
        );
    let o = sweep(d, &case, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let summary = common::json(&d.join("reports/tiny/summary.json"));
    let rejected = summary["draws"][0]["rejected"].as_u64().unwrap();
    assert!(rejected > 0 && rejected <= 30, "{rejected}");
    assert_eq!(summary["draws"][0]["drawn"].as_u64().unwrap(), 2000 + rejected);
    let report = std::fs::read_to_string(d.join("reports/tiny/report.md")).unwrap();
    let line = format!(
        "Degenerate draws, redrawn: `diffuse` {rejected} of {} draws ({:.2} %: {rejected} not representable in f32).",
        2000 + rejected,
        100.0 * rejected as f64 / (2000 + rejected) as f64
    );
    assert!(report.contains(&line), "{line} not in the report");
}

#[test]
fn class3_loops_past_the_driver_limit_are_refused() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let input = write(d, "in.jsonl", &format!("{CONFIG}\n"));
    let output = d.join("out.jsonl");
    let before = snapshot(d);
    let o = eval(&input, &output, &["--methods", "line.numeric@1000000"]);
    refused(&o, &["line.numeric@1000000", "loop-body iterations", "65535"]);
    let o = sweep(
        d,
        &CASE
            .replace("[\"line.ltc2023\"]", "[\"cylinder.numeric@512x1024\"]")
            .replace("center = ", "radius = { dist = \"fixed\", value = 0.01 }\ncenter = "),
        &[],
    );
    refused(&o, &["cylinder.numeric@512x1024", "loop limit", "not reported"]);
    let rect = write(
        d,
        "rect.jsonl",
        &(CONFIG.replace(
            "\"material\"",
            "\"rect\":{\"normal\":[0.0,0.0,1.0],\"width\":0.05},\"material\"",
        ) + "\n"),
    );
    let o = eval(&rect, &output, &["--methods", "rectangle.numeric@256x4096"]);
    refused(&o, &["rectangle.numeric@256x4096", "loop"]);
    only_changed(&before, &snapshot(d), &["case.toml", "rect.jsonl"]);
    assert!(!d.join("reports").exists());
}

#[test]
fn class4_names_never_leave_the_output_folder() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let before = snapshot(d);
    for name in ["../../x", "/tmp/abs", ".hidden", "a b"] {
        let o = sweep(d, &CASE.replace("name = \"tiny\"", &format!("name = \"{name}\"")), &[]);
        refused(&o, &["`name` = ", "report folder"]);
    }
    let two = CASE.replace("name = \"diffuse\"", "name = \"dif fuse\"")
        + "[[materials]]\nname = \"dif,fuse\"\nkind = \"diffuse\"\ncount = 5\n";
    let o = sweep(d, &two, &[]);
    refused(&o, &["\"dif,fuse\"", "same chart file"]);
    only_changed(&before, &snapshot(d), &["case.toml"]);
    assert!(!d.join("reports").exists() && !d.parent().unwrap().join("x").exists());
}

#[test]
fn class5_report_sets_are_written_whole() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    // An earlier run's set with a file this run does not write, and a killed run's temporary.
    let old = d.join("reports/tiny");
    std::fs::create_dir_all(old.join("maps")).unwrap();
    write(&old, "summary.json", "{\"configurations\": 60000}");
    write(&old, "nonfinite.jsonl", "stale\n");
    write(&old, "maps/removed.svg", "<svg/>");
    let killed = d.join("reports/.tiny.tmp-4294967");
    std::fs::create_dir_all(&killed).unwrap();
    write(d, "keep.txt", "mine");
    let before = snapshot(d);
    let o = sweep(d, CASE, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!old.join("nonfinite.jsonl").exists() && !old.join("maps/removed.svg").exists());
    assert!(!killed.exists(), "a killed run's temporary is cleaned up");
    let summary = std::fs::read_to_string(old.join("summary.json")).unwrap();
    assert!(summary.contains("\"configurations\":20"), "{summary}");
    let entries: Vec<_> = std::fs::read_dir(d.join("reports"))
        .unwrap()
        .flatten()
        .map(|e| e.file_name())
        .collect();
    assert_eq!(entries, vec![std::ffi::OsString::from("tiny")], "only the set is left");
    only_changed(&before, &snapshot(d), &["reports", "case.toml"]);

    // A folder that is not a report folder is never replaced: exit 2 before any work.
    let mine = d.join("reports/tiny2");
    std::fs::create_dir_all(&mine).unwrap();
    write(&mine, "notes.md", "precious");
    let before = snapshot(d);
    let o = sweep(d, &CASE.replace("name = \"tiny\"", "name = \"tiny2\""), &[]);
    refused(&o, &["not a linelight report folder"]);
    only_changed(&before, &snapshot(d), &["case.toml"]);
}

#[test]
fn class6_no_panic_is_reachable_from_input() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let before = snapshot(d);
    // A streamed sweep's memory does not grow with the count: an absurd count is refused as such.
    let o = sweep(d, CASE, &["--count", "99999999999999999"]);
    refused(
        &o,
        &["--count 99999999999999999", "configurations per family a sweep takes"],
    );
    let search = format!("{CASE}[search]\nmethods = [\"line.ltc2023\"]\nrestarts = 0\n");
    let o = sweep(d, &search, &[]);
    refused(&o, &["`search.restarts` = 0"]);
    let big = format!("{CASE}[search]\nmethods = [\"line.ltc2023\"]\nrestarts = 100000\npopulation = 100000\n");
    let o = sweep(d, &big, &[]);
    refused(&o, &["`search.restarts` × `search.population`"]);
    let disagree = format!("{CASE}[disagreements]\nrestarts = 0\n");
    refused(&sweep(d, &disagree, &[]), &["`disagreements.restarts` = 0"]);
    let topup = CASE.replace("seed = 7", "seed = 7\ntopup_draws = 1000000000000");
    refused(&sweep(d, &topup, &[]), &["`topup_draws` = 1000000000000"]);
    let wide = format!("{CASE}[search]\nmethods = [\"line.ltc2023\"]\nrestarts = 1000\npopulation = 1000\n");
    let o = sweep(d, &wide, &["--max-memory", "100M"]);
    refused(&o, &["[search] with 1000 × 1000 candidates", "needs an estimated"]);
    only_changed(&before, &snapshot(d), &["case.toml"]);
    assert!(!d.join("reports").exists());
}

#[test]
fn class7_memory_is_estimated_and_limited() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let lines: String = (0..3)
        .map(|i| CONFIG.replace("\"a\"", &format!("\"x{i}\"")) + "\n")
        .collect();
    let input = write(d, "in.jsonl", &lines);
    let output = d.join("out.jsonl");
    let before = snapshot(d);
    let o = sweep(d, CASE, &["--max-memory", "1K"]);
    refused(&o, &["needs an estimated", "more than --max-memory 1.0 KiB"]);
    let o = eval(&input, &output, &["--max-memory", "100"]);
    refused(&o, &["eval of", "needs an estimated"]);
    let o = eval(&input, &output, &["--max-memory", "lots"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--max-memory"), "{}", stderr(&o));
    only_changed(&before, &snapshot(d), &["case.toml", "big.wgsl"]);
}

#[test]
fn class8_numbers_outside_f32_are_refused() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let output = d.join("out.jsonl");
    for (p, what) in [("1e308", "outside"), ("1e200", "outside"), ("1e-30", "outside")] {
        let line = CONFIG
            .replace("[0.3,-0.2,1.0]", &format!("[{p},0,{p}]"))
            .replace("[0.9,0.4,1.6]", &format!("[{p},{p},{p}]"));
        let input = write(d, "in.jsonl", &format!("{line}\n"));
        let before = snapshot(d);
        let o = eval(&input, &output, &[]);
        refused(&o, &["in.jsonl:1:", what, "f32"]);
        assert!(!stderr(&o).contains("distance NaN"), "{}", stderr(&o));
        only_changed(&before, &snapshot(d), &[]);
    }
    let line = CONFIG.replace(
        "{\"kind\":\"diffuse\"}",
        "{\"kind\":\"ltc\",\"minv\":[[1e30,0,0],[0,1,0],[0,0,1]]}",
    );
    let input = write(d, "in.jsonl", &format!("{line}\n"));
    let o = eval(&input, &output, &[]);
    refused(&o, &["an entry of minv = 1e30"]);
}

#[test]
fn class9_case_values_name_file_key_and_value() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let before = snapshot(d);
    for (edit, what) in [
        (("seed = 7", "seed = 7\nerror_floor = { line = 0.0 }"), "`error_floor.line` = 0"),
        (("seed = 7", "seed = 7\nerror_floor = { line = nan }"), "`error_floor.line` = NaN"),
        (("seed = 7", "seed = 7\nerror_floor = { line = -1e-6 }"), "`error_floor.line` = -0.000001"),
        (("[\"line.ltc2023\"]", "[\"line.ltc2023\", \"line.ltc2023\"]"), "\"line.ltc2023\" is listed twice"),
        (
            ("[\"line.ltc2023\"]", "[\"line.ltc2023\", \"line.ltc2017\", \"line.ltc2017_fwt\"]\ncompare = [[\"line.ltc2023\", \"line.ltc2017\", \"line.ltc2017_fwt\"]]"),
            "exactly two methods, got 3",
        ),
    ] {
        let o = sweep(d, &CASE.replace(edit.0, edit.1), &[]);
        refused(&o, &["case.toml", what]);
    }
    let nan = format!("{CASE}[tolerances.\"line.ltc2023\"]\np99 = nan\n");
    refused(
        &sweep(d, &nan, &[]),
        &["case.toml", "`tolerances.\"line.ltc2023\".p99` = NaN"],
    );
    let two = format!("{CASE}[[materials]]\nname = \"diffuse\"\nkind = \"diffuse\"\ncount = 5\n");
    refused(&sweep(d, &two, &[]), &["`materials[1].name` = \"diffuse\"", "unique"]);
    only_changed(&before, &snapshot(d), &["case.toml"]);
    assert!(!d.join("reports").exists());
    // A byte-order mark is not an error.
    let o = sweep(d, &format!("\u{feff}{CASE}"), &[]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn class10_every_kernel_file_is_validated_the_same_way() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let input = write(d, "in.jsonl", &format!("{CONFIG}\n"));
    let output = d.join("out.jsonl");
    let unused = write(
        d,
        "unused.wgsl",
        "//! id: line.unused\n//! target: line\nfn method(scene: Scene) -> f32 { return nope; }\n",
    );
    let builtin = write(
        d,
        "dup.wgsl",
        "//! id: line.ltc2023\n//! target: line\nfn method(scene: Scene) -> f32 { return 0.0; }\n",
    );
    let bracket = write(
        d,
        "br.wgsl",
        "//! id: line.x[y]\n//! target: line\nfn method(scene: Scene) -> f32 { return 0.0; }\n",
    );
    let twice = write(
        d,
        "twice.wgsl",
        "//! id: line.a\n//! target: line\n//! id: line.b\nfn method(scene: Scene) -> f32 { return 0.0; }\n",
    );
    let half = write(d, "half.wgsl", "//! id: line.half\n//! target: line\nenable f16;\nfn method(scene: Scene) -> f32 { return f32(f16(scene.p1.x)); }\n");
    let before = snapshot(d);
    // A kernel no method uses is still compiled.
    let o = eval(&input, &output, &["--kernel", s(&unused), "--methods", "line.ltc2023"]);
    refused(&o, &["unused.wgsl:3:", "nope"]);
    for (k, what) in [
        (
            &builtin,
            "id `line.ltc2023` is already defined by kernels/line_ltc2023.wgsl",
        ),
        (&bracket, "br.wgsl:1: id `line.x[y]`"),
        (&twice, "twice.wgsl:3: `//! id:` appears twice (first on line 1)"),
    ] {
        refused(&linelight(&["check", s(k)]), &[what]);
        let o = eval(&input, &output, &["--kernel", s(k), "--methods", "line.ltc2023"]);
        refused(&o, &[what]);
    }
    only_changed(&before, &snapshot(d), &[]);
    // `enable f16`: check and eval agree.
    let o = linelight(&["check", s(&half)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = eval(&input, &output, &["--kernel", s(&half), "--methods", "line.half"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn class11_csv_fields_are_escaped() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let before = snapshot(d);
    let o = sweep(
        d,
        &CASE.replace("name = \"diffuse\"", "name = \"dif,fuse \\\"x\\\"\""),
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(d.join("reports/tiny/stats.csv")).unwrap();
    let mut r = csv::Reader::from_reader(text.as_bytes());
    let width = r.headers().unwrap().len();
    let rows: Vec<csv::StringRecord> = r.records().map(Result::unwrap).collect();
    assert!(!rows.is_empty());
    for row in &rows {
        assert_eq!(row.len(), width);
        assert_eq!(&row[2], "dif,fuse \"x\"");
    }
    only_changed(&before, &snapshot(d), &["reports", "case.toml"]);
}

#[test]
fn class12_the_rect_normal_used_is_recorded() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    // A normal with a component along the segment (0.6, 0.6, 0.6).
    let line = CONFIG.replace(
        "\"material\"",
        "\"rect\":{\"normal\":[0.0,0.0,1.0],\"width\":0.02},\"material\"",
    );
    let input = write(d, "in.jsonl", &format!("{line}\n"));
    let output = d.join("out.jsonl");
    let before = snapshot(d);
    let o = eval(&input, &output, &["--methods", "rectangle.line"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("in.jsonl:1: `a`: rect.normal made perpendicular"),
        "{}",
        stderr(&o)
    );
    let row: serde_json::Value =
        serde_json::from_str(std::fs::read_to_string(&output).unwrap().lines().next().unwrap()).unwrap();
    let n: Vec<f64> = row["rect"]["normal"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    let e = [0.6, 0.6, 0.6];
    let dot: f64 = n.iter().zip(e).map(|(a, b)| a * b).sum();
    assert!(
        dot.abs() < 1e-12,
        "normal used {n:?} is not perpendicular to the segment"
    );
    assert_eq!(row["rect"]["width"], 0.02);
    only_changed(&before, &snapshot(d), &["out.jsonl"]);
}

#[test]
fn class13_messages_say_what_and_where_and_stay_short() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let output = d.join("out.jsonl");
    let four = write(
        d,
        "four.jsonl",
        &(CONFIG.replace("[0.3,-0.2,1.0]", "[0.3,-0.2,1.0,4.0]") + "\n"),
    );
    let huge_id = "x".repeat(1 << 20);
    let huge = write(
        d,
        "huge.jsonl",
        &(CONFIG
            .replace("\"a\"", &format!("\"{huge_id}\""))
            .replace("[0.9,0.4,1.6]", "[0.3,-0.2,1.0]")
            + "\n"),
    );
    let case = write(d, "case.toml", CASE);
    let before = snapshot(d);
    refused(
        &eval(&four, &output, &[]),
        &["four.jsonl:1:", "expected 3 numbers [x, y, z], got 4"],
    );
    refused(
        &eval(&four, &output, &["--methods", "line.numeric@4294967296"]),
        &["4294967296", "larger than 4294967295"],
    );
    refused(
        &linelight(&["bench", s(&case), "--count", "0"]),
        &["--count must be at least 1"],
    );
    refused(&sweep(d, CASE, &["--count", "0"]), &["--count must be at least 1"]);
    let twice = ["--methods", "line.ltc2023,line.ltc2017,line.ltc2023"];
    let o = linelight(&[&["eval", "--input", s(&four), "--output", s(&output)][..], &twice[..]].concat());
    refused(&o, &["--methods: `line.ltc2023` is listed twice (entries 1 and 3)"]);
    let o = linelight(&[&["bench", s(&case), "--count", "8"][..], &twice[..]].concat());
    refused(&o, &["--methods: `line.ltc2023` is listed twice"]);
    let o = eval(&huge, &output, &[]);
    refused(&o, &["huge.jsonl:1:", "p1 and p2 coincide"]);
    only_changed(&before, &snapshot(d), &[]);
}

#[test]
fn committed_cases_pass_the_value_checks_and_sample_within_the_redraw_limit() {
    for e in std::fs::read_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/cases"))
        .unwrap()
        .flatten()
        // cases/render/ holds render scenes, not sweep cases (tests/render.rs loads them).
        .filter(|e| e.path().is_file())
    {
        let case = linelight::input::case::Case::load(&e.path()).unwrap_or_else(|e| panic!("{e}"));
        let (samples, draws) =
            linelight::input::sampler::sample_case_counted(&case).unwrap_or_else(|e| panic!("{}: {e}", case.name));
        assert_eq!(samples.len(), case.materials.iter().map(|m| m.count).sum::<usize>());
        for d in draws {
            eprintln!(
                "{}: {} rejected of {} drawn: {:?}",
                d.family, d.rejected, d.drawn, d.reasons
            );
        }
    }
}
