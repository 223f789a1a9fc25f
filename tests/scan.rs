//! `linelight scan`: counts on the GPU, rates with their interval, captured offenders that
//! replay with `linelight eval`.

use std::process::Command;

#[test]
fn scan_counts_and_captures_offenders_that_replay() {
    let dir = tempfile::tempdir().unwrap();
    let case = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/line_fwt.toml");
    let o = Command::new(env!("CARGO_BIN_EXE_linelight"))
        .args([
            "scan",
            case.to_str().unwrap(),
            "--count",
            "3e5",
            "--methods",
            "line.ltc2017,line.ltc2023_fix",
        ])
        .args(["--capture", "8", "--out", dir.path().to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = dir.path().join("line_fwt-scan");
    let results: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let results = results.as_array().unwrap();
    // `ggx_iso` takes its M⁻¹ from the fitted table: not generated on the device.
    assert_eq!(results.len(), 4, "two methods × the diffuse and ltc_full families");
    for r in results {
        assert_eq!(r["configurations"], 150000);
        let bad = ["nan", "inf", "negative"]
            .map(|k| r[k].as_u64().unwrap())
            .iter()
            .sum::<u64>();
        let (lo, hi) = (r["rate_low"].as_f64().unwrap(), r["rate_high"].as_f64().unwrap());
        let rate = bad as f64 / 1.5e5;
        assert!(lo <= rate && rate <= hi && hi < 1.0, "{r}");
        assert_eq!(r["captured"].as_array().unwrap().len(), (bad as usize).min(8));
    }
    // Replay: every captured `line.ltc2017` offender is an offender again in eval, on the GPU.
    let lines: Vec<String> = std::fs::read_to_string(out.join("offending.jsonl"))
        .unwrap()
        .lines()
        .filter(|l| l.contains("scan-line.ltc2017-"))
        .map(str::to_string)
        .collect();
    assert!(!lines.is_empty(), "line.ltc2017 has offenders in 1.5e5 configurations");
    let input = dir.path().join("in.jsonl");
    let output = dir.path().join("out.jsonl");
    std::fs::write(&input, lines.join("\n")).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_linelight"))
        .args([
            "eval",
            "--input",
            input.to_str().unwrap(),
            "--output",
            output.to_str().unwrap(),
        ])
        .args(["--methods", "line.ltc2017"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for row in std::fs::read_to_string(&output).unwrap().lines() {
        let r: serde_json::Value = serde_json::from_str(row).unwrap();
        let v = &r["methods"]["line.ltc2017"]["f32"];
        let offending = v.is_string() || v.as_f64().unwrap() < 0.0;
        assert!(offending, "replayed as {v}: {row}");
    }
}
