//! Every path bounded and checked before any work: claim expressions run under operation and
//! size limits, a claim on a bin that does not exist is bad input.

use crate::common;
use common::{stderr, sweep, CASE};
use std::time::{Duration, Instant};

/// `CASE` with one `[[bins]]` axis and the claim `expect` (id `id`).
fn with_claim(id: &str, expect: &str) -> String {
    format!(
        "{CASE}\n[[bins]]\naxis = \"elevation\"\nedges = [10.0, 45.0, 90.0]\n\n[[claims]]\nid = \"{id}\"\nexpect = '{expect}'\ntext = \"t\"\n"
    )
}

#[test]
fn a_claim_that_loops_or_builds_a_huge_string_is_bad_input_naming_it() {
    for (id, expect, limit) in [
        ("spins", "(|| loop { 1 }).call()", "operations"),
        ("grows", r#""x".pad(2000000000, "y") == """#, "bytes"),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let t = Instant::now();
        let o = sweep(dir.path(), &with_claim(id, expect), &[]);
        assert!(
            t.elapsed() < Duration::from_secs(30),
            "{id}: stopped in {:?}",
            t.elapsed()
        );
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{id}: {e}");
        assert!(e.contains(&format!("claim `{id}`")) && e.contains(limit), "{id}: {e}");
        assert!(!dir.path().join("reports").exists(), "{id}: nothing is written");
    }
}

#[test]
fn a_claim_on_a_bin_lower_edge_that_does_not_exist_is_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    // 90 is the axis's upper edge, not a bin's lower edge; 30 is no edge at all.
    for lo in ["30.0", "90.0"] {
        let expect = format!(r#"bin_p99("line.ltc2023", "diffuse", "elevation", {lo}) < 1.0"#);
        let o = sweep(dir.path(), &with_claim("edge", &expect), &[]);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{lo}: {e}");
        assert!(
            e.contains("claim `edge`") && e.contains("lower edge") && e.contains("10, 45"),
            "{lo}: {e}"
        );
    }
    // An edge that exists is measured (the claim holds or is stale, never bad input).
    let expect = r#"bin_count("line.ltc2023", "diffuse", "elevation", 45.0) >= 0.0"#;
    let o = sweep(dir.path(), &with_claim("edge", expect), &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}
