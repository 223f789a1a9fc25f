//! A scan's counts made a rate: offending values over the configurations evaluated, with the
//! exact two-sided 95 % Clopper–Pearson interval (`stats::clopper_pearson`).

use crate::analyse::stats::clopper_pearson;
use crate::input::scene::Config;
use crate::measure::scan::{ScanCounts, Scanned};
use serde::Serialize;

/// What a scan of one method over one family found: what `scan.md` and `summary.json` show.
#[derive(Clone, Debug, Serialize)]
pub struct ScanResult {
    #[serde(flatten)]
    pub counts: ScanCounts,
    /// Offending (NaN, inf, negative, above the bound or above B) over configurations, with its exact
    /// two-sided 95 % Clopper–Pearson interval.
    pub rate: f64,
    pub rate_low: f64,
    pub rate_high: f64,
    pub seconds: f64,
    /// The first offending configurations, in the eval input format.
    pub captured: Vec<Config>,
}

impl From<Scanned> for ScanResult {
    fn from(s: Scanned) -> ScanResult {
        let evaluated = s.counts.configurations;
        let (rate_low, rate_high) = clopper_pearson(s.offending, evaluated);
        ScanResult {
            counts: s.counts,
            rate: s.offending as f64 / evaluated.max(1) as f64,
            rate_low,
            rate_high,
            seconds: s.seconds,
            captured: s.captured,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rate_is_offending_over_evaluated_within_its_interval() {
        let counts = ScanCounts {
            method: "m".into(),
            family: "f".into(),
            configurations: 1000,
            degenerate: 3,
            nan: 2,
            inf: 1,
            negative: 0,
            above_bound: None,
            above_light_bound: 2,
        };
        let r = ScanResult::from(Scanned {
            counts,
            offending: 5,
            seconds: 1.0,
            captured: Vec::new(),
        });
        assert_eq!(r.rate, 0.005);
        assert!(r.rate_low < 0.005 && 0.005 < r.rate_high, "{r:?}");
        // The JSON keeps the counts' keys first, then the rate, as scan's summary.json had them.
        let text = serde_json::to_string(&r).unwrap();
        let at = |k: &str| {
            text.find(&format!("\"{k}\""))
                .unwrap_or_else(|| panic!("{k} in {text}"))
        };
        let order = [
            "method",
            "above_light_bound",
            "rate",
            "rate_high",
            "seconds",
            "captured",
        ]
        .map(at);
        assert!(order.windows(2).all(|w| w[0] < w[1]), "{text}");
    }
}
