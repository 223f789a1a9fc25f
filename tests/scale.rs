//! Sharded sweeps (docs/scale.md): shards run as separate processes, as a CI matrix would run
//! them, and `linelight merge` of their states gives the report of the unsharded sweep.

mod common;
use common::{linelight, stderr, write};

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

fn json(path: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

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
    for f in [
        "worst.jsonl",
        "disagreements.jsonl",
        "comparisons.csv",
        "nonfinite.jsonl",
    ] {
        assert_eq!(
            std::fs::read(whole.join("sharded").join(f)).ok(),
            std::fs::read(merged.join("sharded").join(f)).ok(),
            "{f}"
        );
    }
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
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_linelight"))
            .env("LINELIGHT_EVAL_CHUNK", chunk)
            .args([
                "eval",
                "--input",
                input.to_str().unwrap(),
                "--output",
                output.to_str().unwrap(),
            ])
            .args(["--methods", "line.ltc2023,line.numeric@16"])
            .output()
            .unwrap();
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
