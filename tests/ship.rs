//! "What to ship": a small sweep with user kernels whose answer is known, run
//! through the binary; and a `[budget]`'s values refused with a message naming them.

use crate::common;
use common::snapshot::{only_changed, refused, s, snapshot};
use common::{case, linelight, write};

/// Diffuse lights near the shading point. Lengths above 9.9 are rare in the natural sample
/// (log-uniform on [0.1, 10]: 0.2 %), and the bin [9.9, 10] is topped up to 300 (rejection
/// sampling: 200 draws per configuration of the count are enough).
fn ship() -> String {
    case("ship")
        .key("seed", "11")
        .methods(&["line.numeric@256"])
        .key("min_per_bin", "300")
        .key("topup_draws", "200")
        .diffuse(2000)
        .table("[[bins]]\naxis = \"length\"\nedges = [0.1, 9.9, 10.0]")
        .table("[budget]\nquantile = 0.99\nvalue = 0.05\ntarget = \"line\"\nmin_count = 300")
        .to_string()
}

/// A claim quoting the answer, and one that expects another: the second is STALE.
const CLAIMS: &str = r#"
[[claims]]
id = "ships-short"
expect = 'shipped("diffuse") == "my.short"'
text = "Ship {shipped(\"diffuse\")} on diffuse."
[[claims]]
id = "ships-numeric"
expect = 'shipped("diffuse") == "line.numeric@256"'
text = "Ship {shipped(\"diffuse\")}."
"#;

/// `docs/ci/example/my_line.wgsl` (Listing 1.6) as `id`, returning 0 for lines longer than
/// `cut` (every such light missed: a relative error of 1).
fn kernel(id: &str, cut: Option<f64>) -> String {
    let src = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/ci/example/my_line.wgsl")).unwrap();
    let src = src.replace("//! id: my.line", &format!("//! id: {id}"));
    match cut {
        None => src,
        Some(cut) => format!(
            "{}\nfn method(scene: Scene) -> f32 {{\n    if (length(scene.p2 - scene.p1) > {cut:?}) {{\n        return 0.0;\n    }}\n    return method_full(scene);\n}}\n",
            src.replace("fn method(scene: Scene)", "fn method_full(scene: Scene)")
        ),
    }
}

#[test]
fn a_cheap_user_kernel_ships_except_where_it_breaks_and_a_dearer_method_meets_it_there() {
    let ship = ship();
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let case = write(d, "case.toml", &format!("{ship}{CLAIMS}"));
    let short = write(d, "short.wgsl", &kernel("my.short", Some(9.9)));
    let dark = write(
        d,
        "dark.wgsl",
        "//! id: my.dark\n//! target: line\n//! minv: none\nfn method(scene: Scene) -> f32 { return 0.0 * scene.p1.z; }\n",
    );
    let out = d.join("reports");
    let o = linelight(&[
        "sweep",
        s(&case),
        "--out",
        s(&out),
        "--kernel",
        s(&short),
        "--kernel",
        s(&dark),
    ]);
    // Exit 3: a claim is STALE.
    assert_eq!(o.status.code(), Some(3), "{}", String::from_utf8_lossy(&o.stderr));
    let summary = common::json(&out.join("ship/summary.json"));
    let holds: Vec<(&str, bool)> = summary["claims"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| (c["id"].as_str().unwrap(), c["holds"].as_bool().unwrap()))
        .collect();
    assert_eq!(holds, [("ships-short", true), ("ships-numeric", false)]);
    assert_eq!(summary["claims"][0]["text"], "Ship my.short on diffuse.");
    let ship = &summary["ship"];
    assert_eq!(ship["budget"]["quantile"], 0.99);
    assert_eq!(ship["budget"]["value"], 0.05);
    assert_eq!(ship["budget"]["target"], "line");
    assert_eq!(ship["budget"]["stated"], true);
    let m = &ship["materials"][0];
    assert_eq!(m["material"], "diffuse");
    // The user kernels take part like the built-in, ranked by op count: the dark one is the
    // cheapest and breaks the budget everywhere; the short one meets it over the whole material
    // (its missed lights are 0.2 % of it) and is shipped.
    let order: Vec<&str> = m["candidates"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["label"].as_str().unwrap())
        .collect();
    assert_eq!(order, ["my.dark", "my.short", "line.numeric@256"], "{m}");
    assert_eq!(m["candidates"][0]["whole"]["meets"], "breaks");
    assert_eq!(m["meets_everywhere"], "my.short", "{m}");
    assert_eq!(m["ship"], "my.short");
    // It breaks the budget where lines are longer than 9.9 (every one missed), and the
    // dearer built-in meets it there.
    let regions = m["regions"].as_array().unwrap();
    assert_eq!(regions.len(), 1, "{m}");
    let r = &regions[0];
    assert_eq!(
        (r["axis"].as_str(), r["lo"].as_f64(), r["hi"].as_f64()),
        (Some("length"), Some(9.9), Some(10.0))
    );
    assert_eq!(r["shipped"]["meets"], "breaks");
    assert_eq!(r["shipped"]["bound"]["value"], 1.0);
    assert_eq!(r["instead"]["label"], "line.numeric@256");
    assert!(r["instead"]["judgement"]["bound"]["value"].as_f64().unwrap() <= 0.05);
    // The price: the op count ranks, the measured ns is beside it.
    let price = &m["candidates"][1]["price"];
    assert!(price["ops"].as_u64().unwrap() < m["candidates"][2]["price"]["ops"].as_u64().unwrap());
    assert!(price["measured_ns"].as_f64().unwrap() > 0.0);

    // The report opens with the same answer.
    let report = std::fs::read_to_string(out.join("ship/report.md")).unwrap();
    let first = report.lines().find(|l| l.starts_with("## ")).unwrap();
    assert_eq!(first, "## What to ship");
    let section: String = report
        .split("## What to ship")
        .nth(1)
        .unwrap()
        .split("\n## ")
        .next()
        .unwrap()
        .into();
    assert!(section.contains("**`diffuse`**: ship `my.short`"), "{section}");
    assert!(
        section.contains("| `length` [9.9, 10) | ≤ 1.0e0 | `line.numeric@256` |"),
        "{section}"
    );
    assert!(
        section.contains("the case's `[budget]`") && section.contains("p99"),
        "{section}"
    );
}

#[test]
fn bad_budget_values_are_refused_naming_the_key_and_the_value() {
    let ship = ship();
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let with = |budget: &str| {
        ship.replace(
            "[budget]\nquantile = 0.99\nvalue = 0.05\ntarget = \"line\"\nmin_count = 300\n",
            budget,
        )
    };
    let cases = [
        (
            with("[budget]\nquantile = 99\nvalue = 0.01\n"),
            "`budget.quantile` = 99: a quantile is a fraction strictly between 0 and 1, 0.99 for p99 (for p99 write 0.99)",
        ),
        (
            with("[budget]\nquantile = 1.0\nvalue = 0.01\n"),
            "`budget.quantile` = 1: a quantile is a fraction strictly between 0 and 1",
        ),
        (
            with("[budget]\nquantile = 0.99\nvalue = -0.01\n"),
            "`budget.value` = -0.01: the most the statistic may be must be a finite number > 0",
        ),
        (
            with("[budget]\nquantile = 0.99\nvalue = 0.01\nmin_count = 0\n"),
            "`budget.min_count` = 0: a region needs at least 1 configuration to be judged",
        ),
        (
            with("[budget]\nquantile = 0.99\nvalue = 0.01\nstatistic = \"bits\"\n"),
            "`budget.statistic` = \"bits\": the only statistic a budget can name is \"relative_error\"",
        ),
        (
            with("[budget]\nquantile = 0.99\nvalue = 0.01\ntarget = \"cylinder\"\n"),
            "`budget.target` = \"cylinder\": no method of this run is judged against it (their targets: line)",
        ),
        (with("[budget]\nquantile = 0.99\nvalue = 0.01\ntarget = \"lines\"\n"), "unknown variant `lines`"),
        (with("[budget]\nquantile = 0.99\nvalue = 0.01\ncost = true\n"), "unknown field `cost`"),
        (with("[budget]\nvalue = 0.01\n"), "missing field `quantile`"),
    ];
    for (text, what) in cases {
        let path = write(d, "case.toml", &text);
        let before = snapshot(d);
        refused(
            &linelight(&["sweep", s(&path), "--out", s(&d.join("reports"))]),
            &[what],
        );
        only_changed(&before, &snapshot(d), &[]);
    }
    assert!(!d.join("reports").exists());
}

#[test]
fn a_case_without_a_budget_gets_the_documented_default_and_says_so() {
    let ship = ship();
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let text = ship
        .replace(
            "[budget]\nquantile = 0.99\nvalue = 0.05\ntarget = \"line\"\nmin_count = 300\n",
            "",
        )
        .replace("count = 2000", "count = 400");
    assert!(!text.contains("[budget]"));
    let case = write(d, "case.toml", &text);
    let out = d.join("reports");
    let o = linelight(&["sweep", s(&case), "--out", s(&out)]);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let summary = common::json(&out.join("ship/summary.json"));
    let b = &summary["ship"]["budget"];
    // docs/statistics.md: p99 ≤ 1e-2, 300 per region, cost matters, against the first
    // method's target clipped to the surface (`line` → `line_upper`).
    assert_eq!(
        (
            &b["quantile"],
            &b["value"],
            &b["min_count"],
            &b["cost_matters"],
            &b["target"],
            &b["stated"]
        ),
        (
            &serde_json::json!(0.99),
            &serde_json::json!(0.01),
            &serde_json::json!(300),
            &serde_json::json!(true),
            &serde_json::json!("line_upper"),
            &serde_json::json!(false)
        )
    );
    assert_eq!(
        summary["ship"]["materials"][0]["candidates"][0]["judged_against"],
        "line_upper"
    );
    let report = std::fs::read_to_string(out.join("ship/report.md")).unwrap();
    assert!(
        report.contains("Budget (the default: the case states none): p99"),
        "{report}"
    );
}
