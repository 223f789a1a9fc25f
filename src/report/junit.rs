//! JUnit XML for CI systems: one testcase per method × material × rule. The rules are the
//! case's tolerance checks and, with `--baseline`, the gate's rules (src/app/gate/); each
//! failure carries its numbers.
//!
//! Written by hand to the Apache Ant JUnit schema (the one Jenkins, GitLab and GitHub's
//! test-report actions read; tests/data/junit/ holds it and tests/gate.rs validates against
//! it): `<testsuites>` takes no attributes, each suite carries `id`, `package`, `timestamp`,
//! `hostname`, its counts and `time`, and `properties`, `system-out` and `system-err`; every
//! testcase has a `time`. A suite with no testcase is left out. quick-junit 0.8 wrote
//! `skipped` on `<testsuites>`, which that schema refuses.

use crate::analyse::analysis::Check;
use crate::analyse::gate::{Change, GateReport};

use crate::report::markup::xml_escape as escape;

/// What a testcase found.
enum Status {
    Pass,
    Failure { kind: &'static str, message: String },
    Skipped(String),
}

struct Case {
    name: String,
    classname: String,
    status: Status,
}

struct Suite {
    name: String,
    /// Seconds the suite's work took (the testcases are read from it, so each has time 0).
    seconds: f64,
    cases: Vec<Case>,
    /// The numbers of every testcase, passing or not (the schema gives a testcase no output).
    out: String,
}

/// `YYYY-MM-DDTHH:MM:SS` in UTC, without a zone (the schema's pattern).
fn timestamp(t: std::time::SystemTime) -> String {
    let secs = t.duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs()) as i64;
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    // Civil date from days since 1970-01-01 (Howard Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

/// The machine's name, `localhost` when it cannot be read (the schema requires one).
fn hostname() -> String {
    crate::io::read_system("/proc/sys/kernel/hostname", crate::limits::MAX_SYSTEM_FILE)
        .or_else(|| std::env::var("HOSTNAME").ok())
        .map(|h| h.trim().to_string())
        .filter(|h| !h.is_empty())
        .unwrap_or_else(|| "localhost".into())
}

fn render(suites: &[Suite], at: &str, host: &str) -> String {
    let mut o = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<testsuites>\n");
    for (id, s) in suites.iter().filter(|s| !s.cases.is_empty()).enumerate() {
        let count = |f: fn(&Status) -> bool| s.cases.iter().filter(|c| f(&c.status)).count();
        let failures = count(|s| matches!(s, Status::Failure { .. }));
        let skipped = count(|s| matches!(s, Status::Skipped(_)));
        o += &format!(
            "  <testsuite name=\"{}\" package=\"linelight\" id=\"{id}\" timestamp=\"{at}\" hostname=\"{}\" \
             tests=\"{}\" failures=\"{failures}\" errors=\"0\" skipped=\"{skipped}\" time=\"{:.3}\">\n    <properties/>\n",
            escape(&s.name),
            escape(host),
            s.cases.len(),
            s.seconds.max(0.0)
        );
        for c in &s.cases {
            let open = format!(
                "    <testcase name=\"{}\" classname=\"{}\" time=\"0\"",
                escape(&c.name),
                escape(&c.classname)
            );
            match &c.status {
                Status::Pass => o += &format!("{open}/>\n"),
                Status::Failure { kind, message } => {
                    o += &format!(
                        "{open}>\n      <failure message=\"{m}\" type=\"{kind}\">{m}</failure>\n    </testcase>\n",
                        m = escape(message)
                    )
                }
                Status::Skipped(message) => {
                    o += &format!(
                        "{open}>\n      <skipped message=\"{}\"/>\n    </testcase>\n",
                        escape(message)
                    )
                }
            }
        }
        o += &format!(
            "    <system-out>{}</system-out>\n    <system-err></system-err>\n  </testsuite>\n",
            escape(&s.out)
        );
    }
    o += "</testsuites>\n";
    o
}

fn name(method: &str, material: &str, rule: &str) -> String {
    format!("{method} / {material} / {rule}")
}

/// The suites of a sweep: `<case>.tolerances` (the case's checks; the sweep's `seconds`) and,
/// with a gate, `<case>.baseline` (its rules; the comparison's time).
fn suites(case: &str, checks: &[Check], gate: Option<&GateReport>, seconds: f64) -> Vec<Suite> {
    let mut tol = Suite {
        name: format!("{case}.tolerances"),
        seconds,
        cases: Vec::new(),
        out: String::new(),
    };
    for c in checks {
        let text = format!(
            "{} of {} on {}: measured {:e}, limit {:e}",
            c.what, c.method, c.material, c.measured, c.limit
        );
        let word = match (c.pass, c.too_few) {
            (true, _) => "pass",
            (false, Some(_)) => "NO VERDICT",
            (false, None) => "FAIL",
        };
        tol.out += &format!("{word} {text}\n");
        tol.cases.push(Case {
            name: name(&c.method, &c.material, &c.what),
            classname: c.method.clone(),
            status: if c.pass {
                Status::Pass
            } else if let Some(n) = c.too_few {
                Status::Skipped(format!(
                    "no verdict: {text}, from {n} configurations, fewer than the {} a quantile needs",
                    crate::limits::MIN_JUDGED
                ))
            } else {
                Status::Failure {
                    kind: "tolerance",
                    message: format!("FAIL {text}"),
                }
            },
        });
    }
    let mut suites = vec![tol];
    if let Some(gate) = gate {
        let mut suite = Suite {
            name: format!("{case}.baseline"),
            seconds: gate.seconds,
            cases: Vec::new(),
            out: String::new(),
        };
        for r in &gate.rules {
            suite.out += &format!(
                "{} {} on {} [{}]: {}\n",
                r.change.name(),
                r.method,
                r.material,
                r.rule,
                r.message
            );
            suite.cases.push(Case {
                name: name(&r.method, &r.material, r.rule),
                classname: r.method.clone(),
                status: match r.change {
                    Change::Regressed => Status::Failure {
                        kind: "regression",
                        message: format!("REGRESSED {} on {} [{}]: {}", r.method, r.material, r.rule, r.message),
                    },
                    Change::Skipped => Status::Skipped(r.message.clone()),
                    Change::Improved | Change::Unchanged => Status::Pass,
                },
            });
        }
        for (m, b, a) in &gate.timings {
            suite.out += &format!("{m}: {a:.4} ns/eval, baseline {b:.4} (not gated)\n");
        }
        suites.push(suite);
    }
    suites
}

/// The JUnit document of a sweep that took `seconds`.
pub fn junit(case: &str, checks: &[Check], gate: Option<&GateReport>, seconds: f64) -> String {
    render(
        &suites(case, checks, gate, seconds),
        &timestamp(std::time::SystemTime::now()),
        &hostname(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(pass: bool, measured: f64) -> Check {
        Check {
            method: "line.x".into(),
            material: "diffuse".into(),
            what: "p99 rel. error".into(),
            limit: 0.01,
            measured,
            pass,
            too_few: None,
        }
    }

    #[test]
    fn a_failed_check_is_a_failure_with_its_numbers() {
        let xml = junit("c", &[check(true, 0.001), check(false, 0.5)], None, 1.25);
        assert_eq!(xml.matches("<testcase ").count(), 2, "{xml}");
        assert_eq!(xml.matches("<failure").count(), 1, "{xml}");
        assert!(xml.contains("measured 5e-1, limit 1e-2"), "{xml}");
        assert!(xml.contains("name=\"line.x / diffuse / p99 rel. error\""), "{xml}");
        assert!(
            xml.contains("time=\"1.250\"") && xml.contains("failures=\"1\""),
            "{xml}"
        );
        assert!(xml.contains("<testsuites>\n"), "no attribute on <testsuites>: {xml}");
    }

    #[test]
    fn an_empty_suite_is_left_out_and_text_is_escaped() {
        let xml = junit("c", &[], None, 1.0);
        assert!(!xml.contains("<testsuite "), "{xml}");
        let mut c = check(false, 0.5);
        c.method = "a<b>&\"'\u{1}".into();
        let xml = junit("c", &[c], None, 1.0);
        assert!(xml.contains("a&lt;b&gt;&amp;&quot;&apos;?"), "{xml}");
    }

    #[test]
    fn timestamps_are_utc_civil_dates() {
        let at = |s: u64| timestamp(std::time::UNIX_EPOCH + std::time::Duration::from_secs(s));
        assert_eq!(at(0), "1970-01-01T00:00:00");
        // 2000-02-29 12:34:56 UTC, a leap day.
        assert_eq!(at(951_827_696), "2000-02-29T12:34:56");
        // 2026-12-02 06:40:00 UTC.
        assert_eq!(at(1_796_193_600), "2026-12-02T06:40:00");
    }
}
