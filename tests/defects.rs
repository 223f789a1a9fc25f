//! Defect classes 2 (silently wrong), 3 (panics and aborts) and 5 (messages): one
//! test per defect, each running the CLI as a hostile user would and asserting the exit code,
//! the message, and that nothing outside the intended files changed.

use std::path::Path;

use crate::common;
use common::snapshot::{only_changed, refused, s, snapshot};
use common::{eval, linelight, linelight_in, stderr, write};
use common::{CASE, CONFIG};

/// A line kernel whose value is its loop's trip count, `trips` a WGSL u32 expression.
fn counting_kernel(id: &str, trips: &str) -> String {
    format!(
        "//! id: {id}\n//! target: line\nfn method(scene: Scene) -> f32 {{\n    var c = 0.0;\n    \
         let n = {trips};\n    for (var i = 0u; i < n; i++) {{\n        c += 1.0;\n    }}\n    return c;\n}}\n"
    )
}

// ---- Class 2: silently wrong ----

#[test]
fn class2_scan_applies_the_driver_loop_limit() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let case = write(d, "case.toml", CASE);
    // A static trip count past the limit (the 100,000), as a `while` loop too.
    let fixed = write(d, "fixed.wgsl", &counting_kernel("line.fixed", "100000u"));
    let whiled = write(
        d,
        "whiled.wgsl",
        "//! id: line.whiled\n//! target: line\nfn method(scene: Scene) -> f32 {\n    var i = 0;\n    \
         while (i < 100000) {\n        i = i + 1;\n    }\n    return f32(i);\n}\n",
    );
    // Never ends: the driver cuts it, and its values were negative (the 498).
    let endless = write(
        d,
        "endless.wgsl",
        "//! id: line.endless\n//! target: line\nfn method(scene: Scene) -> f32 {\n    var c = 0.0;\n    \
         loop {\n        c -= 1.0;\n        if (c > 1.0) { break; }\n    }\n    return c;\n}\n",
    );
    // Data-dependent trips past half the limit on every configuration (|p1| < 60).
    let reaching = write(
        d,
        "reaching.wgsl",
        &counting_kernel("line.reaching", "40000u + u32(length(scene.p1))"),
    );
    let out = d.join("reports");
    let before = snapshot(d);
    let scan = |kernel: &Path, id: &str| {
        linelight(&[
            "scan",
            s(&case),
            "--kernel",
            s(kernel),
            "--methods",
            id,
            "--count",
            "2000",
            "--bound",
            "70000",
            "--out",
            s(&out),
        ])
    };
    let o = scan(&fixed, "line.fixed");
    refused(
        &o,
        &[
            "fixed.wgsl",
            "`line.fixed` executes 100000 loop-body iterations",
            "65535",
        ],
    );
    let o = scan(&whiled, "line.whiled");
    refused(&o, &["line.whiled", "loop"]);
    for (k, id) in [(&endless, "line.endless"), (&reaching, "line.reaching")] {
        let o = scan(k, id);
        refused(
            &o,
            &[
                &format!("{id} on family `diffuse` is refused: on "),
                "half this device's loop limit",
            ],
        );
        assert!(!stderr(&o).contains("cannot write"), "{}", stderr(&o));
    }
    only_changed(&before, &snapshot(d), &[]);
    assert!(!out.exists());

    // Counting trips does not change the values: a data-dependent loop well inside the limit
    // gives its trip count, so every value is above a bound just below it.
    let fine = write(
        d,
        "fine.wgsl",
        &counting_kernel("line.fine", "1000u + u32(scene.p1.z * 0.0)"),
    );
    let o = linelight(&[
        "scan",
        s(&case),
        "--kernel",
        s(&fine),
        "--methods",
        "line.fine",
        "--count",
        "2000",
        "--bound",
        "999.5",
        "--out",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let summary = common::json(&out.join("tiny-scan/summary.json"));
    assert_eq!(summary[0]["configurations"], 2000);
    assert_eq!(summary[0]["above_bound"], 2000, "{summary}");
    assert_eq!(summary[0]["negative"], 0);
}

#[test]
fn class2_scan_evaluates_only_configurations_the_sweep_would() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    // Distances from 1e-300 to 1e300: most generated segments do not fit f32. The sweep refuses
    // the case (too many redraws); the scan counted their NaN and inf as the method's. (With
    // 1e±30 a third did not fit, whose redraws sit at the 20-configuration case's limit of 10:
    // the refusal then depended on the draws, and the per-configuration streams of the sharded
    // sweep drew fewer.)
    let far = CASE.replace(
        "center = ",
        "distance = { dist = \"log_uniform\", min = 1e-300, max = 1e300 }\ncenter = ",
    );
    let case = write(d, "case.toml", &far);
    let out = d.join("reports");
    let before = snapshot(d);
    let o = linelight(&["sweep", s(&case), "--out", s(&out)]);
    refused(&o, &["materials `diffuse`", "draws were degenerate"]);
    let o = linelight(&[
        "scan",
        s(&case),
        "--count",
        "100000",
        "--methods",
        "line.ltc2023",
        "--out",
        s(&out),
    ]);
    refused(
        &o,
        &[
            "family `diffuse`",
            "generated configurations were degenerate",
            "not representable in f32",
        ],
    );
    only_changed(&before, &snapshot(d), &[]);
    assert!(!out.exists());
}

#[test]
fn class2_bench_times_no_loop_the_driver_cut_short() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let case = write(d, "case.toml", CASE);
    let reaching = write(
        d,
        "reaching.wgsl",
        &counting_kernel("line.reaching", "40000u + u32(scene.p1.z * 0.0)"),
    );
    let json = d.join("bench.json");
    let before = snapshot(d);
    let o = linelight(&[
        "bench",
        s(&case),
        "--kernel",
        s(&reaching),
        "--methods",
        "line.reaching",
        "--count",
        "64",
        "--repeats",
        "1",
        "--warmup",
        "0",
        "--json",
        s(&json),
    ]);
    refused(
        &o,
        &["line.reaching is refused: on 64 of 64 configurations", "loop limit"],
    );
    only_changed(&before, &snapshot(d), &[]);
}

#[test]
fn class2_float_options_must_be_finite_and_in_range() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let case = write(d, "case.toml", CASE);
    let out = d.join("reports");
    let before = snapshot(d);
    for bound in ["NaN", "inf", "-inf", "1e300", "0", "-1"] {
        // `--bound=-1`: clap reads a separate `-1` as a flag.
        let flag = format!("--bound={bound}");
        let o = linelight(&["scan", s(&case), "--count", "100", &flag, "--out", s(&out)]);
        refused(&o, &["--bound", bound, "must be above 0"]);
    }
    for noise in ["NaN", "inf", "1e300", "1.5", "-0.1"] {
        let (n, g) = (format!("--noise={noise}"), format!("--ops-growth={noise}"));
        let o = linelight(&["diff", s(&case), "line.ltc2023", "line.ltc2017", &n]);
        refused(&o, &["--noise", noise, "must be from 0 to 1"]);
        let o = linelight(&["sweep", s(&case), "--out", s(&out), &n]);
        refused(&o, &["--noise", noise]);
        let o = linelight(&["sweep", s(&case), "--out", s(&out), &g]);
        refused(&o, &["--ops-growth", noise]);
    }
    let o = linelight(&["scan", s(&case), "--count", "100", "--bound", "lots", "--out", s(&out)]);
    refused(&o, &["--bound", "`lots` is not a number"]);
    only_changed(&before, &snapshot(d), &[]);
    assert!(!out.exists());
}

/// `sweep --shard I/2` of `case` with `kernel`, run from `dir`, into `dir/sI`.
fn shards(dir: &Path, extra: &[&str]) {
    for i in 0..2 {
        let shard = format!("{i}/2");
        let out = format!("s{i}");
        let mut args = vec![
            "sweep",
            "case.toml",
            "--kernel",
            "k.wgsl",
            "--shard",
            &shard,
            "--out",
            &out,
        ];
        args.extend(extra);
        let o = linelight_in(dir, &args);
        assert!(o.status.success(), "{}", stderr(&o));
    }
}

#[test]
fn class2_merge_checks_what_the_shards_ran_and_works_from_any_folder() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let work = d.join("work");
    let other = d.join("elsewhere");
    std::fs::create_dir_all(&work).unwrap();
    std::fs::create_dir_all(&other).unwrap();
    write(&work, "case.toml", CASE);
    let kernel = "//! id: line.mine\n//! target: line\nfn method(scene: Scene) -> f32 {\n    \
                  return length(scene.p2 - scene.p1) * 0.1;\n}\n";
    let k = write(&work, "k.wgsl", kernel);
    shards(&work, &[]);
    let merge = |out: &str| linelight_in(&other, &["merge", "../work/s0", "../work/s1", "--out", out]);

    // From another folder: the case and kernel are found beside the records.
    let o = merge("merged");
    assert!(o.status.code().is_some_and(|c| c <= 1), "{}", stderr(&o));
    let summary = std::fs::read_to_string(other.join("merged/tiny/summary.json")).unwrap();
    assert!(
        summary.contains("line.mine"),
        "the --kernel method is in the merged report"
    );

    // A kernel changed since sharding: refused, naming it, nothing written.
    std::fs::write(&k, kernel.replace("0.1", "0.2")).unwrap();
    let before = snapshot(d);
    let o = merge("again");
    refused(&o, &["k.wgsl", "changed since the shards ran", "re-run the shards"]);
    only_changed(&before, &snapshot(d), &[]);
    std::fs::write(&k, kernel).unwrap();
    // The case file too.
    let case = work.join("case.toml");
    std::fs::write(&case, format!("{CASE}\n# edited\n")).unwrap();
    let before = snapshot(d);
    refused(&merge("again"), &["case.toml", "changed since the shards ran"]);
    only_changed(&before, &snapshot(d), &[]);
    std::fs::write(&case, CASE).unwrap();

    // A record of an older format: re-run the shards. (Format 3 had the same `state.format`.)
    let record = work.join("s0/shard-0-of-2.cbor");
    let good = std::fs::read(&record).unwrap();
    let mut value: ciborium::Value = ciborium::from_reader(good.as_slice()).unwrap();
    let state = value
        .as_map_mut()
        .unwrap()
        .iter_mut()
        .find(|(k, _)| k.as_text() == Some("state"))
        .map(|(_, v)| v)
        .unwrap();
    for (k, v) in state.as_map_mut().unwrap() {
        if k.as_text() == Some("format") {
            *v = ciborium::Value::Integer(3.into());
        }
    }
    let mut old = Vec::new();
    ciborium::into_writer(&value, &mut old).unwrap();
    std::fs::write(&record, &old).unwrap();
    let before = snapshot(d);
    refused(&merge("again"), &["shard-0-of-2.cbor", "format 3", "re-run the shards"]);
    // A truncated record is said in words, not as a Rust debug value.
    std::fs::write(&record, &good[..good.len() / 2]).unwrap();
    let o = merge("again");
    refused(&o, &["shard-0-of-2.cbor", "ends early"]);
    assert!(
        !stderr(&o).contains("Io(") && !stderr(&o).contains("UnexpectedEof"),
        "{}",
        stderr(&o)
    );
    only_changed(&before, &snapshot(d), &["work/s0"]);
    std::fs::write(&record, &good).unwrap();

    // A shard given twice, and shards of another --count: in words, no `Some(50)`.
    let o = linelight_in(&other, &["merge", "../work/s0", "../work/s0", "--out", "again"]);
    refused(&o, &["shard 0/2 is given twice"]);
    let count = d.join("count");
    std::fs::create_dir_all(&count).unwrap();
    write(&count, "case.toml", CASE);
    write(&count, "k.wgsl", kernel);
    shards(&count, &["--count", "50"]);
    let o = linelight_in(&other, &["merge", "../count/s0", "../work/s1", "--out", "again"]);
    refused(&o, &["--count 50", "the case's counts"]);
    assert!(!stderr(&o).contains("Some("), "{}", stderr(&o));
    assert!(!other.join("again").exists());
}

#[test]
fn class2_chain_count_zero_is_refused() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let case = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/ggx.toml");
    let out = d.join("chain");
    let before = snapshot(d);
    let o = linelight(&["chain", s(&case), "--count", "0", "--out", s(&out)]);
    refused(&o, &["--count must be at least 1"]);
    only_changed(&before, &snapshot(d), &[]);
    assert!(!out.exists());
}

#[test]
fn class2_bins_and_maps_on_axes_the_case_never_draws_are_refused() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let out = d.join("reports");
    let alpha_map = format!(
        "{CASE}[[maps]]\nx = {{ axis = \"alpha\", edges = [0.1, 0.5, 1.0] }}\ny = {{ axis = \"elevation\", edges = [10.0, 50.0, 90.0] }}\n"
    );
    let radius_bins = format!("{CASE}[[bins]]\naxis = \"radius\"\nedges = [0.01, 0.1]\n");
    let view_map = format!(
        "{CASE}[[maps]]\nx = {{ axis = \"length\", edges = [0.1, 1.0] }}\ny = {{ axis = \"view_angle\", edges = [0.0, 45.0] }}\n"
    );
    // Drawn, but the edges miss every value the case draws (elevation is 10°–90°).
    let missed = format!(
        "{CASE}[[maps]]\nx = {{ axis = \"length\", edges = [0.1, 1.0] }}\ny = {{ axis = \"elevation\", edges = [100.0, 150.0] }}\n"
    );
    for (case, what) in [
        (
            &alpha_map,
            &[
                "`maps[0]` (alpha × elevation): `x.axis` = \"alpha\"",
                "no family of the case draws it",
            ][..],
        ),
        (
            &radius_bins,
            &["`bins[0].axis` = \"radius\"", "a geometry with a `radius`"][..],
        ),
        (
            &view_map,
            &["`maps[0]` (length × view_angle): `y.axis` = \"view_angle\""][..],
        ),
        (
            &missed,
            &[
                "`maps[0]` (length × elevation): `y.edges` = [100 … 150]",
                "drawn only in [10, 90]",
            ][..],
        ),
    ] {
        let path = write(d, "case.toml", case);
        let before = snapshot(d);
        let o = linelight(&["sweep", s(&path), "--out", s(&out)]);
        let mut what = what.to_vec();
        what.push("case.toml");
        refused(&o, &what);
        only_changed(&before, &snapshot(d), &[]);
        assert!(!out.exists());
    }
}

#[test]
fn axis_ranges_agree_with_the_sampler() {
    // The check above reads which families draw an axis from the case; the sampler is what
    // draws them. Over every committed case: NaN exactly where no value is drawn, and drawn
    // parameters within their distribution's range.
    for e in std::fs::read_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/cases"))
        .unwrap()
        .flatten()
        // cases/render/ holds render scenes, not sweep cases.
        .filter(|e| e.path().extension().is_some_and(|x| x == "toml"))
    {
        let mut case = linelight::input::case::Case::load(&e.path()).unwrap();
        for m in &mut case.materials {
            m.count = m.count.min(200);
        }
        let samples = linelight::input::sampler::sample_case(&case);
        for s in &samples {
            let family = &case.materials[s.material];
            for axis in linelight::input::case::AXES {
                let v = s.axes.get(axis);
                match linelight::input::case::values::axis_range(&case, family, axis) {
                    None => assert!(v.is_nan(), "{}: `{}` draws {axis} = {v}", case.name, family.name),
                    Some((lo, hi)) => assert!(
                        v.is_finite() && lo - 1e-9 * lo.abs() <= v && v <= hi + 1e-9 * hi.abs(),
                        "{}: `{}`: {axis} = {v} outside [{lo}, {hi}]",
                        case.name,
                        family.name
                    ),
                }
            }
        }
    }
}

// ---- Class 3: panics and aborts ----

#[test]
fn class3_sizes_are_capped_before_they_reach_a_panic() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let case = write(d, "case.toml", CASE);
    let out = d.join("reports");
    let table = d.join("t.csv");
    let before = snapshot(d);
    for capture in ["2000000", "100000000000", "18446744073709551615"] {
        let o = linelight(&[
            "scan",
            s(&case),
            "--count",
            "100",
            "--capture",
            capture,
            "--out",
            s(&out),
        ]);
        refused(&o, &[&format!("--capture {capture}"), "at most 65536"]);
    }
    for size in ["4294967296", "65536", "257", "18446744073709551615"] {
        let start = std::time::Instant::now();
        let o = linelight(&["fit", "--out", s(&table), "--size", size]);
        refused(&o, &[&format!("--size {size} × {size}"), "65536 entries"]);
        assert!(start.elapsed().as_secs() < 30, "refused, not fitted");
    }
    let o = linelight(&[
        "fit",
        "--aniso",
        "--out",
        s(&table),
        "--aniso-size",
        "100000,100000,100000,100000",
    ]);
    refused(&o, &["--aniso-size 100000 × 100000 × 100000 × 100000"]);
    only_changed(&before, &snapshot(d), &[]);
    assert!(!out.exists());
}

// ---- Class 5: messages ----

#[test]
fn class5_a_loop_limit_refusal_is_not_a_failed_write() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let input = write(d, "in.jsonl", &format!("{CONFIG}\n"));
    let output = write(d, "out.jsonl", "earlier results\n");
    let endless = write(
        d,
        "reaching.wgsl",
        &counting_kernel("line.reaching", "40000u + u32(scene.p1.z)"),
    );
    let before = snapshot(d);
    let o = eval(
        &input,
        &output,
        &["--kernel", s(&endless), "--methods", "line.reaching"],
    );
    refused(
        &o,
        &[
            "error: line.reaching is refused: on 1 of 1 configurations",
            "loop limit",
        ],
    );
    assert!(!stderr(&o).contains("cannot write"), "{}", stderr(&o));
    // The earlier output is left whole.
    only_changed(&before, &snapshot(d), &[]);
}

#[test]
fn class5_check_applies_the_loop_limit_eval_applies() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let input = write(d, "in.jsonl", &format!("{CONFIG}\n"));
    let output = d.join("out.jsonl");
    let fixed = write(d, "fixed.wgsl", &counting_kernel("line.fixed", "100000u"));
    let fine = write(d, "fine.wgsl", &counting_kernel("line.fine", "1000u"));
    let before = snapshot(d);
    let checked = linelight(&["check", s(&fixed), s(&fine)]);
    let evaluated = eval(&input, &output, &["--kernel", s(&fixed), "--methods", "line.fixed"]);
    let why = "fixed.wgsl: `line.fixed` executes 100000 loop-body iterations per configuration";
    refused(&checked, &[why]);
    refused(&evaluated, &[why]);
    // The other kernel is still checked, and said to be within the limit.
    let listed = String::from_utf8_lossy(&checked.stdout).into_owned();
    assert!(
        listed.contains("fine.wgsl: ok (line.fine → line)") && listed.contains("within the device's limit"),
        "{listed}"
    );
    only_changed(&before, &snapshot(d), &[]);
}

#[test]
fn class5_sizes_and_numbers_read_as_written() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let input = write(d, "in.jsonl", &format!("{CONFIG}\n"));
    let output = d.join("out.jsonl");
    let before = snapshot(d);
    let o = eval(&input, &output, &["--max-memory", "1"]);
    refused(&o, &["more than --max-memory 1 B:"]);
    assert!(!stderr(&o).contains("default"), "{}", stderr(&o));
    // |p| of 1e308 coordinates is 1.4e308, not the overflow of their squares.
    let big = write(
        d,
        "big.jsonl",
        &(CONFIG.replace("[0.3,-0.2,1.0]", "[1e308,0,1e308]") + "\n"),
    );
    let o = eval(&big, &output, &[]);
    refused(
        &o,
        &["big.jsonl:1:", "max(|p1|, |p2|) = 1.4142135623730951e308 is outside"],
    );
    assert!(!stderr(&o).contains("= inf"), "{}", stderr(&o));
    only_changed(&before, &snapshot(d), &["big.jsonl"]);
}

#[test]
fn class5_a_full_disk_names_the_file() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let input = write(d, "in.jsonl", &format!("{CONFIG}\n"));
    let case = write(d, "case.toml", CASE);
    let out = d.join("reports");
    let before = snapshot(d);
    // /dev/full: every write fails with ENOSPC.
    let o = linelight(&[
        "eval",
        "--input",
        s(&input),
        "--output",
        "/dev/full",
        "--methods",
        "line.ltc2023",
    ]);
    refused(&o, &["cannot write /dev/full: No space left on device"]);
    let o = linelight(&["sweep", s(&case), "--out", s(&out), "--raw", "/dev/full"]);
    refused(&o, &["cannot write /dev/full: No space left on device"]);
    only_changed(&before, &snapshot(d), &[]);
    assert!(!out.exists(), "no report set after a failed --raw");
}

#[test]
fn class5_glsl_errors_are_the_kernels_own() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let glsl = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/kernels/glsl/line_ltc2017.glsl"))
        .unwrap()
        .replace("line.ltc2017_glsl", "line.mine_glsl");
    // A byte-order mark is not an error (as in a WGSL kernel or a case file).
    let bom = write(d, "bom.glsl", &format!("\u{feff}{glsl}"));
    // A character GLSL does not have, on line 3: named there, not in the prelude.
    let mut lines: Vec<&str> = glsl.lines().collect();
    let at = lines.iter().position(|l| !l.starts_with("//")).unwrap();
    let bad_line = format!("@ {}", lines[at]);
    lines[at] = &bad_line;
    let stray = write(d, "stray.glsl", &(lines.join("\n") + "\n"));
    let before = snapshot(d);
    let o = linelight(&["check", s(&bom)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = linelight(&["check", s(&stray)]);
    refused(
        &o,
        &[&format!("stray.glsl:{}: 1:", at + 1), "'@' is not a GLSL character"],
    );
    assert!(!stderr(&o).contains("prelude"), "{}", stderr(&o));
    only_changed(&before, &snapshot(d), &[]);
}
