//! JUnit XML for CI systems: one testcase per method × material × rule. The rules are the
//! case's tolerance checks and, with `--baseline`, the gate's rules (src/app/gate/mod.rs); each
//! failure carries its numbers. Written with quick-junit.

use super::{Change, GateReport};
use crate::analyse::analysis::Check;
use quick_junit::{NonSuccessKind, Report, TestCase, TestCaseStatus, TestSuite};

fn testcase(method: &str, material: &str, rule: &str, status: TestCaseStatus) -> TestCase {
    let mut t = TestCase::new(format!("{method} / {material} / {rule}"), status);
    t.set_classname(method.to_string());
    t
}

fn failure(message: String) -> TestCaseStatus {
    let mut s = TestCaseStatus::non_success(NonSuccessKind::Failure);
    s.set_message(message);
    s
}

/// The JUnit document of a sweep: suite `<case>.tolerances` and, with a gate, `<case>.baseline`.
pub fn junit(case: &str, checks: &[Check], gate: Option<&GateReport>) -> anyhow::Result<String> {
    let mut report = Report::new(format!("linelight {case}"));
    let mut tol = TestSuite::new(format!("{case}.tolerances"));
    for c in checks {
        let text = format!(
            "{} of {} on {}: measured {:e}, limit {:e}",
            c.what, c.method, c.material, c.measured, c.limit
        );
        let status = if c.pass {
            TestCaseStatus::success()
        } else {
            failure(format!("FAIL {text}"))
        };
        let mut t = testcase(&c.method, &c.material, &c.what, status);
        t.set_system_out(text);
        tol.add_test_case(t);
    }
    report.add_test_suite(tol);
    if let Some(gate) = gate {
        let mut suite = TestSuite::new(format!("{case}.baseline"));
        for r in &gate.rules {
            let status = match r.change {
                Change::Regressed => failure(format!(
                    "REGRESSED {} on {} [{}]: {}",
                    r.method, r.material, r.rule, r.message
                )),
                Change::Skipped => {
                    let mut s = TestCaseStatus::skipped();
                    s.set_message(r.message.clone());
                    s
                }
                Change::Improved | Change::Unchanged => TestCaseStatus::success(),
            };
            let mut t = testcase(&r.method, &r.material, r.rule, status);
            t.set_system_out(format!("{}: {}", r.change.name(), r.message));
            suite.add_test_case(t);
        }
        let timing: String = gate
            .timings
            .iter()
            .map(|(m, b, a)| format!("{m}: {a:.4} ns/eval, baseline {b:.4} (not gated)\n"))
            .collect();
        suite.set_system_out(timing);
        report.add_test_suite(suite);
    }
    Ok(report.to_string()?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failed_check_is_a_failure_with_its_numbers() {
        let check = |pass, measured| Check {
            method: "line.x".into(),
            material: "diffuse".into(),
            what: "p99 rel. error".into(),
            limit: 0.01,
            measured,
            pass,
        };
        let xml = junit("c", &[check(true, 0.001), check(false, 0.5)], None).unwrap();
        assert_eq!(xml.matches("<testcase ").count(), 2, "{xml}");
        assert_eq!(xml.matches("<failure").count(), 1, "{xml}");
        assert!(xml.contains("measured 5e-1, limit 1e-2"), "{xml}");
        assert!(xml.contains("name=\"line.x / diffuse / p99 rel. error\""), "{xml}");
    }
}
