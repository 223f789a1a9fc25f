//! The gate's paired share rule (docs/ci/README.md): over the configurations lit in both the
//! baseline and this run, a configuration got worse when its error ratio exceeds 1 + noise
//! and its error grew by more than k ULPs of the reference. Per material and per bin, the
//! share that got worse is tested against an allowed share with a one-sided binomial test.
//! The quantile rules (app/gate) look at the distribution; this rule looks at how many moved,
//! so a change that improves p99 while worsening many configurations still fails.

use crate::analyse::stats::{binomial_upper_tail, nearest_rank, nearest_rank_unsorted};
use rand::{Rng, SeedableRng};
use serde::Serialize;

/// Relative errors below this count as this: f32 cannot resolve them (2⁻²⁴, half an ulp at
/// 1), so ratios of two such errors are rounding noise, not a change.
pub const ERROR_FLOOR: f64 = 1.0 / 16_777_216.0;

/// The share rule's thresholds.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ShareOptions {
    /// A ratio up to 1 + noise is no change (the quantile rules' noise).
    pub noise: f64,
    /// An error growth up to this many ULPs of the reference (f32) is no change.
    pub ulps: f64,
    /// The share of configurations allowed to get worse.
    pub share: f64,
    /// The binomial test's significance: a bin fails when P(this many worse | share) < alpha.
    pub alpha: f64,
    /// A bin with fewer worse configurations than this never fails.
    pub min_worse: usize,
}

impl Default for ShareOptions {
    fn default() -> Self {
        ShareOptions {
            noise: 0.05,
            ulps: 4.0,
            share: 0.05,
            alpha: 0.01,
            min_worse: 5,
        }
    }
}

/// One configuration lit in both runs: its relative errors and the reference's f32 ULP over
/// |reference| ([`crate::analyse::stats::ulp_relative`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pair {
    pub base: f64,
    pub now: f64,
    pub ulp: f64,
}

impl Pair {
    /// Worse beyond the noise and beyond k ULPs of the reference.
    pub fn worse(&self, o: &ShareOptions) -> bool {
        let fl = |e: f64| e.max(ERROR_FLOOR);
        fl(self.now) / fl(self.base) > 1.0 + o.noise && self.now - self.base > o.ulps * self.ulp
    }

    /// Better by the same two margins.
    pub fn better(&self, o: &ShareOptions) -> bool {
        let fl = |e: f64| e.max(ERROR_FLOOR);
        fl(self.base) / fl(self.now) > 1.0 + o.noise && self.base - self.now > o.ulps * self.ulp
    }
}

/// The share test of one scope: a whole material, or one bin of one axis.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ShareTest {
    /// `all` for the whole material, else `axis [lo, hi)`.
    pub scope: String,
    pub pairs: usize,
    pub worse: usize,
    pub better: usize,
    /// P(at least `worse` of `pairs` worse) if each got worse with the allowed share.
    pub p_value: f64,
    pub regressed: bool,
}

impl ShareTest {
    /// The P value as the rule prints it: `< 1e-300` where it underflows to 0.
    pub fn p_text(&self) -> String {
        if self.p_value > 0.0 {
            format!("{:.1e}", self.p_value)
        } else {
            "< 1e-300".into()
        }
    }

    pub fn share(&self) -> f64 {
        if self.pairs == 0 {
            0.0
        } else {
            self.worse as f64 / self.pairs as f64
        }
    }
}

/// The test over `pairs`, indices of the pairs in scope.
pub fn share_test(scope: String, pairs: &[Pair], o: &ShareOptions) -> ShareTest {
    let worse = pairs.iter().filter(|p| p.worse(o)).count();
    let better = pairs.iter().filter(|p| p.better(o)).count();
    let p_value = binomial_upper_tail(worse, pairs.len(), o.share);
    ShareTest {
        scope,
        pairs: pairs.len(),
        worse,
        better,
        p_value,
        regressed: worse >= o.min_worse && p_value < o.alpha,
    }
}

/// A bin axis as the share rule sees it: its name and edges.
pub struct Axis<'a> {
    pub name: &'a str,
    pub edges: &'a [f64],
}

/// The share tests of one material: the whole material first, then each bin of each axis that
/// holds a pair. `bins[i][a]` is pair i's bin on axis a (None: outside the axis).
pub fn share_tests(pairs: &[Pair], bins: &[Vec<Option<usize>>], axes: &[Axis], o: &ShareOptions) -> Vec<ShareTest> {
    assert_eq!(pairs.len(), bins.len(), "one bin list per pair");
    let mut tests = vec![share_test("all".into(), pairs, o)];
    for (a, axis) in axes.iter().enumerate() {
        for k in 0..axis.edges.len().saturating_sub(1) {
            let inside: Vec<Pair> = pairs
                .iter()
                .zip(bins)
                .filter(|(_, b)| b.get(a).copied().flatten() == Some(k))
                .map(|(p, _)| *p)
                .collect();
            if inside.is_empty() {
                continue;
            }
            let scope = format!("{} [{}, {})", axis.name, axis.edges[k], axis.edges[k + 1]);
            tests.push(share_test(scope, &inside, o));
        }
    }
    tests
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Change {
    Regressed,
    Improved,
    Unchanged,
    /// Not compared (unsupported material, or a method new since the baseline).
    Skipped,
}

impl Change {
    /// The verdict of a set of rules: regressed if any rule regressed, else improved if any
    /// improved, else unchanged.
    pub fn overall(rules: &[RuleResult]) -> Change {
        if rules.iter().any(|r| r.change == Change::Regressed) {
            Change::Regressed
        } else if rules.iter().any(|r| r.change == Change::Improved) {
            Change::Improved
        } else {
            Change::Unchanged
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Change::Regressed => "regressed",
            Change::Improved => "improved",
            Change::Unchanged => "unchanged",
            Change::Skipped => "skipped",
        }
    }
}

/// One gated rule for one method × material (material `(all)` for per-method rules).
#[derive(Clone, Debug, Serialize)]
pub struct RuleResult {
    pub method: String,
    pub material: String,
    pub rule: &'static str,
    pub change: Change,
    /// The numbers behind the outcome, one line.
    pub message: String,
}

/// The paired statistics of one method × material.
#[derive(Clone, Debug, Serialize)]
pub struct Paired {
    pub pairs: usize,
    /// exp(mean log ratio): the geometric mean of now / baseline error, with its 95 % bounds.
    pub geomean: [f64; 3],
    /// p99 of now over p99 of baseline (over the paired configurations), with its bounds.
    pub p99_ratio: [f64; 3],
    /// Configurations worse / better by more than the noise threshold (a sign test's counts).
    pub worse: usize,
    pub better: usize,
}

/// Paired bootstrap of (geometric-mean ratio, p99 ratio) over (baseline, now) error pairs.
pub fn paired(pairs: &[(f64, f64)], resamples: usize, noise: f64) -> Paired {
    let n = pairs.len();
    let fl = |e: f64| e.max(ERROR_FLOOR);
    let logs: Vec<f64> = pairs.iter().map(|&(b, a)| (fl(a) / fl(b)).ln()).collect();
    let base: Vec<f64> = pairs.iter().map(|&(b, _)| fl(b)).collect();
    let now: Vec<f64> = pairs.iter().map(|&(_, a)| fl(a)).collect();
    let stat = |idx: &mut dyn Iterator<Item = usize>| {
        let (mut sum, mut b, mut a) = (0.0, Vec::with_capacity(n), Vec::with_capacity(n));
        for i in idx {
            sum += logs[i];
            b.push(base[i]);
            a.push(now[i]);
        }
        let pb = nearest_rank_unsorted(&mut b, 0.99);
        let pa = nearest_rank_unsorted(&mut a, 0.99);
        ((sum / n as f64).exp(), pa / pb)
    };
    if n == 0 {
        return Paired {
            pairs: 0,
            geomean: [f64::NAN; 3],
            p99_ratio: [f64::NAN; 3],
            worse: 0,
            better: 0,
        };
    }
    let (g, p) = stat(&mut (0..n));
    // Seeded: the same inputs give the same verdict on every machine.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x6c696e65);
    let (mut gs, mut ps) = (Vec::with_capacity(resamples), Vec::with_capacity(resamples));
    for _ in 0..resamples {
        let (gi, pi) = stat(&mut (0..n).map(|_| rng.random_range(0..n)));
        gs.push(gi);
        ps.push(pi);
    }
    gs.sort_by(f64::total_cmp);
    ps.sort_by(f64::total_cmp);
    let bounds = |v: &[f64], mid: f64| {
        if v.is_empty() {
            [mid, mid, mid]
        } else {
            [nearest_rank(v, 0.025), mid, nearest_rank(v, 0.975)]
        }
    };
    let t = (1.0 + noise).ln();
    Paired {
        pairs: n,
        geomean: bounds(&gs, g),
        p99_ratio: bounds(&ps, p),
        worse: logs.iter().filter(|&&d| d > t).count(),
        better: logs.iter().filter(|&&d| d < -t).count(),
    }
}

impl Paired {
    /// Regressed when either ratio's lower bound is above 1 + noise; otherwise improved when
    /// either ratio's upper bound is below 1/(1 + noise); otherwise unchanged (within noise).
    pub fn change(&self, noise: f64) -> Change {
        let up = 1.0 + noise;
        let [g_lo, _, g_hi] = self.geomean;
        let [p_lo, _, p_hi] = self.p99_ratio;
        if self.pairs == 0 {
            Change::Unchanged
        } else if g_lo > up || p_lo > up {
            Change::Regressed
        } else if g_hi < 1.0 / up || p_hi < 1.0 / up {
            Change::Improved
        } else {
            Change::Unchanged
        }
    }
}

/// The comparison of a run with a baseline.
#[derive(Clone, Debug, Serialize)]
pub struct GateReport {
    pub baseline_adapter: String,
    pub adapter: String,
    pub rules: Vec<RuleResult>,
    /// (method, baseline ns/eval, now ns/eval): reported, never gated.
    pub timings: Vec<(String, f64, f64)>,
    /// Methods run now that the baseline does not have (not gated).
    pub new_methods: Vec<String>,
    pub change: Change,
    /// The share rule's thresholds, and its tests per method × material.
    pub share_options: ShareOptions,
    pub shares: Vec<Shares>,
    /// Seconds the comparison took (the JUnit suite's time).
    pub seconds: f64,
    /// The configurations that got worse (share rule), or NaN/inf or false light where the
    /// baseline had neither, once each, in sample order: `regressed.jsonl` of the report.
    #[serde(skip)]
    pub replay: Vec<crate::input::scene::Config>,
}

/// The share tests of one method on one material.
#[derive(Clone, Debug, Serialize)]
pub struct Shares {
    pub method: String,
    pub material: String,
    pub tests: Vec<ShareTest>,
}

/// A ratio as the rules print it.
pub fn g(x: f64) -> String {
    format!("{x:.4}")
}

impl GateReport {
    pub fn regressed(&self) -> bool {
        self.change == Change::Regressed
    }

    /// The one-line summary: verdict, counts, and the regressed rules by name.
    pub fn summary(&self) -> String {
        let count = |c: Change| self.rules.iter().filter(|r| r.change == c).count();
        let regressed: Vec<String> = self
            .rules
            .iter()
            .filter(|r| r.change == Change::Regressed)
            .map(|r| format!("{} {} {}", r.method, r.material, r.rule))
            .collect();
        let improved: Vec<String> = self
            .rules
            .iter()
            .filter(|r| r.change == Change::Improved && r.rule == "error")
            .map(|r| format!("{} {}", r.method, r.material))
            .collect();
        let mut s = format!(
            "gate: {} ({} regressed, {} improved, {} unchanged, {} skipped)",
            self.change.name().to_uppercase(),
            count(Change::Regressed),
            count(Change::Improved),
            count(Change::Unchanged),
            count(Change::Skipped)
        );
        if !regressed.is_empty() {
            s += &format!("; regressed: {}", regressed.join(", "));
        }
        if !improved.is_empty() {
            s += &format!("; error improved: {}", improved.join(", "));
        }
        if self.adapter != self.baseline_adapter {
            // Another driver's transcendentals differ: a change may be the adapter's, not the kernel's.
            s += "; WARNING: the baseline was saved on another adapter";
        }
        s
    }

    /// Every rule and the timings, for the terminal.
    pub fn details(&self) -> String {
        let mut s = format!(
            "baseline adapter: {}\nthis run's adapter: {}\n",
            self.baseline_adapter, self.adapter
        );
        for r in &self.rules {
            s += &format!(
                "  {:<10} {} on {} [{}]: {}\n",
                r.change.name(),
                r.method,
                r.material,
                r.rule,
                r.message
            );
        }
        for (m, b, a) in &self.timings {
            s += &format!(
                "  timing (not gated) {m}: {} ns/eval against baseline {} ns/eval (×{})\n",
                g(*a),
                g(*b),
                g(a / b)
            );
        }
        for m in &self.new_methods {
            s += &format!("  new (no baseline, not gated): {m}\n");
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pair(base: f64, now: f64) -> Pair {
        Pair {
            base,
            now,
            ulp: 2f64.powi(-23),
        }
    }

    #[test]
    fn worse_needs_both_the_ratio_and_the_ulps() {
        let o = ShareOptions::default();
        // ×2 and far more than 4 ULPs: worse.
        assert!(pair(1e-4, 2e-4).worse(&o));
        assert!(pair(2e-4, 1e-4).better(&o));
        // ×1.04: within the noise.
        assert!(!pair(1e-4, 1.04e-4).worse(&o));
        // ×2 but one ULP of growth: a last-bit change.
        let one = 2f64.powi(-23);
        assert!(!pair(one, 2.0 * one).worse(&o));
        // ×2 and 5 ULPs: worse.
        assert!(pair(5.0 * one, 10.0 * one).worse(&o));
        // Below the floor on both sides: no change, whatever the ratio.
        assert!(!pair(1e-12, 1e-9).worse(&o));
    }

    #[test]
    fn the_share_fails_only_beyond_the_allowed_share_and_the_minimum_count() {
        let o = ShareOptions::default();
        let mixed = |n: usize, worse: usize| -> Vec<Pair> {
            (0..n)
                .map(|i| if i < worse { pair(1e-4, 1e-3) } else { pair(1e-4, 1e-4) })
                .collect()
        };
        // 3 % of 1000 worse: within the 5 % allowed.
        let t = share_test("all".into(), &mixed(1000, 30), &o);
        assert!(!t.regressed && t.worse == 30 && t.p_value > 0.5, "{t:?}");
        // 10 % of 1000: far beyond (P ≈ 1e-9).
        let t = share_test("all".into(), &mixed(1000, 100), &o);
        assert!(t.regressed && t.p_value < 1e-6, "{t:?}");
        // 4 of 4: every one worse, but fewer than the minimum count.
        let t = share_test("all".into(), &mixed(4, 4), &o);
        assert!(!t.regressed, "{t:?}");
        // 5 of 20: 25 %, P(X >= 5 | 20, 5 %) = 0.0026 < 0.01.
        let t = share_test("all".into(), &mixed(20, 5), &o);
        assert!(t.regressed && (t.p_value - 0.002_6).abs() < 1e-4, "{t:?}");
        // A looser share lets 10 % pass.
        let loose = ShareOptions { share: 0.2, ..o };
        assert!(!share_test("all".into(), &mixed(1000, 100), &loose).regressed);
    }

    #[test]
    fn a_bin_fails_where_the_whole_material_does_not() {
        let o = ShareOptions::default();
        // 1000 pairs over two bins; 40 worse, all in bin 1 (of 100): 4 % overall, 40 % there.
        let pairs: Vec<Pair> = (0..1000)
            .map(|i| {
                if (900..940).contains(&i) {
                    pair(1e-4, 1e-3)
                } else {
                    pair(1e-4, 1e-4)
                }
            })
            .collect();
        let bins: Vec<Vec<Option<usize>>> = (0..1000).map(|i| vec![Some(usize::from(i >= 900))]).collect();
        let axes = [Axis {
            name: "tilt",
            edges: &[0.0, 0.5, 1.0],
        }];
        let t = share_tests(&pairs, &bins, &axes, &o);
        assert_eq!(t.len(), 3);
        assert!(!t[0].regressed && t[0].worse == 40, "{:?}", t[0]);
        assert!(!t[1].regressed && t[1].pairs == 900, "{:?}", t[1]);
        assert!(
            t[2].regressed && t[2].scope == "tilt [0.5, 1)" && t[2].worse == 40,
            "{:?}",
            t[2]
        );
    }

    #[test]
    fn paired_test_sees_a_shift_and_not_the_noise() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let base: Vec<f64> = (0..2000).map(|_| 10f64.powf(rng.random_range(-7.0..-3.0))).collect();
        // Same errors, jittered by ±1 %: within noise.
        let same: Vec<(f64, f64)> = base.iter().map(|&b| (b, b * rng.random_range(0.99..1.01))).collect();
        assert_eq!(paired(&same, 200, 0.05).change(0.05), Change::Unchanged);
        // Every error ×1.5: regressed.
        let worse: Vec<(f64, f64)> = base.iter().map(|&b| (b, b * 1.5)).collect();
        assert_eq!(paired(&worse, 200, 0.05).change(0.05), Change::Regressed);
        // Only the worst 2 % ×10: the geometric mean barely moves, p99 catches it.
        let mut sorted = base.clone();
        sorted.sort_by(f64::total_cmp);
        let cut = sorted[sorted.len() * 98 / 100];
        let tail: Vec<(f64, f64)> = base.iter().map(|&b| (b, if b >= cut { b * 10.0 } else { b })).collect();
        assert_eq!(paired(&tail, 200, 0.05).change(0.05), Change::Regressed);
        // Every error halved: improved.
        let better: Vec<(f64, f64)> = base.iter().map(|&b| (b, b * 0.5)).collect();
        assert_eq!(paired(&better, 200, 0.05).change(0.05), Change::Improved);
    }
}
