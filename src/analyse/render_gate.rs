//! The render gate's rules (docs/render.md, "In the gate"): a render compared with its
//! baseline pixel by pixel, per method. Pure: the FLIP maps come in computed (the app layer
//! runs nv-flip on the images); this file only decides.
//!
//! - `flip`: the mean FLIP against the reference over the floor, now against the baseline's;
//!   a rise beyond the noise is a regression.
//! - `image`: the screenshot comparison, FLIP between the baseline's image and this run's. A
//!   visible change (FLIP above the visible threshold on at least the visible share of the
//!   floor) fails when at least that many of the changed pixels moved away from the reference
//!   (their FLIP against it rose): a local regression fails even when the mean improved.
//! - `nan`: a floor pixel NaN or ±inf now that was not in the baseline.

use crate::analyse::gate::{Change, RuleResult};

/// The render gate's thresholds.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct RenderGateOptions {
    /// A change of the mean FLIP against the reference within ±this is no change.
    pub flip_noise: f64,
    /// A pixel's FLIP above this is visible (docs/render.md: the render's own threshold).
    pub visible_flip: f64,
    /// A set of pixels is visible when it holds at least this share of the floor (and at
    /// least one pixel).
    pub visible_share: f64,
}

/// One method's maps over the floor pixels, all in the same pixel order.
pub struct MethodMaps<'a> {
    pub label: &'a str,
    /// FLIP of the baseline's image against the baseline's reference image.
    pub base: &'a [f32],
    /// FLIP of this run's image against this run's reference image.
    pub now: &'a [f32],
    /// FLIP of this run's image against the baseline's image.
    pub change: &'a [f32],
    /// NaN or ±inf in the baseline, and now.
    pub base_nonfinite: &'a [bool],
    pub now_nonfinite: &'a [bool],
}

/// The rules of one method and the floor pixels (indices) that regressed: changed visibly and
/// moved away from the reference, or NaN/inf new since the baseline.
pub struct MethodOutcome {
    pub rules: Vec<RuleResult>,
    pub regressed_pixels: Vec<usize>,
}

fn mean(v: &[f32]) -> f64 {
    if v.is_empty() {
        0.0
    } else {
        v.iter().map(|&x| f64::from(x)).sum::<f64>() / v.len() as f64
    }
}

/// The least count of pixels that is visible on a floor of `n` pixels.
pub fn visible_count(n: usize, o: &RenderGateOptions) -> usize {
    ((o.visible_share * n as f64).ceil() as usize).max(1)
}

pub fn rules(m: &MethodMaps, o: &RenderGateOptions) -> MethodOutcome {
    let n = m.now.len();
    assert!(
        [
            m.base.len(),
            m.change.len(),
            m.base_nonfinite.len(),
            m.now_nonfinite.len()
        ]
        .iter()
        .all(|&k| k == n),
        "one value per floor pixel in every map"
    );
    let rule = |rule: &'static str, change: Change, message: String| RuleResult {
        method: m.label.to_string(),
        material: "floor".into(),
        rule,
        change,
        message,
    };
    let at_least = visible_count(n, o);
    let above = |v: &[f32]| v.iter().filter(|&&x| f64::from(x) > o.visible_flip).count();
    let (mb, ma) = (mean(m.base), mean(m.now));
    let delta = ma - mb;
    let flip = rule(
        "flip",
        if delta > o.flip_noise {
            Change::Regressed
        } else if delta < -o.flip_noise {
            Change::Improved
        } else {
            Change::Unchanged
        },
        format!(
            "mean FLIP against the reference {ma:.5} (baseline {mb:.5}, change {delta:+.5}, noise ±{}); \
             FLIP > {} on {} of {n} floor pixels (baseline {})",
            o.flip_noise,
            o.visible_flip,
            above(m.now),
            above(m.base)
        ),
    );
    let changed: Vec<usize> = (0..n).filter(|&i| f64::from(m.change[i]) > o.visible_flip).collect();
    let worse: Vec<usize> = changed.iter().copied().filter(|&i| m.now[i] > m.base[i]).collect();
    let better = changed.iter().filter(|&&i| m.now[i] < m.base[i]).count();
    let visible = changed.len() >= at_least;
    let image = rule(
        "image",
        if !visible {
            Change::Unchanged
        } else if worse.len() >= at_least {
            Change::Regressed
        } else if better >= at_least {
            Change::Improved
        } else {
            Change::Unchanged
        },
        format!(
            "against the baseline's image: mean FLIP {:.5}, FLIP > {} on {} of {n} floor pixels ({}; visible \
             means at least {at_least}); of those, {} moved away from the reference and {better} towards it \
             (a regression from {at_least})",
            mean(m.change),
            o.visible_flip,
            changed.len(),
            if visible {
                "a visible change"
            } else {
                "no visible change"
            },
            worse.len()
        ),
    );
    let new_nan: Vec<usize> = (0..n).filter(|&i| m.now_nonfinite[i] && !m.base_nonfinite[i]).collect();
    let fixed = (0..n).filter(|&i| m.base_nonfinite[i] && !m.now_nonfinite[i]).count();
    let nan = rule(
        "nan",
        if !new_nan.is_empty() {
            Change::Regressed
        } else if fixed > 0 {
            Change::Improved
        } else {
            Change::Unchanged
        },
        format!(
            "{} floor pixels NaN/inf new since the baseline, {fixed} fixed",
            new_nan.len()
        ),
    );
    let mut regressed_pixels = if image.change == Change::Regressed {
        worse
    } else {
        Vec::new()
    };
    regressed_pixels.extend(new_nan);
    regressed_pixels.sort_unstable();
    regressed_pixels.dedup();
    MethodOutcome {
        rules: vec![flip, image, nan],
        regressed_pixels,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const O: RenderGateOptions = RenderGateOptions {
        flip_noise: 0.001,
        visible_flip: 0.1,
        visible_share: 0.001,
    };

    fn outcome(base: &[f32], now: &[f32], change: &[f32]) -> Vec<Change> {
        let f = vec![false; base.len()];
        let m = MethodMaps {
            label: "m",
            base,
            now,
            change,
            base_nonfinite: &f,
            now_nonfinite: &f,
        };
        rules(&m, &O).rules.iter().map(|r| r.change).collect()
    }

    #[test]
    fn the_same_image_is_unchanged() {
        let base = vec![0.2f32; 1000];
        assert_eq!(outcome(&base, &base, &[0.0; 1000]), [Change::Unchanged; 3]);
    }

    #[test]
    fn a_local_visible_regression_fails_though_the_mean_improves() {
        // 10 of 1000 pixels visibly changed and further from the reference; the other 990
        // slightly closer: the mean improves, the image rule fails.
        let base = vec![0.2f32; 1000];
        let mut now = vec![0.19f32; 1000];
        let mut change = vec![0.01f32; 1000];
        for i in 0..10 {
            now[i] = 0.6;
            change[i] = 0.5;
        }
        let c = outcome(&base, &now, &change);
        assert_eq!(c, [Change::Improved, Change::Regressed, Change::Unchanged]);
        // A visible change towards the reference is an improvement.
        let now: Vec<f32> = (0..1000).map(|i| if i < 10 { 0.0 } else { 0.2 }).collect();
        let c = outcome(&base, &now, &change);
        assert_eq!(c[1], Change::Improved);
        // Below the visible share (0 of 1000 above 0.1): no visible change.
        assert_eq!(outcome(&base, &base, &[0.09; 1000])[1], Change::Unchanged);
    }

    #[test]
    fn a_mean_rise_beyond_the_noise_fails_and_new_nan_fails() {
        let base = vec![0.2f32; 100];
        let now = vec![0.202f32; 100];
        assert_eq!(outcome(&base, &now, &[0.0; 100])[0], Change::Regressed);
        let now = vec![0.2005f32; 100];
        assert_eq!(outcome(&base, &now, &[0.0; 100])[0], Change::Unchanged);
        let f = vec![false; 100];
        let mut t = f.clone();
        t[3] = true;
        let m = MethodMaps {
            label: "m",
            base: &base,
            now: &base,
            change: &[0.0; 100],
            base_nonfinite: &f,
            now_nonfinite: &t,
        };
        let out = rules(&m, &O);
        assert_eq!(out.rules[2].change, Change::Regressed);
        assert_eq!(out.regressed_pixels, vec![3]);
        assert_eq!(visible_count(100, &O), 1);
        assert_eq!(visible_count(35584, &O), 36);
    }
}
