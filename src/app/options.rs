//! Every float option of every command is read and checked here, by one rule: a finite
//! number inside the option's range. NaN, infinities and values such as 1e300 would
//! otherwise pass every comparison they meet (a bound no f32 exceeds, a noise band that
//! hides any change), so they are refused with exit 2 before any work.

/// The values a float option may take: finite, from `min` (excluded when `min_open`) to `max`.
#[derive(Clone, Copy, Debug)]
pub struct FloatRange {
    pub min: f64,
    pub min_open: bool,
    pub max: f64,
    /// What the range means, for the message.
    pub why: &'static str,
}

/// `--noise`, `--ops-growth`: a fraction from 0 to 1 (1 already calls a 2× change no change).
pub const FRACTION: FloatRange = FloatRange {
    min: 0.0,
    min_open: false,
    max: 1.0,
    why: "a fraction: 0.05 is 5 %, and 1 already takes a 2× change for none",
};

/// `--worse-ulps`: ULPs of the reference, from 0 to 2²³ (2²³ ULPs is the reference itself: a
/// larger k would call no growth a change).
pub const ULPS: FloatRange = FloatRange {
    min: 0.0,
    min_open: false,
    max: 8_388_608.0,
    why: "ULPs of the reference in f32; 8388608 ULPs is the reference itself",
};

/// `scan --bound`: above 0, and no larger than the largest f32, since the kernels' f32
/// values are compared with it (a larger bound would count nothing).
pub const BOUND: FloatRange = FloatRange {
    min: 0.0,
    min_open: true,
    max: f32::MAX as f64,
    why: "the f32 values are compared with it",
};

/// Checks `value`, given as `flag`, against `range`; the message names both.
pub fn check_float(flag: &str, value: f64, range: FloatRange) -> Result<f64, String> {
    why_not(value, range).map_or(Ok(value), |why| Err(format!("{flag} {why}")))
}

/// Why `value` is outside `range` (None: it is inside), starting with the value.
fn why_not(value: f64, range: FloatRange) -> Option<String> {
    let low = if range.min_open {
        value > range.min
    } else {
        value >= range.min
    };
    if value.is_finite() && low && value <= range.max {
        return None;
    }
    let number = |v: f64| {
        if v.abs() >= 1e6 {
            format!("{v:e}")
        } else {
            format!("{v}")
        }
    };
    let what = if value.is_finite() {
        format!("{}:", number(value))
    } else {
        format!("{value} is not a finite number:")
    };
    let (min, max) = (number(range.min), number(range.max));
    let span = if range.min_open {
        format!("above {min} and at most {max}")
    } else {
        format!("from {min} to {max}")
    };
    Some(format!("{what} must be {span} ({})", range.why))
}

/// Parses a float option as typed and checks it ([`check_float`]); clap adds the flag's name.
fn parse_float(text: &str, range: FloatRange) -> Result<f64, String> {
    let value: f64 = text
        .trim()
        .parse()
        .map_err(|_| format!("`{}` is not a number", crate::input::names::clip(text)))?;
    why_not(value, range).map_or(Ok(value), Err)
}

/// clap's parser of `--noise` and `--ops-growth`.
pub fn fraction(text: &str) -> Result<f64, String> {
    parse_float(text, FRACTION)
}

/// clap's parser of `--worse-ulps`.
pub fn ulps(text: &str) -> Result<f64, String> {
    parse_float(text, ULPS)
}

/// clap's parser of `scan --bound`.
pub fn bound(text: &str) -> Result<f64, String> {
    parse_float(text, BOUND)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_finite_values_in_range_pass() {
        for bad in ["NaN", "nan", "inf", "-inf", "1e300", "-0.1", "1.5", "x", ""] {
            assert!(fraction(bad).is_err(), "{bad}");
        }
        assert_eq!(fraction("0"), Ok(0.0));
        assert_eq!(fraction("0.05"), Ok(0.05));
        assert_eq!(fraction("1"), Ok(1.0));
        for bad in ["NaN", "inf", "-1", "1e7", "x"] {
            assert!(ulps(bad).is_err(), "{bad}");
        }
        assert_eq!(ulps("0"), Ok(0.0));
        assert_eq!(ulps("4"), Ok(4.0));
        for bad in ["NaN", "inf", "1e300", "3.5e38", "0", "-1"] {
            assert!(bound(bad).is_err(), "{bad}");
        }
        assert_eq!(bound("70000"), Ok(70000.0));
        assert_eq!(bound("3.4e38"), Ok(3.4e38));
        let e = check_float("--noise", f64::NAN, FRACTION).unwrap_err();
        assert_eq!(
            e,
            "--noise NaN is not a finite number: must be from 0 to 1 (a fraction: 0.05 is 5 %, and 1 \
             already takes a 2× change for none)"
        );
        let e = check_float("--bound", 1e300, BOUND).unwrap_err();
        assert!(
            e.starts_with("--bound 1e300: must be above 0 and at most 3.4028234663852886e38"),
            "{e}"
        );
    }
}
