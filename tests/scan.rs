//! `linelight scan`: counts on the GPU, rates with their interval, captured offenders that
//! replay with `linelight eval`.

use crate::common;
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
            "line.ltc2017,line.ltc2023,line.ltc2023_fix",
        ])
        .args(["--capture", "8", "--out", dir.path().to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = dir.path().join("line_fwt-scan");
    let results = common::json(&out.join("summary.json"));
    let results = results.as_array().unwrap();
    // `ggx_iso` takes its M⁻¹ from the fitted table: not generated on the device.
    assert_eq!(
        results.len(),
        9,
        "three methods × the diffuse, ltc_full and short_rising families"
    );
    for r in results {
        assert_eq!(r["configurations"], 100000);
        let bad = ["nan", "inf", "negative", "above_light_bound"]
            .map(|k| r[k].as_u64().unwrap())
            .iter()
            .sum::<u64>();
        let (lo, hi) = (r["rate_low"].as_f64().unwrap(), r["rate_high"].as_f64().unwrap());
        let rate = bad as f64 / 1e5;
        assert!(lo <= rate && rate <= hi && hi < 1.0, "{r}");
        assert_eq!(r["captured"].as_array().unwrap().len(), (bad as usize).min(8));
    }
    // The 2023 listing returns max(0, …): never negative, so its offenders are values above the
    // light's bound; on `diffuse` it has some in 1e5 configurations (1.3 % in a run of 2e7).
    let l2023 = results
        .iter()
        .find(|r| r["method"] == "line.ltc2023" && r["family"] == "diffuse")
        .unwrap();
    assert_eq!(l2023["negative"], 0);
    assert!(l2023["above_light_bound"].as_u64().unwrap() > 100, "{l2023}");
    // Replay: every captured `line.ltc2017` offender is an offender again in eval, on the GPU.
    let lines: Vec<String> = std::fs::read_to_string(out.join("offending.jsonl"))
        .unwrap()
        .lines()
        .filter(|l| l.contains("scan-line.ltc2017-") || l.contains("scan-line.ltc2023-diffuse-"))
        .map(str::to_string)
        .collect();
    assert!(!lines.is_empty(), "line.ltc2017 has offenders in 1.5e5 configurations");
    let input = dir.path().join("in.jsonl");
    let output = dir.path().join("out.jsonl");
    std::fs::write(&input, lines.join("\n")).unwrap();
    let o = common::eval(&input, &output, &["--methods", "line.ltc2017,line.ltc2023"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let configs: Vec<serde_json::Value> = lines.iter().map(|l| serde_json::from_str(l).unwrap()).collect();
    let mut above = 0;
    for (row, config) in std::fs::read_to_string(&output).unwrap().lines().zip(&configs) {
        let r: serde_json::Value = serde_json::from_str(row).unwrap();
        let id = r["id"].as_str().unwrap();
        let method = if id.starts_with("scan-line.ltc2017-") {
            "line.ltc2017"
        } else {
            "line.ltc2023"
        };
        let v = &r["methods"][method]["f32"];
        if id.ends_with("-above_light") {
            // Above the bound, and the bound is one: for the diffuse material B = 2L/(π r²)
            // (r the distance to the segment), computed here in f64 on its own.
            let v = v.as_f64().unwrap();
            let reference = r["reference"]["line"].as_f64().unwrap();
            if config["material"]["kind"] == "diffuse" {
                let p = |k: &str| -> [f64; 3] { serde_json::from_value(config[k].clone()).unwrap() };
                let (p1, p2) = (p("p1"), p("p2"));
                let e: Vec<f64> = (0..3).map(|i| p2[i] - p1[i]).collect();
                let ee: f64 = e.iter().map(|x| x * x).sum();
                let t = (-(0..3).map(|i| p1[i] * e[i]).sum::<f64>() / ee).clamp(0.0, 1.0);
                let r2: f64 = (0..3).map(|i| (p1[i] + t * e[i]).powi(2)).sum();
                let bound = 2.0 * ee.sqrt() / (std::f64::consts::PI * r2);
                assert!(reference <= bound, "{id}: reference {reference} above B {bound}");
                assert!(v > 1.0005 * bound, "{id}: {v} not above B {bound}");
                above += 1;
            }
            assert!(v > reference, "{id}: {v} against {reference}");
        } else {
            let offending = v.is_string() || v.as_f64().unwrap() < 0.0;
            assert!(offending, "replayed as {v}: {row}");
        }
    }
    assert!(
        above > 0,
        "some diffuse offenders above the light's bound were replayed"
    );
}
