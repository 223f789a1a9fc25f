//! f32 intervals with outward rounding. An [`Iv`]'s ends are f32 values held as f64 (integers
//! and booleans use the same type, exactly). Every operation's result holds every f32 an
//! implementation within the spec's rule may return for any arguments inside the operands.

/// A closed interval `[lo, hi]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Iv {
    pub lo: f64,
    pub hi: f64,
}

/// Why an operation has no finite bound.
#[derive(Clone, Debug, PartialEq)]
pub enum Gap {
    /// An infinity or NaN may be an intermediate (a driver assuming finite math may return
    /// anything from here on).
    NonFinite(&'static str),
    /// The spec bounds the operation only on a range the operands leave.
    Domain(&'static str),
}

impl Iv {
    pub fn point(x: f64) -> Iv {
        Iv { lo: x, hi: x }
    }
    pub fn new(lo: f64, hi: f64) -> Iv {
        Iv { lo, hi }
    }
    pub fn hull(self, o: Iv) -> Iv {
        Iv::new(self.lo.min(o.lo), self.hi.max(o.hi))
    }
    pub fn is_point(self) -> bool {
        self.lo == self.hi
    }
    /// An infinite end or a NaN.
    pub fn non_finite(self) -> bool {
        !(self.lo.is_finite() && self.hi.is_finite())
    }
    pub fn contains(self, x: f64) -> bool {
        self.lo <= x && x <= self.hi
    }
    pub fn negated(self) -> Iv {
        Iv::new(-self.hi, -self.lo)
    }
    /// The larger magnitude of the two ends.
    pub fn mag(self) -> f64 {
        self.lo.abs().max(self.hi.abs())
    }
    /// The smallest magnitude inside.
    pub fn mig(self) -> f64 {
        if self.contains(0.0) {
            0.0
        } else {
            self.lo.abs().min(self.hi.abs())
        }
    }
    /// Subnormal inputs and outputs may be flushed to zero: the interval takes in 0.
    pub fn flush(self) -> Iv {
        let tiny = f32::MIN_POSITIVE as f64;
        let lo = if self.lo > 0.0 && self.lo < tiny { 0.0 } else { self.lo };
        let hi = if self.hi < 0.0 && self.hi > -tiny { 0.0 } else { self.hi };
        Iv::new(lo, hi)
    }
}

/// `a + b` as `s + e` exactly (Knuth's two-sum in f64).
pub fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    let e = (a - (s - bb)) + (b - bb);
    (s, if e.is_finite() { e } else { 0.0 })
}

/// The largest f32 ≤ s + e (|e| at most half an f64 ULP of s).
pub fn down(s: f64, e: f64) -> f64 {
    if s.is_nan() {
        return f64::NAN;
    }
    let r = s as f32;
    let rf = r as f64;
    (if rf > s || (rf == s && e < 0.0) {
        r.next_down()
    } else {
        r
    }) as f64
}

/// The smallest f32 ≥ s + e.
pub fn up(s: f64, e: f64) -> f64 {
    if s.is_nan() {
        return f64::NAN;
    }
    let r = s as f32;
    let rf = r as f64;
    (if rf < s || (rf == s && e > 0.0) { r.next_up() } else { r }) as f64
}

/// The spec's ULP(x) for f32, taken at its larger value: the gap of x's binade (the spec's
/// minimum gap is half of it at a power of two: the larger one keeps the bound outer).
pub fn ulp32(x: f64) -> f64 {
    let a = x.abs();
    if !(a <= f32::MAX as f64) {
        return 2f64.powi(104); // beyond the finite range: MAX - next_down(MAX)
    }
    if a < f32::MIN_POSITIVE as f64 {
        return 2f64.powi(-149);
    }
    // The binade's exponent, read from the f64 bits (a is a normal f64 here).
    let e = ((a.to_bits() >> 52) & 0x7ff) as i32 - 1023;
    2f64.powi(e - 23)
}

/// A lower and an upper f64 bound of a value some f64 library function returned within a few
/// f64 ULP (libm's f64 functions are within 1 ULP; 4 are allowed).
pub fn f64_lower(x: f64) -> f64 {
    x.next_down().next_down().next_down().next_down()
}
pub fn f64_upper(x: f64) -> f64 {
    x.next_up().next_up().next_up().next_up()
}

/// The exact range `[lo, hi]` (f64 bounds) rounded outward to f32: a correctly rounded result.
pub fn round_out(lo: f64, hi: f64) -> Iv {
    Iv::new(down(lo, 0.0), up(hi, 0.0)).flush()
}

/// The exact range widened by `k` ULP (at its larger magnitude), rounded outward.
pub fn widen_ulp(lo: f64, hi: f64, k: f64) -> Iv {
    let u = k * ulp32(lo.abs().max(hi.abs()));
    round_out((lo - u).next_down(), (hi + u).next_up())
}

/// The exact range widened by an absolute `eps`, rounded outward.
pub fn widen_abs(lo: f64, hi: f64, eps: f64) -> Iv {
    round_out((lo - eps).next_down(), (hi + eps).next_up())
}

pub fn add(a: Iv, b: Iv) -> Iv {
    let (s, e) = two_sum(a.lo, b.lo);
    let (t, f) = two_sum(a.hi, b.hi);
    Iv::new(down(s, e), up(t, f)).flush()
}

pub fn sub(a: Iv, b: Iv) -> Iv {
    add(a, b.negated())
}

/// Products of f32 values are exact in f64 (48 significant bits, exponents in range).
pub fn mul(a: Iv, b: Iv) -> Iv {
    let p = [a.lo * b.lo, a.lo * b.hi, a.hi * b.lo, a.hi * b.hi];
    if p.iter().any(|x| x.is_nan()) {
        return Iv::new(f64::NAN, f64::NAN);
    }
    let lo = p.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = p.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    Iv::new(down(lo, 0.0), up(hi, 0.0)).flush()
}

/// `a / b` within `k` ULP (2.5 by the spec; 0 for a correctly rounded quotient). A divisor
/// holding 0, or any magnitude outside [2^-126, 2^126], has no bound.
pub fn div(a: Iv, b: Iv, k: f64) -> Result<Iv, Gap> {
    if b.contains(0.0) {
        return Err(Gap::NonFinite("division by a divisor that may be 0"));
    }
    if b.mig() < super::accuracy::DOMAIN_MIN || b.mag() > super::accuracy::DOMAIN_MAX {
        return Err(Gap::Domain("division with |y| outside [2^-126, 2^126]"));
    }
    let q = [a.lo / b.lo, a.lo / b.hi, a.hi / b.lo, a.hi / b.hi];
    let lo = q.iter().copied().fold(f64::INFINITY, f64::min).next_down();
    let hi = q.iter().copied().fold(f64::NEG_INFINITY, f64::max).next_up();
    Ok(widen_ulp(lo, hi, k))
}

/// Three-valued truth: [1, 1] true, [0, 0] false, [0, 1] either.
pub fn truth(yes: bool, no: bool) -> Iv {
    match (yes, no) {
        (true, false) => Iv::point(1.0),
        (false, true) => Iv::point(0.0),
        _ => Iv::new(0.0, 1.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounding_down_and_up_bracket_the_exact_sum() {
        let (a, b) = (1.0f64, 2f64.powi(-30));
        let (s, e) = two_sum(a, b);
        assert_eq!(down(s, e), 1.0);
        assert_eq!(up(s, e), (1.0f32).next_up() as f64);
        // Exactly representable: a point.
        assert_eq!(add(Iv::point(1.0), Iv::point(2.0)), Iv::point(3.0));
        // 1 - 2^-126: far below f64 resolution, still bracketed.
        let t = sub(Iv::point(1.0), Iv::point(2f64.powi(-126)));
        assert_eq!(t, Iv::new((1.0f32).next_down() as f64, 1.0));
    }

    #[test]
    fn ulp_is_the_binade_gap() {
        assert_eq!(ulp32(1.5), 2f64.powi(-23));
        assert_eq!(ulp32(1.0), 2f64.powi(-23));
        assert_eq!(ulp32(0.75), 2f64.powi(-24));
        assert_eq!(ulp32(0.0), 2f64.powi(-149));
    }

    #[test]
    fn subnormals_may_flush() {
        let tiny = 2f64.powi(-140);
        assert_eq!(Iv::point(tiny).flush(), Iv::new(0.0, tiny));
        assert_eq!(Iv::point(-tiny).flush(), Iv::new(-tiny, 0.0));
    }

    #[test]
    fn division_by_a_range_holding_zero_is_not_bounded() {
        assert!(matches!(
            div(Iv::point(1.0), Iv::new(-1.0, 1.0), 2.5),
            Err(Gap::NonFinite(_))
        ));
        assert!(matches!(
            div(Iv::point(1.0), Iv::point(2f64.powi(127)), 2.5),
            Err(Gap::Domain(_))
        ));
        let q = div(Iv::point(1.0), Iv::point(3.0), 2.5).unwrap();
        assert!(q.contains((1.0f32 / 3.0) as f64));
        assert!(q.hi - q.lo <= 6.0 * ulp32(1.0 / 3.0));
    }
}
