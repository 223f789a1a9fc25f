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

/// CRC-32 (ISO-HDLC, PNG's) of `bytes`.
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= u32::from(b);
        for _ in 0..8 {
            c = if c & 1 == 1 { (c >> 1) ^ 0xEDB8_8320 } else { c >> 1 };
        }
    }
    !c
}

/// A PNG chunk: length, type, data, CRC of type and data.
fn chunk(kind: &[u8; 4], data: &[u8]) -> Vec<u8> {
    let mut body = kind.to_vec();
    body.extend_from_slice(data);
    let mut out = (data.len() as u32).to_be_bytes().to_vec();
    out.extend_from_slice(&body);
    out.extend_from_slice(&crc32(&body).to_be_bytes());
    out
}

/// A 74-byte PNG whose header declares `width` × `height` 8-bit RGB pixels (its data is a
/// fragment of a zlib stream: nothing that could be decoded to that size).
fn declared_png(width: u32, height: u32) -> Vec<u8> {
    let mut ihdr = width.to_be_bytes().to_vec();
    ihdr.extend_from_slice(&height.to_be_bytes());
    ihdr.extend_from_slice(&[8, 2, 0, 0, 0]);
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    png.extend(chunk(b"IHDR", &ihdr));
    png.extend(chunk(
        b"IDAT",
        &[
            0x78, 0x9c, 0xed, 0xc1, 0x01, 0x0d, 0x00, 0x00, 0x00, 0xc2, 0xa0, 0xf7, 0x4f, 0x6d, 0x0e, 0x37, 0xa0,
        ],
    ));
    png.extend(chunk(b"IEND", &[]));
    png
}

#[test]
fn a_render_baseline_image_declaring_a_huge_size_is_refused_before_decoding() {
    let png = declared_png(60000, 60000);
    assert_eq!(png.len(), 74);
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = common::write(
        d,
        "scene.toml",
        r#"name = "gate_floor"
methods = ["my.line", "line.ltc2023_fix"]
[render]
width = 48
height = 40
camera = { position = [0.3, -3.0, 1.4], look_at = [0.0, 0.4, 0.0], fov_deg = 55.0 }
light = { p1 = [-0.7, 0.5, 0.35], p2 = [0.8, 0.3, 0.6] }
material = { kind = "diffuse" }
"#,
    );
    let kernel = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/ci/example/my_line.wgsl");
    let render = |extra: &[&str]| {
        let out = d.join("out");
        let mut args = vec![
            "render",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--kernel",
            kernel,
        ];
        args.extend(extra);
        common::linelight(&args)
    };
    let base = d.join("base");
    let o = render(&["--save-baseline", base.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    std::fs::remove_dir_all(d.join("out")).unwrap();
    std::fs::write(base.join("images/my.line.png"), &png).unwrap();
    let t = Instant::now();
    let o = render(&["--baseline", base.to_str().unwrap()]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(
        e.contains("method `my.line`") && e.contains("60000 × 60000") && e.contains("not decoded"),
        "{e}"
    );
    assert!(t.elapsed() < Duration::from_secs(60), "{:?}", t.elapsed());
    assert!(!d.join("out").exists(), "nothing written");
}

#[test]
fn includes_stay_inside_the_kernel_folder_and_the_include_folders() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let kernels = d.join("kernels");
    let inc = d.join("inc");
    std::fs::create_dir_all(&kernels).unwrap();
    std::fs::create_dir_all(&inc).unwrap();
    // A file outside both folders whose first token would show in a front end's error.
    common::write(d, "secret.glsl", "TOPSECRET_TOKEN = 1;\n");
    std::os::unix::fs::symlink(d.join("secret.glsl"), kernels.join("link.glsl")).unwrap();
    std::os::unix::fs::symlink(d.join("secret.glsl"), inc.join("ilink.glsl")).unwrap();
    let secret = d.join("secret.glsl");
    let absolute = format!("\"{}\"", secret.display());
    for (name, says) in [
        (absolute.as_str(), "not an absolute path"),
        ("\"/etc/passwd\"", "not an absolute path"),
        ("\"../secret.glsl\"", "outside"),
        ("\"link.glsl\"", "outside"),
        ("<ilink.glsl>", "outside"),
        ("<../secret.glsl>", "outside"),
    ] {
        let k = common::write(
            &kernels,
            "k.glsl",
            &format!(
                "//! id: line.inc\n//! target: line\n#include {name}\nfloat method(Scene scene) {{ return 1.0; }}\n"
            ),
        );
        let o = common::linelight(&["check", k.to_str().unwrap(), "--include", inc.to_str().unwrap()]);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{name}: {e}");
        assert!(e.contains("k.glsl:3:") && e.contains(says), "{name}: {e}");
        assert!(
            !e.contains("TOPSECRET") && !e.contains("root:"),
            "{name}: nothing read is echoed: {e}"
        );
    }
    // A WGSL kernel's --include folder is confined the same way (a symlink out is refused).
    let k = common::write(
        &kernels,
        "k.wgsl",
        "//! id: line.inc_wgsl\n//! target: line\n#include \"ilink.glsl\"\nfn method(scene: Scene) -> f32 { return 1.0; }\n",
    );
    let o = common::linelight(&["check", k.to_str().unwrap(), "--include", inc.to_str().unwrap()]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("outside") && !e.contains("TOPSECRET"), "{e}");
    // Inside stays allowed: beside the kernel, in a subfolder, `..` that stays inside, and
    // a symlink whose target is inside.
    std::fs::create_dir_all(kernels.join("sub")).unwrap();
    common::write(&kernels, "two.glsl", "float two() { return 2.0; }\n");
    common::write(&kernels.join("sub"), "one.glsl", "#include \"../two.glsl\"\n");
    std::os::unix::fs::symlink(kernels.join("two.glsl"), inc.join("two_link.glsl")).unwrap();
    let k = common::write(
        &kernels,
        "ok.glsl",
        "//! id: line.inc_ok\n//! target: line\n#include \"sub/one.glsl\"\nfloat method(Scene scene) { return two(); }\n",
    );
    let o = common::linelight(&["check", k.to_str().unwrap(), "--include", inc.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let k = common::write(
        &kernels,
        "ok2.glsl",
        "//! id: line.inc_ok2\n//! target: line\n#include <two_link.glsl>\nfloat method(Scene scene) { return two(); }\n",
    );
    let o = common::linelight(&["check", k.to_str().unwrap(), "--include", inc.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}
