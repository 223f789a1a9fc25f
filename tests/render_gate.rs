//! The render gate (docs/render.md "In the gate"): a render baseline saved from a
//! user kernel on a held-out scene (no shipped scene); the same kernel passes; the kernel with a
//! visible bug (the 1/π of the Lambertian BRDF forgotten) fails with JUnit failures naming it and
//! its regressed pixels replayable; a malformed baseline (another format, a missing image, an
//! image of another size, a scene of another size or another camera, a sweep baseline) is
//! refused with exit 2 and nothing written.

use crate::common;

use common::{stderr, validate_junit, write};
use std::path::{Path, PathBuf};
use std::process::Output;

const KERNEL: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/ci/example/my_line.wgsl");

/// A small held-out scene: a diffuse floor, the user's line kernel beside a built-in.
fn scene(width: u32, camera_y: f64) -> String {
    format!(
        r#"name = "gate_floor"
methods = ["my.line", "line.ltc2023_fix"]
[render]
width = {width}
height = 40
camera = {{ position = [0.3, {camera_y}, 1.4], look_at = [0.0, 0.4, 0.0], fov_deg = 55.0 }}
light = {{ p1 = [-0.7, 0.5, 0.35], p2 = [0.8, 0.3, 0.6] }}
material = {{ kind = "diffuse" }}
"#
    )
}

fn render(dir: &Path, scene: &Path, kernel: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "render".to_string(),
        scene.display().to_string(),
        "--out".into(),
        dir.join("out").display().to_string(),
        "--kernel".into(),
        kernel.display().to_string(),
    ];
    args.extend(extra.iter().map(|s| s.to_string()));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    common::linelight(&args)
}

fn text(o: &Output) -> String {
    format!(
        "exit {:?}\nstdout:\n{}\nstderr:\n{}",
        o.status.code(),
        String::from_utf8_lossy(&o.stdout),
        stderr(o)
    )
}

/// The example kernel with the Lambertian 1/π forgotten: every pixel π times too bright.
fn without_one_over_pi(dir: &Path) -> PathBuf {
    let base = std::fs::read_to_string(KERNEL).unwrap();
    assert!(base.contains("    return I / PI;"));
    write(
        dir,
        "my_line.wgsl",
        &base.replace("    return I / PI;", "    return I;"),
    )
}

#[test]
fn an_unchanged_render_passes_and_a_visibly_worse_kernel_fails() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let s = write(d, "scene.toml", &scene(64, -3.0));
    let base = d.join("base");
    let o = render(d, &s, Path::new(KERNEL), &["--save-baseline", base.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let index = std::fs::read_to_string(base.join("render-baseline.json")).unwrap();
    let v: serde_json::Value = serde_json::from_str(&index).unwrap();
    assert_eq!(v["format"], 1, "{index}");
    assert_eq!(
        (v["scene"]["width"].as_u64(), v["scene"]["height"].as_u64()),
        (Some(64), Some(40))
    );
    assert_eq!(v["scene"]["configurations_sha256"].as_str().map(str::len), Some(64));
    for m in v["methods"].as_array().unwrap() {
        assert!(base.join(m["image"].as_str().unwrap()).is_file(), "{m}");
        assert_eq!(m["kernel_sha256"].as_str().map(str::len), Some(64), "{m}");
    }
    // Saved again, the same bytes: a baseline is committed and diffed.
    let again = d.join("again");
    let o = render(d, &s, Path::new(KERNEL), &["--save-baseline", again.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert_eq!(
        index,
        std::fs::read_to_string(again.join("render-baseline.json")).unwrap()
    );
    assert_eq!(
        std::fs::read(base.join("images/my.line.png")).unwrap(),
        std::fs::read(again.join("images/my.line.png")).unwrap()
    );

    // The same kernel: unchanged, exit 0, JUnit without a failure.
    let junit = d.join("junit.xml");
    let gate = ["--baseline", base.to_str().unwrap(), "--junit", junit.to_str().unwrap()];
    let o = render(d, &s, Path::new(KERNEL), &gate);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(
        String::from_utf8_lossy(&o.stdout).contains("gate: UNCHANGED"),
        "{}",
        text(&o)
    );
    let xml = std::fs::read_to_string(&junit).unwrap();
    assert!(
        xml.contains("gate_floor.baseline") && !xml.contains("<failure"),
        "{xml}"
    );
    validate_junit(&junit);
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("out/gate_floor/render.json")).unwrap()).unwrap();
    assert_eq!(json["baseline"]["change"], "unchanged", "{}", json["baseline"]);
    let md = std::fs::read_to_string(d.join("out/gate_floor/render.md")).unwrap();
    assert!(md.contains("## Against the baseline"), "{md}");

    // The kernel with the 1/π forgotten: regressed, exit 1, a JUnit failure per rule naming it.
    let worse = without_one_over_pi(d);
    let o = render(d, &s, &worse, &gate);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("gate: REGRESSED") && out.contains("my.line floor image"),
        "{}",
        text(&o)
    );
    assert!(out.contains("my.line floor flip"), "{}", text(&o));
    assert!(
        !out.contains("line.ltc2023_fix floor"),
        "the built-in did not change: {}",
        text(&o)
    );
    let xml = std::fs::read_to_string(&junit).unwrap();
    assert!(
        xml.contains("<failure") && xml.contains("REGRESSED my.line on floor [image]"),
        "{xml}"
    );
    validate_junit(&junit);
    assert!(stderr(&o).contains("kernel changed since the baseline"), "{}", text(&o));
    // The regressed pixels are configurations `eval` replays.
    let regressed = std::fs::read_to_string(d.join("out/gate_floor/regressed.jsonl")).unwrap();
    let lines: Vec<serde_json::Value> = regressed.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert!(lines.len() > 100, "{}", lines.len());
    assert!(lines
        .iter()
        .all(|l| l["id"].as_str().is_some_and(|id| id.contains('_'))));
    let replay = d.join("replay.jsonl");
    let o = common::linelight(&[
        "eval",
        "--input",
        d.join("out/gate_floor/regressed.jsonl").to_str().unwrap(),
        "--output",
        replay.to_str().unwrap(),
        "--methods",
        "line.ltc2023_fix",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
}

#[test]
fn a_malformed_baseline_is_refused_and_nothing_is_written() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let s = write(d, "scene.toml", &scene(48, -3.0));
    let base = d.join("base");
    let o = render(d, &s, Path::new(KERNEL), &["--save-baseline", base.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    std::fs::remove_dir_all(d.join("out")).unwrap();
    let index = std::fs::read_to_string(base.join("render-baseline.json")).unwrap();

    // Each broken copy of the baseline, with the scene it is compared on and what the message says.
    let refused = |name: &str, scene: &Path, break_it: &dyn Fn(&Path), says: &[&str]| {
        let b = d.join(name);
        std::fs::create_dir_all(b.join("images")).unwrap();
        for f in std::fs::read_dir(base.join("images")).unwrap() {
            let f = f.unwrap();
            std::fs::copy(f.path(), b.join("images").join(f.file_name())).unwrap();
        }
        std::fs::write(b.join("render-baseline.json"), &index).unwrap();
        break_it(&b);
        let junit = d.join(format!("{name}.xml"));
        let o = render(
            d,
            scene,
            Path::new(KERNEL),
            &["--baseline", b.to_str().unwrap(), "--junit", junit.to_str().unwrap()],
        );
        assert_eq!(o.status.code(), Some(2), "{name}: {}", text(&o));
        let e = stderr(&o);
        for s in says {
            assert!(e.contains(s), "{name}: `{s}` not in: {e}");
        }
        assert!(e.lines().count() < 8, "{name}: a bounded message: {e}");
        assert!(!d.join("out").exists(), "{name}: nothing written");
        assert!(!junit.exists(), "{name}: no JUnit");
    };
    refused(
        "format",
        &s,
        &|b| {
            let p = b.join("render-baseline.json");
            let t = std::fs::read_to_string(&p)
                .unwrap()
                .replace("\"format\": 1", "\"format\": 2");
            std::fs::write(p, t).unwrap();
        },
        &["render baseline format 2", "reads format 1"],
    );
    refused(
        "missing",
        &s,
        &|b| std::fs::remove_file(b.join("images/my.line.png")).unwrap(),
        &["method `my.line`", "missing or unreadable image"],
    );
    refused(
        "not_png",
        &s,
        &|b| std::fs::write(b.join("images/my.line.png"), b"not an image").unwrap(),
        &["method `my.line`", "not a PNG image"],
    );
    // An image of another size: the reference of a 64-wide save put in this 48-wide baseline.
    let wide = write(d, "wide.toml", &scene(64, -3.0));
    let other = d.join("wide_base");
    let o = render(
        d,
        &wide,
        Path::new(KERNEL),
        &["--save-baseline", other.to_str().unwrap()],
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    std::fs::remove_dir_all(d.join("out")).unwrap();
    refused(
        "image_size",
        &s,
        &|b| {
            std::fs::copy(
                other.join("images/reference_line_upper.png"),
                b.join("images/reference_line_upper.png"),
            )
            .unwrap();
        },
        &["reference `line_upper`", "size mismatch", "64 × 40"],
    );
    refused("scene_size", &wide, &|_| {}, &["size mismatch", "48 × 40", "64 × 40"]);
    let moved = write(d, "moved.toml", &scene(48, -3.2));
    refused(
        "scene_changed",
        &moved,
        &|_| {},
        &["scene changed", "save the baseline again"],
    );
    refused(
        "outside",
        &s,
        &|b| {
            let p = b.join("render-baseline.json");
            let t = std::fs::read_to_string(&p)
                .unwrap()
                .replace("images/my.line.png", "../base/images/my.line.png");
            std::fs::write(p, t).unwrap();
        },
        &["is not inside the baseline folder"],
    );
    refused(
        "no_format",
        &s,
        &|b| std::fs::write(b.join("render-baseline.json"), "{\"scene\": {}}").unwrap(),
        &["no `format` number"],
    );
}

#[test]
fn render_gate_outputs_are_checked_before_any_work() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let s = write(d, "scene.toml", &scene(32, -3.0));
    // A baseline inside the render folder it would be replaced with.
    let inside = d.join("out/gate_floor/base");
    let o = render(d, &s, Path::new(KERNEL), &["--save-baseline", inside.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(!d.join("out").exists(), "{}", text(&o));
    // JUnit without a baseline to compare with.
    let o = render(
        d,
        &s,
        Path::new(KERNEL),
        &["--junit", d.join("j.xml").to_str().unwrap()],
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(stderr(&o).contains("needs --baseline"), "{}", text(&o));
    // A sweep's baseline folder is not a render baseline's, either way.
    let sweep_base = d.join("sweep_base");
    std::fs::create_dir_all(sweep_base.join("errors")).unwrap();
    std::fs::write(sweep_base.join("baseline.json"), "{}").unwrap();
    let o = render(
        d,
        &s,
        Path::new(KERNEL),
        &["--save-baseline", sweep_base.to_str().unwrap()],
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(stderr(&o).contains("baseline folder"), "{}", text(&o));
    let o = render(d, &s, Path::new(KERNEL), &["--baseline", sweep_base.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(stderr(&o).contains("sweep baseline"), "{}", text(&o));
    assert!(!d.join("out").exists(), "{}", text(&o));
    // A noise outside 0..1.
    let o = render(d, &s, Path::new(KERNEL), &["--flip-noise", "2"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
}
