//! Property tests (proptest) of the three parsers that read user input: the case file, the
//! eval line and the kernel header. On any input they return a value or an error — never a
//! panic — within a bounded time, and an error says where. Case counts are kept small so
//! the suite stays fast; each input is also timed (a parser that hangs fails the test).

use linelight::input::case::Case;
use linelight::kernel::KernelFile;
use proptest::prelude::*;
use std::time::{Duration, Instant};

/// One parse may take at most this (they take microseconds).
const BOUND: Duration = Duration::from_secs(2);

fn config() -> ProptestConfig {
    ProptestConfig {
        cases: 256,
        max_shrink_iters: 256,
        ..ProptestConfig::default()
    }
}

const CASE: &str = r#"name = "t"
title = "t"
seed = 1
methods = ["line.ltc2023", "line.ltc2017"]
compare = [["line.ltc2017", "line.ltc2023"]]
error_floor = { line = 1e-6 }
[geometry]
distance = { dist = "fixed", value = 1.0 }
elevation = { dist = "uniform", min = 0.0, max = 90.0 }
tilt_angle = { dist = "uniform", min = 0.0, max = 180.0 }
length = { dist = "log_uniform", min = 0.1, max = 10.0 }
center = { dist = "fixed", value = 0.0 }
radius = { dist = "log_uniform", min = 0.001, max = 0.1 }
[[materials]]
name = "iso"
kind = "ltc_sparse"
count = 4
alpha = { dist = "log_uniform", min = 0.1, max = 1.0 }
aspect = { dist = "uniform", min = 0.5, max = 2.0 }
[[bins]]
axis = "length"
edges = [0.1, 1.0, 10.0]
[search]
methods = ["line.ltc2023"]
restarts = 2
steps = 1
population = 2
[tolerances."line.ltc2023"]
p99 = 0.01
nan = 0
"#;

/// Values a hostile user might put anywhere: edge numbers, wrong types, odd strings.
fn value() -> impl Strategy<Value = String> {
    prop_oneof![
        prop::sample::select(vec![
            "0",
            "-0.0",
            "-1",
            "1e-300",
            "1e300",
            "1.7976931348623157e308",
            "nan",
            "inf",
            "-inf",
            "99999999999999999999",
            "18446744073709551616",
            "4294967296",
            "\"\"",
            "\"../../x\"",
            "[]",
            "[1, 2, 3]",
            "{}",
            "{ dist = \"fixed\", value = 0.0 }",
            "{ dist = \"uniform\", min = 2.0, max = 1.0 }",
            "{ dist = \"log_uniform\", min = 0.0, max = 1.0 }",
            "{ dist = \"signed_log_uniform\", min = 1e-300, max = 1e300 }",
            "true",
            "\"\u{feff}\"",
        ])
        .prop_map(str::to_string),
        any::<f64>().prop_map(|v| format!("{v:?}").replace("NaN", "nan")),
        any::<String>().prop_map(|s| format!("{s:?}")),
    ]
}

fn timed<T>(f: impl FnOnce() -> T) -> T {
    let start = Instant::now();
    let v = f();
    assert!(start.elapsed() < BOUND, "took {:?}", start.elapsed());
    v
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn case_parser_never_panics_on_arbitrary_text(text in any::<String>()) {
        let r = timed(|| Case::parse("p.toml", &text));
        if let Err(e) = r {
            prop_assert!(e.to_string().starts_with("p.toml"), "{e}");
        }
    }

    #[test]
    fn case_parser_never_panics_on_a_mutated_case(line in 0usize..48, v in value(), keep_key in any::<bool>()) {
        // One line of a valid case replaced: its value by a hostile one, or the whole line.
        let text: String = CASE
            .lines()
            .enumerate()
            .map(|(i, l)| {
                if i != line {
                    l.to_string()
                } else if let (true, Some((key, _))) = (keep_key, l.split_once(" = ")) {
                    format!("{key} = {v}")
                } else {
                    v.clone()
                }
            })
            .collect::<Vec<_>>()
            .join("\n");
        match timed(|| Case::parse("p.toml", &text)) {
            Err(e) => prop_assert!(e.to_string().starts_with("p.toml"), "{e}"),
            // What is accepted samples without a panic (small counts only).
            Ok(case) if case.materials.iter().map(|m| m.count).sum::<usize>() <= 1000 => {
                let _ = timed(|| linelight::input::sampler::sample_case_counted(&case));
            }
            Ok(_) => {}
        }
    }

    #[test]
    fn eval_line_parser_never_panics(
        fields in prop::collection::vec((prop::sample::select(vec![
            "id", "p1", "p2", "radius", "rect", "material", "normal", "width", "extra",
        ]), value()), 0..8),
        base in any::<bool>(),
    ) {
        let mut obj: Vec<String> = if base {
            vec![
                "\"id\": \"c\"".into(),
                "\"p1\": [0.3, -0.2, 1.0]".into(),
                "\"p2\": [0.9, 0.4, 1.6]".into(),
                "\"material\": {\"kind\": \"diffuse\"}".into(),
            ]
        } else {
            Vec::new()
        };
        // TOML spellings of specials are not JSON: they make malformed lines, also worth reading.
        obj.extend(fields.iter().map(|(k, v)| format!("\"{k}\": {v}")));
        let line = format!("{{{}}}\n", obj.join(", "));
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("in.jsonl");
        std::fs::write(&path, &line).unwrap();
        match timed(|| linelight::measure::eval_rows::read_configs(&path)) {
            Err(e) => prop_assert!(e.to_string().contains("in.jsonl"), "{e}"),
            Ok(configs) => {
                // Accepted configurations are ones every kernel can be given.
                for c in configs {
                    prop_assert!(c.validate().is_ok());
                    let _ = linelight::input::scene::GpuScene::from(&c);
                }
            }
        }
    }

    #[test]
    fn eval_line_parser_never_panics_on_arbitrary_bytes(bytes in prop::collection::vec(any::<u8>(), 0..300)) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("in.jsonl");
        std::fs::write(&path, &bytes).unwrap();
        if let Err(e) = timed(|| linelight::measure::eval_rows::read_configs(&path)) {
            prop_assert!(e.to_string().contains("in.jsonl"), "{e}");
        }
    }

    #[test]
    fn kernel_header_parser_never_panics(
        lines in prop::collection::vec((prop::sample::select(vec![
            "id", "target", "source", "minv", "params", "uses", "junk", "",
        ]), any::<String>(), any::<bool>()), 0..8),
        tail in any::<String>(),
    ) {
        let mut text = String::new();
        for (key, value, colon) in &lines {
            text.push_str(&format!("//! {key}{} {value}\n", if *colon { ":" } else { "" }));
        }
        text.push_str(&tail);
        match timed(|| KernelFile::parse("k.wgsl", &text)) {
            Err(e) => {
                let e = e.to_string();
                prop_assert!(e.starts_with("k.wgsl:"), "{e}");
                prop_assert!(e.len() < 1000, "message of {} bytes", e.len());
            }
            Ok(k) => prop_assert!(linelight::kernel::valid_id(&k.id)),
        }
    }
}
