//! Promises of the README's exit table and docs/robustness.md that no other test kept: each
//! runs the CLI and asserts the exit code, the message, and that nothing outside the intended
//! files changed.

use crate::common;
use common::CONFIG;

use common::snapshot::{only_changed, refused, s, snapshot};
use common::{case, eval, linelight, linelight_with, stderr, write};
use std::process::Command;

/// Two methods on the tiny case.
fn tiny() -> String {
    case("tiny")
        .methods(&["line.ltc2017", "line.numeric@16"])
        .diffuse(20)
        .to_string()
}

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
    let o = eval(&input, &d.join("out.jsonl"), &[]);
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
    let o = linelight(&args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(std::fs::read_to_string(&output).unwrap().starts_with(r#"{"id":"a""#));
}

#[test]
fn an_injected_dispatch_failure_ends_a_sweep_with_exit_4_and_keeps_the_earlier_reports() {
    let tiny = tiny();
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let case = write(d, "case.toml", &tiny);
    let reports = d.join("reports");
    let raw = d.join("raw.jsonl");
    let args = ["sweep", s(&case), "--out", s(&reports), "--raw", s(&raw)];
    let o = linelight(&args);
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
        let o = linelight(args);
        assert_eq!(o.status.code(), Some(0), "{args:?}: {}", stderr(&o));
        let out = String::from_utf8_lossy(&o.stdout);
        assert!(!out.trim().is_empty(), "{args:?} printed nothing");
    }
    let version = linelight(&["--version"]);
    let v = String::from_utf8_lossy(&version.stdout);
    assert_eq!(v.trim(), format!("linelight {}", env!("CARGO_PKG_VERSION")));
    let adapters = linelight(&["adapters"]);
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
    let tiny = tiny();
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let ltc = |aspect: &str, peak: &str| {
        format!(
            "{tiny}[[materials]]\nname = \"l\"\nkind = \"ltc_full\"\ncount = 5\n\
             alpha = {{ dist = \"fixed\", value = 0.3 }}\naspect = {aspect}\npeak = {peak}\n\
             shear = {{ dist = \"fixed\", value = 0.0 }}\nrotation = {{ dist = \"fixed\", value = 0.0 }}\n"
        )
    };
    let fixed = |v: &str| format!("{{ dist = \"fixed\", value = {v} }}");
    let two = tiny.replace(
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
            tiny.replace(
                "center = ",
                "rect_width = { dist = \"uniform\", min = -0.1, max = 0.1 }\ncenter = ",
            ),
            "`geometry.rect_width` = uniform [-0.1, 0.1]: must draw only values > 0",
        ),
        (
            format!("{tiny}[search]\nmethods = [\"line.ltc2017\"]\nrestarts = 1\nsteps = 20000\npopulation = 2\n"),
            "`search.steps` = 20000: at most 10000",
        ),
        (
            format!("{tiny}[search]\nmethods = [\"line.ltc2017\"]\nrestarts = 1\nsteps = 2\npopulation = 0\n"),
            "`search.restarts` = 1, `search.population` = 0: both must be at least 1",
        ),
        (
            format!("{two}[disagreements]\nepsilon = 0.0\n"),
            "`disagreements.epsilon` = 0: the smallest error a ratio divides by must be a finite number > 0",
        ),
        (
            tiny.replace(
                "methods = [\"line.ltc2017\", \"line.numeric@16\"]",
                "methods = [\"line.ltc2017\", \"line.numeric@16\"]\ncompare = [[\"line.ltc2017\", \"line.ltc2017\"]]",
            ),
            "`compare[0]` = [\"line.ltc2017\", \"line.ltc2017\"]: a method compared with itself",
        ),
    ];
    for (case, what) in cases {
        let path = write(d, "case.toml", &case);
        let before = snapshot(d);
        let o = linelight(&["sweep", s(&path), "--out", s(&d.join("reports"))]);
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
        let o = eval(&input, &d.join("out.jsonl"), &[]);
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
    let o = eval(&input, &d.join("out.jsonl"), &["--methods", "caps.point"]);
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
    let o = eval(&input, &d.join("out.jsonl"), &[]);
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
    let tiny = tiny();
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    // A maximum is judged from any number of configurations (a p99 of 20 would be no verdict).
    let failing_tolerance = format!("{tiny}[tolerances.\"line.ltc2017\"]\nmax = 1e-12\n");
    let stale_claim = format!(
        "{tiny}[[claims]]\nid = \"never\"\nexpect = 'p99(\"line.ltc2017\", \"diffuse\") < 1e-12'\ntext = \"never\"\n"
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
        let o = eval(&input, &output, &["--kernel", s(&kernel), "--methods", "user.k"]);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(stderr(&o).contains(what), "`{what}` not in {}", stderr(&o));
        only_changed(&before, &snapshot(d), &[]);
    }
    // An output replaced keeps its permission bits.
    let output = write(d, "out.jsonl", "old\n");
    std::fs::set_permissions(&output, std::fs::Permissions::from_mode(0o640)).unwrap();
    let o = eval(&input, &output, &["--methods", "line.ltc2017"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let mode = std::fs::metadata(&output).unwrap().permissions().mode() & 0o7777;
    assert_eq!(mode, 0o640, "{mode:o}");
    assert!(std::fs::read_to_string(&output).unwrap().starts_with(r#"{"id":"a""#));
}

#[test]
fn a_killed_sweep_leaves_the_earlier_outputs_whole() {
    let tiny = tiny();
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let case = write(d, "case.toml", &tiny);
    let reports = d.join("reports");
    let raw = d.join("raw.jsonl");
    let args = ["sweep", s(&case), "--out", s(&reports), "--raw", s(&raw)];
    let o = linelight(&args);
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
    let o = linelight(&args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let left: Vec<_> = snapshot(d)
        .into_keys()
        .filter(|p| p.to_string_lossy().contains(".tmp-"))
        .collect();
    assert!(left.is_empty(), "temporaries left: {left:?}");
}

// ---------------------------------------------------------------------------------------------
// An output that cannot be written. The tests run as root, whom permission bits do not stop:
// a file made immutable (`chattr +i`, which stops root too) is refused before any work; a path
// where nothing can be created (procfs, mounted on every Linux machine and container) fails
// with exit 2 when it is created.

/// `chattr +i` on `path` for as long as the guard lives; None where the file system or the
/// missing capability (CAP_LINUX_IMMUTABLE, which a default container lacks) does not allow it.
struct Immutable(std::path::PathBuf);

impl Immutable {
    fn set(path: &std::path::Path) -> Result<Immutable, String> {
        let o = Command::new("chattr").arg("+i").arg(path).output();
        match o {
            Ok(o) if o.status.success() => Ok(Immutable(path.to_path_buf())),
            Ok(o) => Err(format!("chattr +i: {}", String::from_utf8_lossy(&o.stderr).trim())),
            Err(e) => Err(format!("chattr: {e}")),
        }
    }
}

impl Drop for Immutable {
    fn drop(&mut self) {
        // The temporary folder could not be removed otherwise.
        let _ = Command::new("chattr").arg("-i").arg(&self.0).status();
    }
}

#[test]
fn an_output_that_cannot_be_written_is_refused_before_any_work() {
    let tiny = tiny();
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let input = write(d, "in.jsonl", &format!("{CONFIG}\n"));
    let case = write(d, "case.toml", &tiny);
    // procfs: no file can be created in /proc, root or not. access(2) lets root through, so
    // this is found when the file is created, after the run (not before any work, as for the
    // immutable file below): still exit 2 naming the path, and nothing changed.
    let proc_out = "/proc/linelight-promises-out.jsonl";
    let before = snapshot(d);
    let o = linelight_with(
        &[],
        &[
            "eval",
            "--input",
            s(&input),
            "--output",
            proc_out,
            "--methods",
            "line.ltc2017",
        ],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(&format!("cannot write {proc_out}")),
        "{}",
        stderr(&o)
    );
    assert!(!std::path::Path::new(proc_out).exists());
    only_changed(&before, &snapshot(d), &[]);

    // An immutable file, for root as for anyone: refused by the output plan, nothing run.
    let old = write(d, "old.jsonl", "old\n");
    let raw = write(d, "raw.jsonl", "old raw\n");
    let guard = match Immutable::set(&old) {
        Ok(g) => g,
        Err(why) => {
            return common::skip_or_fail(
                "an_output_that_cannot_be_written_is_refused_before_any_work (immutable file)",
                &why,
            )
        }
    };
    let before = snapshot(d);
    let o = eval(&input, &old, &["--methods", "line.ltc2017"]);
    refused(
        &o,
        &[&format!("--output {}: permission denied (not writable)", s(&old))],
    );
    // A sweep whose --raw cannot be written writes no report either.
    let o = linelight_with(
        &[],
        &["sweep", s(&case), "--out", s(&d.join("reports")), "--raw", s(&old)],
    );
    refused(&o, &[&format!("--raw {}: permission denied (not writable)", s(&old))]);
    only_changed(&before, &snapshot(d), &[]);
    assert!(!d.join("reports").exists());
    drop(guard);
    // Writable again, the same eval replaces it.
    let o = eval(&input, &raw, &["--methods", "line.ltc2017"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

// ---------------------------------------------------------------------------------------------
// The memory budget: a kernel's private memory in `check`, and the default limit.

/// MemTotal of /proc/meminfo in bytes, read here, apart from src/limits.rs.
fn mem_total() -> u64 {
    let m = std::fs::read_to_string("/proc/meminfo").unwrap();
    let kib: u64 = m
        .lines()
        .find_map(|l| l.strip_prefix("MemTotal:"))
        .and_then(|v| v.trim().strip_suffix("kB"))
        .map(|v| v.trim().parse().unwrap())
        .expect("MemTotal in /proc/meminfo");
    kib * 1024
}

/// The invocations in flight docs/robustness.md counts: a 64-wide workgroup per core.
fn in_flight() -> u64 {
    64 * std::thread::available_parallelism().map_or(1, |n| n.get() as u64)
}

/// A kernel holding `private` f32s in a `var<private>` array and `local` in a local array.
fn big_kernel(id: &str, private: u64, local: u64) -> String {
    format!(
        "//! id: {id}\n//! target: line\nvar<private> big: array<f32, {private}>;\n\
         fn method(scene: Scene) -> f32 {{\n    var near: array<f32, {local}>;\n    \
         big[0] = scene.p1.z;\n    near[0] = scene.p2.z;\n    return big[0] + near[0];\n}}\n"
    )
}

#[test]
fn check_counts_a_kernels_private_and_local_memory_against_the_limit() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    // 512 KiB private + 512 KiB local = 1 MiB per invocation.
    let kernel = write(d, "big.wgsl", &big_kernel("user.big", 1 << 17, 1 << 17));
    let n = in_flight();
    let before = snapshot(d);
    // The two arrays are 1 MiB; the prelude's and the entry point's own locals add a few bytes.
    // At 1 MiB per invocation in flight: refused, naming the file, the parts and the limit.
    let limit = n << 20;
    let o = linelight(&["check", s(&kernel), "--max-memory", &limit.to_string()]);
    refused(
        &o,
        &[
            &format!(
                "big.wgsl: its private and local variables (1.0 MiB per invocation, × {n} invocations in \
                 flight) needs an estimated {}",
                linelight::limits::Bytes(n << 20)
            ),
            "more than --max-memory",
        ],
    );
    assert!(String::from_utf8_lossy(&o.stdout).trim().is_empty());
    // With 4 KiB per invocation to spare: the kernel is fine.
    let o = linelight_with(
        &[],
        &[
            "check",
            s(&kernel),
            "--max-memory",
            &(n * ((1 << 20) + 4096)).to_string(),
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        String::from_utf8_lossy(&o.stdout).contains("big.wgsl: ok (user.big → line)"),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    // The private array alone is half as much: within the limit the whole kernel exceeds.
    let half = write(d, "half.wgsl", &big_kernel("user.half", 1 << 17, 1));
    let o = linelight(&["check", s(&half), "--max-memory", &limit.to_string()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // eval applies the same rule to a --kernel file, before any input is read.
    let input = write(d, "in.jsonl", &format!("{CONFIG}\n"));
    let before_eval = snapshot(d);
    let o = eval(
        &input,
        &d.join("out.jsonl"),
        &["--kernel", s(&kernel), "--max-memory", &limit.to_string()],
    );
    refused(
        &o,
        &["big.wgsl: its private and local variables (1.0 MiB per invocation"],
    );
    only_changed(&before_eval, &snapshot(d), &[]);
    only_changed(&before, &snapshot(d), &["half.wgsl", "in.jsonl"]);
}

#[test]
fn the_default_memory_limit_is_half_of_memtotal_and_refuses_above_it() {
    let half = mem_total() / 2;
    assert_eq!(linelight::limits::default_max_memory().0, half);
    let named = format!(
        "more than the default limit {} (half of this machine's memory)",
        linelight::limits::Bytes(half)
    );
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    // A kernel whose private array times the invocations in flight exceeds the default, with
    // no --max-memory: refused by `check`, naming the default.
    // 1 GiB private and 1 GiB local (naga lays out no type of 2 GiB or more).
    let per = 2u64 << 30;
    let kernel = write(d, "huge.wgsl", &big_kernel("user.huge", 1 << 28, 1 << 28));
    let before = snapshot(d);
    let o = linelight(&["check", s(&kernel)]);
    if per * in_flight() > half {
        refused(&o, &["huge.wgsl: its private and local variables", &named]);
    } else {
        // A machine with more memory than 2 GiB × the invocations in flight × 2.
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    }
    // A sweep whose statistics exceed it: a 2000 × 2000 map is 4,000,000 cells of 8 KiB
    // (32 GiB) per method and material.
    let edges = |n: usize, lo: f64, hi: f64| {
        (0..=n)
            .map(|i| format!("{}", lo + (hi - lo) * i as f64 / n as f64))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let map = write(
        d,
        "map.toml",
        &format!(
            "{}[[maps]]\nx = {{ axis = \"elevation\", edges = [{}] }}\ny = {{ axis = \"tilt\", edges = [{}] }}\n",
            common::CASE,
            edges(2000, 10.0, 90.0),
            edges(2000, 0.0, 180.0)
        ),
    );
    // (Run only where it is refused: elsewhere it would measure 4,000,000 cells.)
    if 4_000_000u64 * (8 << 10) > half {
        let before_map = snapshot(d);
        let o = linelight(&["sweep", s(&map), "--out", s(&d.join("r"))]);
        refused(&o, &["4000000 map cells", &named]);
        only_changed(&before_map, &snapshot(d), &[]);
    }
    only_changed(&before, &snapshot(d), &["map.toml"]);
    // Given, the limit is named as --max-memory, not as the default.
    let o = linelight(&["check", s(&kernel), "--max-memory", "1M"]);
    refused(&o, &["more than --max-memory 1.0 MiB"]);
    assert!(!stderr(&o).contains("default"), "{}", stderr(&o));
}

// ---------------------------------------------------------------------------------------------
// A reference that cannot be computed: exit 2 naming the configuration, never a NaN row.

#[test]
fn a_reference_that_is_not_finite_is_exit_2_naming_the_configuration() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    // Extreme but valid: every entry of M⁻¹ within 2^60, its determinant 1e-264 (not 0), the
    // segment crossing the horizon. The lobe's condition number ‖M⁻¹‖·‖adj M⁻¹‖/det overflows
    // and D underflows to 0, so the reference's error estimate is 0 × ∞ = NaN. No test hook:
    // this is what a user can send.
    let bad = r#"{"id":"cond","p1":[0.3,-0.2,0.001],"p2":[0.9,0.4,-0.002],"material":{"kind":"ltc","minv":[[1e18,0,0],[0,1e18,0],[0,0,1e-300]]}}"#;
    let input = write(d, "in.jsonl", &format!("{CONFIG}\n{bad}\n"));
    let output = write(d, "out.jsonl", "old\n");
    let before = snapshot(d);
    let o = eval(&input, &output, &["--methods", "line.ltc2017"]);
    refused(
        &o,
        &[
            "in.jsonl: 3 reference(s) not finite",
            "configuration `cond`: the line reference cannot be computed (value 0, error NaN)",
            "configuration `cond`: the line_upper reference",
            "configuration `cond`: the line_isotropic reference",
        ],
    );
    // The good first line is not written either: the output is replaced only once complete.
    assert!(!stderr(&o).contains("`a`"), "{}", stderr(&o));
    only_changed(&before, &snapshot(d), &[]);
    // Its determinant 1e6 times larger and the references are numbers again (exactly 0).
    let fine = bad.replace("1e-300", "1e-290");
    let input = write(d, "in.jsonl", &format!("{fine}\n"));
    let o = eval(&input, &output, &["--methods", "line.ltc2017"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let row = std::fs::read_to_string(&output).unwrap();
    assert!(row.contains(r#""reference":{"line":0.0,"#), "{row}");
}
