//! Findings computed from the data: the claim engine flags an expectation that fails, the
//! false-light row catches light where none arrives, and the disagreement search finds the
//! region where a pair was built to differ.

use crate::common;
use common::{linelight, stderr, write};
use std::path::{Path, PathBuf};

/// A built-in kernel under a new id, its `method` renamed to `inner` so a test can wrap it.
/// A derived kernel is flattened (its base's text with the replaced functions, then its own)
/// and given its inherited target and M⁻¹ support.
fn wrapped(builtin: &str, id: &str, method: &str) -> String {
    let path = format!("kernels/{builtin}");
    let k = linelight::kernel::builtin_kernels()
        .into_iter()
        .find(|k| k.path == path)
        .unwrap();
    let is_header = |l: &&str| l.trim_start().starts_with("//!");
    let mut header: Vec<String> = k
        .text
        .lines()
        .filter(is_header)
        .filter(|l| !(l.starts_with("//! derive:") || l.starts_with("//! replace:")))
        .map(|l| {
            if l.starts_with("//! id:") {
                format!("//! id: {id}")
            } else {
                l.to_string()
            }
        })
        .collect();
    if !header.iter().any(|l| l.starts_with("//! target:")) {
        header.push(format!("//! target: {}", k.target.name()));
    }
    if !header.iter().any(|l| l.starts_with("//! minv:")) {
        let minv = serde_json::to_value(k.minv).unwrap();
        header.push(format!("//! minv: {}", minv.as_str().unwrap()));
    }
    let body: Vec<String> = k
        .parts()
        .iter()
        .flat_map(|(_, t)| {
            t.lines()
                .filter(|l| !is_header(l))
                .map(str::to_string)
                .collect::<Vec<_>>()
        })
        .collect();
    format!(
        "{}\n{}\n{method}\n",
        header.join("\n"),
        body.join("\n")
            .replace("fn method(scene: Scene) -> f32", "fn inner(scene: Scene) -> f32")
    )
}

/// Sweeps `CASE` with `line.numeric` beside the user kernel `kernel` (file `file` in `dir`):
/// the report folder and its summary.
fn sweep_beside_numeric(dir: &Path, file: &str, label: &str, kernel: &str) -> (PathBuf, serde_json::Value) {
    let kernel = write(dir, file, kernel);
    let case = CASE
        .replace(
            r#"methods = ["line.ltc2017", "line.ltc2023"]"#,
            &format!(r#"methods = ["line.numeric", "{label}"]"#),
        )
        .replace(r#"compare = [["line.ltc2017", "line.ltc2023"]]"#, "");
    let case = write(dir, "c.toml", &case);
    let out = dir.join("reports");
    let o = linelight(&[
        "sweep",
        case.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--kernel",
        kernel.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let summary = common::json(&out.join("claimed/summary.json"));
    (out.join("claimed"), summary)
}

/// A method's statistics on the summary's first material.
fn first_material(summary: &serde_json::Value, label: &str) -> serde_json::Value {
    summary["analysis"]["methods"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["label"] == label)
        .unwrap()["materials"][0]
        .clone()
}

const CASE: &str = r#"
name = "claimed"
title = "claims"
seed = 11
methods = ["line.ltc2017", "line.ltc2023"]
compare = [["line.ltc2017", "line.ltc2023"]]
min_per_bin = 0
[disagreements]
restarts = 2
steps = 3
population = 8
[geometry]
elevation = { dist = "uniform", min = -30.0, max = 90.0 }
tilt_angle = { dist = "uniform", min = 0.0, max = 180.0 }
length = { dist = "log_uniform", min = 0.01, max = 10.0 }
center = { dist = "signed_log_uniform", min = 0.01, max = 100.0 }
[[materials]]
name = "diffuse"
kind = "diffuse"
count = 400
"#;

#[test]
fn a_claim_whose_expectation_fails_is_stale_and_exits_3() {
    let dir = tempfile::tempdir().unwrap();
    let claims = r#"
[[claims]]
id = "true-one"
expect = 'p99("line.ltc2023", "diffuse") > 0.0'
text = "p99 of 2023 is {sci(p99(\"line.ltc2023\", \"diffuse\"))} over {configurations()} configurations."
[[claims]]
id = "false-one"
expect = 'p99("line.ltc2023", "diffuse") < 0.0'
text = "a relative error below zero: {p99(\"line.ltc2023\", \"diffuse\")}"
"#;
    let case = write(dir.path(), "c.toml", &format!("{CASE}{claims}"));
    let out = dir.path().join("reports");
    let o = linelight(&["sweep", case.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("STALE: false-one"));
    let report = std::fs::read_to_string(out.join("claimed/report.md")).unwrap();
    let stale = report.find("## STALE findings").expect("STALE section");
    assert!(stale < report.find("## At a glance").unwrap(), "STALE comes first");
    assert!(report.contains("**STALE `false-one`**"));
    assert!(!report.contains("**STALE `true-one`**"));
    // The true claim's numbers are this run's: the configuration count is filled in.
    assert!(report.contains("over 400 configurations."), "{report}");
    assert!(
        report.contains("**No verdict**"),
        "a case without checks has no verdict"
    );
    let summary = common::json(&out.join("claimed/summary.json"));
    let holds: Vec<bool> = summary["claims"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["holds"].as_bool().unwrap())
        .collect();
    assert_eq!(holds, [true, false]);
}

#[test]
fn a_claim_naming_what_the_case_lacks_is_bad_input_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let claims = "\n[[claims]]\nid = \"x\"\nexpect = 'p99(\"line.nope\", \"diffuse\") > 0.0'\ntext = \"t\"\n";
    let case = write(dir.path(), "c.toml", &format!("{CASE}{claims}"));
    let out = dir.path().join("reports");
    let o = linelight(&["sweep", case.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("claim `x`") && stderr(&o).contains("line.nope"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists(), "nothing is written");
    // A case file still carrying hand-typed `notes` says how to update.
    let case = write(
        dir.path(),
        "n.toml",
        &CASE.replace("seed = 11", "seed = 11\nnotes = \"old\""),
    );
    let o = linelight(&["sweep", case.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("[[claims]]"), "{}", stderr(&o));
}

#[test]
fn light_where_none_arrives_shows_in_the_false_light_row_only() {
    let dir = tempfile::tempdir().unwrap();
    // Exactly `line.numeric@64` where light arrives; a constant where the segment lies wholly
    // below the horizon, where the diffuse reference is exactly 0.
    let kernel = wrapped(
        "line_numeric.wgsl",
        "test.false_light",
        "fn method(scene: Scene) -> f32 {\n    if (scene.p1.z <= 0.0 && scene.p2.z <= 0.0) { return 0.125; }\n    return inner(scene);\n}",
    );
    let (out, summary) = sweep_beside_numeric(dir.path(), "false_light.wgsl", "test.false_light", &kernel);
    let all = |label: &str| first_material(&summary, label)["all"].clone();
    let (plain, lit) = (all("line.numeric"), all("test.false_light"));
    let zero = plain["false_light"]["configurations"].as_u64().unwrap();
    assert!(
        zero > 20,
        "the sample has configurations wholly below the horizon: {zero}"
    );
    assert_eq!(plain["false_light"]["lit"], 0);
    assert_eq!(lit["false_light"]["configurations"].as_u64(), Some(zero));
    assert_eq!(lit["false_light"]["lit"].as_u64(), Some(zero), "every one is lit");
    assert_eq!(lit["false_light"]["value"]["max"], 0.125);
    // Where light arrives the two are the same method: the error statistics do not move.
    assert_eq!(plain["rel"], lit["rel"]);
    assert_eq!(plain["count"], lit["count"]);
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    let row = report
        .lines()
        .find(|l| l.starts_with("| `test.false_light` | `diffuse` |"))
        .expect("false-light row");
    assert!(row.contains(&format!("| {zero} | {zero} (100.0 %) |")), "{row}");
}

#[test]
fn the_disagreement_search_finds_the_region_built_in() {
    let dir = tempfile::tempdir().unwrap();
    // `line.ltc2023_fix`, off by 1e-3 relative where the segment starts at positive x.
    let kernel = wrapped(
        "line_ltc2023_fix.wgsl",
        "test.off_at_positive_x",
        "fn method(scene: Scene) -> f32 {\n    let v = inner(scene);\n    if (scene.p1.x > 0.0) { return v * 1.001; }\n    return v;\n}",
    );
    let kernel = write(dir.path(), "off.wgsl", &kernel);
    let case = CASE
        .replace(
            r#"methods = ["line.ltc2017", "line.ltc2023"]"#,
            r#"methods = ["line.ltc2023_fix", "test.off_at_positive_x"]"#,
        )
        .replace(
            r#"compare = [["line.ltc2017", "line.ltc2023"]]"#,
            r#"compare = [["line.ltc2023_fix", "test.off_at_positive_x"]]"#,
        )
        // Well-conditioned lights, so that 1e-3 stands far above the f32 rounding of the fix.
        .replace("min = 0.01, max = 100.0", "min = 0.01, max = 1.0")
        .replace("min = -30.0, max = 90.0", "min = 20.0, max = 90.0")
        .replace("restarts = 2", "restarts = 4");
    let case = write(dir.path(), "c.toml", &case);
    let out = dir.path().join("reports");
    let o = linelight(&[
        "sweep",
        case.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--kernel",
        kernel.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = std::fs::read_to_string(out.join("claimed/disagreements.jsonl")).unwrap();
    let configs: Vec<serde_json::Value> = text.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    // Eval input format and nothing else.
    for c in &configs {
        let keys: Vec<&String> = c.as_object().unwrap().keys().collect();
        assert!(keys
            .iter()
            .all(|k| ["id", "p1", "p2", "material", "radius", "rect"].contains(&k.as_str())));
    }
    let off_worse: Vec<&serde_json::Value> = configs
        .iter()
        .filter(|c| {
            c["id"]
                .as_str()
                .unwrap()
                .starts_with("disagree-test.off_at_positive_x-worse-than-line.ltc2023_fix")
        })
        .collect();
    assert!(!off_worse.is_empty(), "found where the built-in error is");
    for c in &off_worse {
        assert!(c["p1"][0].as_f64().unwrap() > 0.0, "outside the region: {c}");
    }
    let summary = common::json(&out.join("claimed/summary.json"));
    let best = summary["disagreements"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|d| d["a"] == "test.off_at_positive_x")
        .map(|d| d["ratio"].as_f64().unwrap())
        .fold(0.0, f64::max);
    assert!(best >= 100.0, "1e-3 against an f32-accurate method: ratio {best}");
    // The other way there is nothing built in: no ratio anywhere near it.
    let reverse = summary["disagreements"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|d| d["a"] == "line.ltc2023_fix")
        .map(|d| d["ratio"].as_f64().unwrap())
        .fold(0.0, f64::max);
    assert!(reverse < best / 10.0, "reverse {reverse} against {best}");
}

/// A case where `line_upper` is 0 for two geometric sets: lights wholly below the surface and
/// lights above it but only outside an LTC lobe (row 3 of M⁻¹ is (0.5, 0, 1): D is 0 where
/// 0.5·x + z ≤ 0). Horizontal segments, so a light is wholly below exactly when the closest
/// point's elevation is ≤ 0 (half the draws).
const BELOW_CASE: &str = r#"
name = "below"
title = "wholly below against line_upper = 0"
seed = 5
min_per_bin = 0
methods = ["test.lights_below", "test.lights_above"]
[geometry]
distance = { dist = "fixed", value = 1.0 }
elevation = { dist = "uniform", min = -20.0, max = 20.0 }
azimuth = { dist = "uniform", min = 0.0, max = 360.0 }
tilt_angle = { dist = "fixed", value = 0.0 }
length = { dist = "log_uniform", min = 0.01, max = 0.1 }
center = { dist = "uniform", min = -0.05, max = 0.05 }
[[materials]]
name = "lobe"
kind = "ltc_sparse"
count = 400
alpha = { dist = "fixed", value = 0.5 }
shear = { dist = "fixed", value = 0.5 }
[[claims]]
id = "apart"
expect = 'below_false_lit("test.lights_above", "lobe") == 0.0 && upper_false_lit("test.lights_below", "lobe") == below_zero("test.lights_below", "lobe") && below_zero("test.lights_below", "lobe") < upper_zero("test.lights_below", "lobe")'
text = "{below_zero(\"test.lights_below\", \"lobe\")} wholly below of {upper_zero(\"test.lights_below\", \"lobe\")}."
"#;

#[test]
fn wholly_below_is_counted_apart_from_line_upper_zero() {
    let dir = tempfile::tempdir().unwrap();
    let below = "fn method(scene: Scene) -> f32 {\n    if (scene.p1.z <= 0.0 && scene.p2.z <= 0.0) { return 0.125; }\n    return 0.0;\n}";
    let above = "fn method(scene: Scene) -> f32 {\n    if (scene.p1.z <= 0.0 && scene.p2.z <= 0.0) { return 0.0; }\n    return 0.125;\n}";
    let k1 = write(
        dir.path(),
        "below.wgsl",
        &wrapped("line_numeric.wgsl", "test.lights_below", below),
    );
    let k2 = write(
        dir.path(),
        "above.wgsl",
        &wrapped("line_numeric.wgsl", "test.lights_above", above),
    );
    let case = write(dir.path(), "c.toml", BELOW_CASE);
    let out = dir.path().join("reports");
    let o = linelight(&[
        "sweep",
        case.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--kernel",
        k1.to_str().unwrap(),
        "--kernel",
        k2.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let summary = common::json(&out.join("below/summary.json"));
    let material = |label: &str| first_material(&summary, label);
    let n = |v: &serde_json::Value| v.as_u64().unwrap();
    let (b, a) = (material("test.lights_below"), material("test.lights_above"));
    let wholly = n(&b["wholly_below"]["false_light"]["configurations"]);
    let upper = n(&b["all"]["false_light"]["configurations"]);
    // Half the elevations are ≤ 0: a binomial(400, 1/2) count, far inside these bounds.
    assert!((140..=260).contains(&wholly), "wholly below: {wholly}");
    assert!(
        upper > wholly + 20,
        "lights above the surface outside the lobe: {upper} vs {wholly}"
    );
    // The kernel lighting exactly the wholly-below ones lights every one of them and no other.
    assert_eq!(n(&b["wholly_below"]["false_light"]["lit"]), wholly);
    assert_eq!(n(&b["all"]["false_light"]["lit"]), wholly);
    // The one lighting everything else lights none of them, and every other zero of line_upper.
    assert_eq!(n(&a["wholly_below"]["false_light"]["lit"]), 0);
    assert_eq!(n(&a["all"]["false_light"]["lit"]), upper - wholly);
    let report = std::fs::read_to_string(out.join("below/report.md")).unwrap();
    assert!(
        report.contains(&format!("{wholly} wholly below of {upper}.")),
        "{report}"
    );
}

#[test]
fn missed_light_has_its_own_column_apart_from_the_error() {
    let dir = tempfile::tempdir().unwrap();
    // Exactly `line.numeric@64`, but 0 for every light whose first end point is above z = 0.3:
    // missed light on lit configurations, in f32 and in f64.
    let kernel = wrapped(
        "line_numeric.wgsl",
        "test.misses",
        "fn method(scene: Scene) -> f32 {\n    if (scene.p1.z > 0.3) { return 0.0; }\n    return inner(scene);\n}",
    );
    let (out, summary) = sweep_beside_numeric(dir.path(), "misses.wgsl", "test.misses", &kernel);
    let all = |label: &str| first_material(&summary, label)["all"].clone();
    let (plain, misses) = (all("line.numeric"), all("test.misses"));
    let dark = misses["dark"].as_u64().unwrap();
    let dark_f64 = misses["dark_f64"].as_u64().unwrap();
    let lit = misses["count"].as_u64().unwrap();
    assert!(dark * 10 > lit, "more than a tenth missed: {dark} of {lit}");
    assert_eq!(dark_f64, dark, "the f64 formula misses the same lights");
    assert_eq!(plain["dark"], 0);
    // With the missed ones, p99 is the plateau at 1; without them, the quadrature's own error.
    assert_eq!(misses["rel"]["p99"].as_f64(), Some(1.0));
    let p99_lit = misses["rel_lit"]["p99"].as_f64().unwrap();
    assert!(p99_lit <= plain["rel"]["max"].as_f64().unwrap(), "{p99_lit}");
    assert!(p99_lit < 1e-2, "{p99_lit}");
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    let glance = &report[report.find("## At a glance").unwrap()..];
    let row = |label: &str| {
        glance
            .lines()
            .find(|l| l.starts_with(&format!("| `{label}` |")))
            .unwrap_or_else(|| panic!("no At a glance row for {label}"))
            .to_string()
    };
    let r = row("test.misses");
    assert!(r.contains(&format!("| {dark} of {lit} (f64 {dark_f64}) |")), "{r}");
    assert!(!r.contains("1.0e0 /"), "the error column leaves missed light out: {r}");
    assert!(r.contains(&linelight::report::markup::sci(Some(p99_lit))), "{r}");
    assert!(row("line.numeric").ends_with("| 0 |"), "{}", row("line.numeric"));
}
