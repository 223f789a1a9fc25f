//! Sharded sweeps (docs/scale.md): shards run as separate processes, as a CI matrix would run
//! them, and `linelight merge` of their states gives the report of the unsharded sweep.

use crate::common;
use common::{json, linelight, stderr, write};

const CASE: &str = r#"
name = "sharded"
title = "sharded"
seed = 11
methods = ["line.ltc2017", "line.ltc2023"]
compare = [["line.ltc2017", "line.ltc2023"]]
min_per_bin = 300
[geometry]
elevation = { dist = "uniform", min = -20.0, max = 90.0 }
tilt_angle = { dist = "uniform", min = 0.0, max = 180.0 }
length = { dist = "log_uniform", min = 0.01, max = 100.0 }
center = { dist = "signed_log_uniform", min = 0.001, max = 1000.0 }
[[materials]]
name = "diffuse"
kind = "diffuse"
count = 3200
[[materials]]
name = "ggx_iso"
kind = "ltc_ggx"
count = 3200
alpha = { dist = "log_uniform", min = 0.02, max = 1.0 }
view_angle = { dist = "uniform", min = 0.0, max = 89.0 }
[[bins]]
axis = "reach_near_o"
edges = [0.0, 0.1, 1.0, 10.0, 1e12]
[search]
methods = ["line.ltc2017"]
restarts = 3
steps = 3
population = 8
"#;

#[test]
fn merged_shards_give_the_unsharded_report() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let case = write(d, "case.toml", CASE);
    let s = |p: &std::path::Path| p.to_str().unwrap().to_string();
    let whole = d.join("whole");
    let o = linelight(&["sweep", &s(&case), "--out", &s(&whole)]);
    assert!(o.status.code().is_some_and(|c| c <= 1), "{}", stderr(&o));
    let n = 3;
    let mut dirs = Vec::new();
    let mut measured = Vec::new();
    for i in 0..n {
        let dir = d.join(format!("shard{i}"));
        let o = linelight(&["sweep", &s(&case), "--shard", &format!("{i}/{n}"), "--out", &s(&dir)]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(dir.join(format!("shard-{i}-of-{n}.cbor")).is_file());
        dirs.push(s(&dir));
        // "shard I/N: C configurations in …": what this shard drew and measured.
        let out = String::from_utf8_lossy(&o.stdout).to_string();
        let c: usize = out
            .split(": ")
            .nth(1)
            .and_then(|t| t.split(' ').next())
            .and_then(|t| t.parse().ok())
            .unwrap_or_else(|| panic!("{out}"));
        measured.push(c);
    }
    // A shard missing is refused, naming what is missing.
    let merged = d.join("merged");
    let o = linelight(&["merge", &dirs[0], &dirs[2], "--out", &s(&merged)]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("of 3"), "{}", stderr(&o));
    let mut args = vec!["merge".to_string()];
    args.extend(dirs.iter().cloned());
    args.extend(["--out".to_string(), s(&merged)]);
    let o = linelight(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.code().is_some_and(|c| c <= 1), "{}", stderr(&o));
    let (a, b) = (
        json(&whole.join("sharded/summary.json")),
        json(&merged.join("sharded/summary.json")),
    );
    // Counts exact, sketches merged bucket for bucket, worst cases and searches the same.
    for key in ["analysis", "configurations", "disagreements", "leak", "draws", "topups"] {
        assert_eq!(a[key], b[key], "{key} differs");
    }
    // The case's thin bins were topped up, and each shard drew and measured about a third of
    // the natural sample (6400 configurations in blocks of 1024: 3072 or 2048 and 1280) plus
    // its share of the top-ups its own counts call for (a superset of its share of the whole's).
    let kept: u64 = a["topups"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t["kept"].as_u64().unwrap())
        .sum();
    assert!(kept > 0, "no top-ups: the test would not cover them: {}", a["topups"]);
    let whole_configurations = a["configurations"].as_u64().unwrap() as usize;
    assert!(measured.iter().sum::<usize>() >= whole_configurations, "{measured:?}");
    for (i, &c) in measured.iter().enumerate() {
        assert!(
            c <= 3072 + kept as usize,
            "shard {i} measured {c} of {whole_configurations}"
        );
    }
    // The CPU evaluator's measuring times, one (label, seconds) per method, added over the
    // shards; named for what they hold.
    for key in ["cpu_f64_seconds", "cpu_f32_seconds"] {
        let rows = b["timing"][key]
            .as_array()
            .unwrap_or_else(|| panic!("timing.{key}: {}", b["timing"]));
        let labels: Vec<&str> = rows.iter().map(|r| r[0].as_str().unwrap()).collect();
        assert_eq!(labels, ["line.ltc2017", "line.ltc2023"], "{key}");
        assert!(
            rows.iter().all(|r| r[1].as_f64().is_some_and(|s| s > 0.0)),
            "{key}: {rows:?}"
        );
    }
    let timing = b["timing"].as_object().unwrap();
    assert!(!timing.keys().any(|k| k.contains("port")), "{:?}", timing.keys());
    let stats = |dir: &std::path::Path| std::fs::read_to_string(dir.join("sharded/stats.csv")).unwrap();
    assert_eq!(stats(&whole), stats(&merged));
    assert!(
        stats(&whole).contains(",sketch"),
        "no sketched bin: the test would not cover sketches"
    );
    assert!(stats(&whole).contains(",exact"));
    // The searches ran in the shards, each start's climb the one the unsharded run makes of
    // it, and the merge kept the climbs of the whole sample's best starts: the same findings.
    for f in [
        "worst.jsonl",
        "disagreements.jsonl",
        "comparisons.csv",
        "nonfinite.jsonl",
    ] {
        assert!(whole.join("sharded").join(f).is_file(), "{f}");
        assert_eq!(
            std::fs::read(whole.join("sharded").join(f)).ok(),
            std::fs::read(merged.join("sharded").join(f)).ok(),
            "{f}"
        );
    }
    assert!(
        !std::fs::read_to_string(whole.join("sharded/disagreements.jsonl"))
            .unwrap()
            .is_empty(),
        "no disagreement found: the test would not cover the searches"
    );
    // Shard 0 alone timed the methods and attributed; the report says so.
    assert_eq!(b["timing"]["shards"], 3);
    assert!(b["timing"]["cost_rounds"].as_array().is_some_and(|r| r.len() == 2));
    let report = std::fs::read_to_string(merged.join("sharded/report.md")).unwrap();
    assert!(report.contains("Merged from 3 shards"), "timing section");
    assert!(report.contains("ran in shard 0 of 3 alone"), "timing section");

    // No Vulkan adapter (the loader pointed at nothing), the shards given in another order:
    // the same files.
    let bare = d.join("bare");
    let mut args = vec!["merge".to_string()];
    args.extend(dirs.iter().rev().cloned());
    args.extend(["--out".to_string(), s(&bare)]);
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_linelight"))
        .args(&args)
        .env("VK_ICD_FILENAMES", "/nonexistent")
        .env("VK_DRIVER_FILES", "/nonexistent")
        .output()
        .unwrap();
    assert!(o.status.code().is_some_and(|c| c <= 1), "{}", stderr(&o));
    // That environment has no adapter: a sweep there is refused for want of one.
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_linelight"))
        .args(["sweep", &s(&case), "--shard", "0/3", "--out", &s(&d.join("none"))])
        .env("VK_ICD_FILENAMES", "/nonexistent")
        .env("VK_DRIVER_FILES", "/nonexistent")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    for f in [
        "stats.csv",
        "worst.jsonl",
        "disagreements.jsonl",
        "comparisons.csv",
        "nonfinite.jsonl",
    ] {
        assert_eq!(
            std::fs::read(merged.join("sharded").join(f)).ok(),
            std::fs::read(bare.join("sharded").join(f)).ok(),
            "{f}"
        );
    }
    let mut c = json(&bare.join("sharded/summary.json"));
    let mut m = b.clone();
    for v in [&mut c, &mut m] {
        let o = v.as_object_mut().unwrap();
        // When and how it was called.
        o.remove("stages");
        o.remove("command_line");
    }
    assert_eq!(c, m, "summary.json");

    // Malformed search or timing state in a record: refused with exit 2, naming it, nothing written.
    let refused = |dirs: &[String], why: &str| {
        let out = d.join("refused");
        let mut args = vec!["merge".to_string()];
        args.extend(dirs.iter().cloned());
        args.extend(["--out".to_string(), s(&out)]);
        let o = linelight(&args.iter().map(String::as_str).collect::<Vec<_>>());
        assert_eq!(o.status.code(), Some(2), "{why}: {}", stderr(&o));
        assert!(stderr(&o).contains(why), "{why}: {}", stderr(&o));
        assert!(!out.exists(), "{why}: written");
    };
    let edited = |i: usize, what: &str, edit: &dyn Fn(&mut ciborium::Value, &ciborium::Value)| -> Vec<String> {
        let copy = d.join(format!("edited-{what}"));
        let _ = std::fs::remove_dir_all(&copy);
        let mut out = Vec::new();
        for (k, dir) in dirs.iter().enumerate() {
            let to = copy.join(format!("shard{k}"));
            std::fs::create_dir_all(&to).unwrap();
            let name = format!("shard-{k}-of-{n}.cbor");
            let bytes = std::fs::read(std::path::Path::new(dir).join(&name)).unwrap();
            if k == i {
                let zero = std::fs::read(std::path::Path::new(&dirs[0]).join(format!("shard-0-of-{n}.cbor"))).unwrap();
                let zero: ciborium::Value = ciborium::from_reader(zero.as_slice()).unwrap();
                let mut value: ciborium::Value = ciborium::from_reader(bytes.as_slice()).unwrap();
                edit(measured_mut(&mut value), &measured_of(&zero));
                let mut w = Vec::new();
                ciborium::into_writer(&value, &mut w).unwrap();
                std::fs::write(to.join(&name), w).unwrap();
            } else {
                std::fs::write(to.join(&name), bytes).unwrap();
            }
            // The case file is found at its absolute path, as the shards ran it.
            out.push(s(&to));
        }
        out
    };
    let set = |v: &mut ciborium::Value, key: &str, to: ciborium::Value| {
        for (k, x) in v.as_map_mut().unwrap() {
            if k.as_text() == Some(key) {
                *x = to;
                return;
            }
        }
        panic!("no {key}");
    };
    let get = |v: &ciborium::Value, key: &str| -> ciborium::Value {
        v.as_map()
            .unwrap()
            .iter()
            .find(|(k, _)| k.as_text() == Some(key))
            .map(|(_, x)| x.clone())
            .unwrap()
    };
    // Shard 0 without its timing of methods.
    let dirs2 = edited(0, "untimed", &|m, _| set(m, "timed", ciborium::Value::Null));
    refused(&dirs2, "no part timed the methods");
    // A second shard with a timing of methods.
    let dirs2 = edited(1, "timed-twice", &|m, zero| set(m, "timed", get(zero, "timed")));
    refused(&dirs2, "both timed the methods");
    // A shard whose climbs are gone: the whole sample's best starts it measured were not climbed.
    let dirs2 = edited(0, "unclimbed", &|m, _| {
        let mut climbs = get(m, "climbs");
        for (_, v) in climbs.as_map_mut().unwrap() {
            for list in v.as_array_mut().unwrap() {
                *list = ciborium::Value::Array(Vec::new());
            }
        }
        set(m, "climbs", climbs);
    });
    refused(&dirs2, "was not climbed by any part");
    // Climbs of another set of searches.
    let dirs2 = edited(1, "other-searches", &|m, _| {
        let mut climbs = get(m, "climbs");
        for (_, v) in climbs.as_map_mut().unwrap() {
            v.as_array_mut().unwrap().pop();
        }
        set(m, "climbs", climbs);
    });
    refused(&dirs2, "different searches");
}

/// The measure stage's part of a shard record (`state.measured`).
fn measured_mut(record: &mut ciborium::Value) -> &mut ciborium::Value {
    fn field<'a>(v: &'a mut ciborium::Value, key: &str) -> &'a mut ciborium::Value {
        v.as_map_mut()
            .unwrap()
            .iter_mut()
            .find(|(k, _)| k.as_text() == Some(key))
            .map(|(_, x)| x)
            .unwrap()
    }
    field(field(record, "state"), "measured")
}

fn measured_of(record: &ciborium::Value) -> ciborium::Value {
    let field = |v: &ciborium::Value, key: &str| -> ciborium::Value {
        v.as_map()
            .unwrap()
            .iter()
            .find(|(k, _)| k.as_text() == Some(key))
            .map(|(_, x)| x.clone())
            .unwrap()
    };
    field(&field(record, "state"), "measured")
}

#[test]
fn bad_shard_is_refused() {
    for bad in ["3/3", "1", "a/b", "0/0"] {
        let o = linelight(&["sweep", "cases/line_fwt.toml", "--shard", bad, "--out", "/nonexistent"]);
        assert_eq!(o.status.code(), Some(2), "{bad}: {}", stderr(&o));
        assert!(stderr(&o).contains("--shard"), "{}", stderr(&o));
    }
}

#[test]
fn eval_streams_in_chunks_keeping_the_order() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    // Eleven configurations: with chunks of 3 the input is read in four chunks.
    let lines: String = (0..11)
        .map(|i| {
            let z = 0.5 + 0.1 * i as f64;
            format!(
                "{{\"id\":\"c{i}\",\"p1\":[0.3,-0.2,{z}],\"p2\":[0.9,0.4,{}],\"material\":{{\"kind\":\"diffuse\"}}}}\n",
                z + 0.6
            )
        })
        .collect();
    let input = write(d, "in.jsonl", &lines);
    let run = |chunk: &str, out: &str| {
        let output = d.join(out);
        let o = common::eval_with(
            &[("LINELIGHT_EVAL_CHUNK", chunk)],
            &input,
            &output,
            &["--methods", "line.ltc2023,line.numeric@16"],
        );
        assert!(o.status.success(), "{}", stderr(&o));
        std::fs::read_to_string(output).unwrap()
    };
    let (chunked, whole) = (run("3", "a.jsonl"), run("1000", "b.jsonl"));
    assert_eq!(chunked, whole);
    let ids: Vec<String> = chunked
        .lines()
        .map(|l| {
            serde_json::from_str::<serde_json::Value>(l).unwrap()["id"]
                .as_str()
                .unwrap()
                .to_string()
        })
        .collect();
    assert_eq!(ids, (0..11).map(|i| format!("c{i}")).collect::<Vec<_>>());
    // A bad line anywhere is found before any chunk is evaluated: nothing is written.
    let bad = write(d, "bad.jsonl", &format!("{lines}{{\"id\":\"x\"}}\n"));
    let output = d.join("c.jsonl");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_linelight"))
        .env("LINELIGHT_EVAL_CHUNK", "3")
        .args([
            "eval",
            "--input",
            bad.to_str().unwrap(),
            "--output",
            output.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("bad.jsonl:12"), "{}", stderr(&o));
    assert!(!output.exists());
}
