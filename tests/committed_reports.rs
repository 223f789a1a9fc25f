//! scripts/compare-report, which CI runs through scripts/check-reports on every committed sweep
//! report: a committed stats.csv, analysis or "What to ship" answer that disagrees with a fresh
//! run fails it, and a timing that differs does not.

use crate::common;
use std::path::Path;
use std::process::Command;

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for name in ["stats.csv", "summary.json"] {
        std::fs::copy(from.join(name), to.join(name)).unwrap();
    }
}

fn compare(committed: &Path, fresh: &Path) -> (i32, String) {
    let o = Command::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scripts/compare-report"))
        .args([committed, fresh])
        .output()
        .expect("python3 runs scripts/compare-report");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    (o.status.code().unwrap_or(-1), text)
}

#[test]
fn a_moved_number_fails_and_a_timing_does_not() {
    let t = tempfile::tempdir().unwrap();
    let committed = Path::new(env!("CARGO_MANIFEST_DIR")).join("reports/rectangle");
    let (a, b) = (t.path().join("a"), t.path().join("b"));
    copy_dir(&committed, &a);
    copy_dir(&committed, &b);
    assert_eq!(compare(&a, &b).0, 0, "{}", compare(&a, &b).1);

    // A timing moves: still the same report.
    let mut s = common::json(&b.join("summary.json"));
    s["timing"]["total_seconds"] = serde_json::json!(1e9);
    std::fs::write(b.join("summary.json"), serde_json::to_string(&s).unwrap()).unwrap();
    let (code, text) = compare(&a, &b);
    assert_eq!(code, 0, "{text}");

    // One digit of stats.csv moves: refused, naming the file and the line.
    let csv = std::fs::read_to_string(a.join("stats.csv")).unwrap();
    let mut lines: Vec<String> = csv.lines().map(str::to_string).collect();
    let row = lines
        .iter()
        .position(|l| l.chars().any(|c| c.is_ascii_digit()) && l.contains(','))
        .unwrap()
        .max(1);
    let at = lines[row].rfind(|c: char| c.is_ascii_digit()).unwrap();
    let digit = lines[row].as_bytes()[at];
    lines[row].replace_range(at..at + 1, if digit == b'9' { "8" } else { "9" });
    std::fs::write(b.join("stats.csv"), lines.join("\n") + "\n").unwrap();
    let (code, text) = compare(&a, &b);
    assert_eq!(code, 1, "{text}");
    assert!(
        text.contains("stats.csv") && text.contains(&format!("line {}", row + 1)),
        "{text}"
    );

    // The analysis moves with stats.csv unchanged: refused, naming the key.
    copy_dir(&committed, &b);
    let mut s = common::json(&b.join("summary.json"));
    s["configurations"] = serde_json::json!(s["configurations"].as_u64().unwrap() + 1);
    std::fs::write(b.join("summary.json"), serde_json::to_string(&s).unwrap()).unwrap();
    let (code, text) = compare(&a, &b);
    assert_eq!(code, 1, "{text}");
    assert!(text.contains("configurations"), "{text}");

    // The "What to ship" answer: its measured ns is a timing, its choice is not.
    let with_ship = |dir: &Path, ship: &str, ns: f64| {
        copy_dir(&committed, dir);
        let mut s = common::json(&dir.join("summary.json"));
        s["ship"] = serde_json::json!({"materials": [{"ship": ship, "candidates": [{"label": ship, "price": {"ops": 120, "measured_ns": ns}}]}]});
        std::fs::write(dir.join("summary.json"), serde_json::to_string(&s).unwrap()).unwrap();
    };
    with_ship(&a, "m.cheap", 40.0);
    with_ship(&b, "m.cheap", 55.0);
    let (code, text) = compare(&a, &b);
    assert_eq!(code, 0, "{text}");
    with_ship(&b, "m.dear", 40.0);
    let (code, text) = compare(&a, &b);
    assert_eq!(code, 1, "{text}");
    assert!(text.contains("ship/materials/0/"), "{text}");
}
