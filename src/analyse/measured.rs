//! The measure stage's mergeable state as [`Accumulate`]s, like the analysis's accumulators:
//! the best starts of the searches (`TopK`), the kept state (`Kept`), the times
//! (`Timing`) and a sweep's part (`Part`), so that shards merge through one trait.

use crate::analyse::stats::Accumulate;
use crate::measure::search::{Start, TopK};
use crate::measure::sweep::{Keep, Kept, Part, Timing, TopUpRow};

/// A start offered by its configuration's global index (ties keep the lower index).
impl Accumulate<(usize, Start)> for TopK {
    fn add(&mut self, (index, start): (usize, Start)) {
        self.push(index, start);
    }

    fn merge(&mut self, other: &TopK) -> Result<(), String> {
        self.merge_from(other);
        Ok(())
    }
}

impl<'a> Accumulate<Keep<'a>> for Kept {
    fn add(&mut self, input: Keep<'a>) {
        self.add_chunk(input);
    }

    fn merge(&mut self, other: &Kept) -> Result<(), String> {
        self.merge_from(other);
        Ok(())
    }
}

/// Another run's measuring times add to these (the searches and the cost pass run once).
impl<'a> Accumulate<&'a Timing> for Timing {
    fn add(&mut self, input: &'a Timing) {
        Timing::add(self, input);
    }

    fn merge(&mut self, other: &Timing) -> Result<(), String> {
        Timing::add(self, other);
        Ok(())
    }
}

/// A part takes measured top-ups whole (settled at the merge: `sweep::settle_topups`).
impl Accumulate<TopUpRow> for Part {
    fn add(&mut self, row: TopUpRow) {
        self.topup_rows.push(row);
    }

    fn merge(&mut self, other: &Part) -> Result<(), String> {
        self.merge_from(other)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analyse::stats::merge_each;

    fn start(score: f64) -> Start {
        let case = crate::input::case::Case::parse(
            "t.toml",
            r#"
name = "t"
title = "t"
seed = 1
methods = ["line.ltc2017"]
[geometry]
elevation = { dist = "uniform", min = 10.0, max = 90.0 }
tilt_angle = { dist = "uniform", min = 0.0, max = 180.0 }
length = { dist = "log_uniform", min = 0.1, max = 10.0 }
center = { dist = "uniform", min = -2.0, max = 2.0 }
[[materials]]
name = "d"
kind = "diffuse"
count = 1
"#,
        )
        .unwrap();
        Start {
            sample: crate::input::sampler::sample_case(&case).remove(0),
            values: vec![0.0],
            reference: crate::reference::Estimate { value: 1.0, error: 0.0 },
            score,
        }
    }

    #[test]
    fn top_k_merged_is_the_k_best_of_one_pass_ties_to_the_lower_index() {
        let scores = [3.0, 1.0, 4.0, 1.0, 5.0, 9.0, 2.0, 6.0, 5.0, 3.0];
        let mut whole = TopK::new(4);
        for (i, &s) in scores.iter().enumerate() {
            whole.add((i, start(s)));
        }
        // Two parts: even and odd indices, merged through the trait (as shards are).
        let mut parts = [TopK::new(4), TopK::new(4)];
        for (i, &s) in scores.iter().enumerate() {
            parts[i % 2].add((i, start(s)));
        }
        let (a, b) = parts.split_at_mut(1);
        merge_each(a, &b[..1]).unwrap();
        let order = |t: TopK| t.into_sorted().into_iter().map(|s| s.score).collect::<Vec<_>>();
        assert_eq!(order(whole), [9.0, 6.0, 5.0, 5.0]);
        assert_eq!(order(a[0].clone()), [9.0, 6.0, 5.0, 5.0]);
    }
}
