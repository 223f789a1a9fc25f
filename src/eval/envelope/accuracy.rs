//! The WGSL specification's accuracy rules for f32, as data: the envelope (src/eval/interp/
//! envelope.rs) takes every allowance from [`TABLE`], so the numbers are written once, here.
//! Paraphrased (not copied) from the spec named in [`SPEC`]; docs/envelope.md cites each row.

/// Where the rules were read.
pub struct SpecSource {
    pub repository: &'static str,
    pub path: &'static str,
    pub commit: &'static str,
    pub date: &'static str,
    pub sections: &'static str,
}

pub const SPEC: SpecSource = SpecSource {
    repository: "gpuweb/gpuweb",
    path: "wgsl/index.bs",
    commit: "da251f90d8a04f3b52de9de306ba4155146de729",
    date: "2026-08-19",
    sections: "§ Floating Point Accuracy (#floating-point-accuracy), its table \"Accuracy of concrete floating \
               point operations / built-in functions\" (#concrete-float-accuracy), § Floating Point Rounding and \
               Overflow, § Reassociation and Fusion, § Floating Point Conversion, and the flush-to-zero and \
               Finite Math Assumption rules of § Floating Point Evaluation",
};

/// How far an f32 result may be from the exact result.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bound {
    /// Either f32 neighbour of the exact result (the exact value when representable).
    CorrectlyRounded,
    /// Within this many ULP (the spec's ULP: the smallest gap between f32 values around x).
    Ulp(f64),
    /// Within `a + b·|x|` ULP, x the argument (`exp`, `exp2`).
    UlpAffine(f64, f64),
    /// Within this absolute error.
    Absolute(f64),
    /// Absolute error on `[lo, hi]` of the argument, `ulp` ULP outside it (`log`, `log2`).
    AbsoluteInsideUlpOutside { abs: f64, lo: f64, hi: f64, ulp: f64 },
    /// The accuracy of evaluating the named WGSL expression, each of its operations by its
    /// own rule.
    Inherited(&'static str),
    /// The worse (the hull) of an absolute error and an inherited form (`acos`, `asin`).
    AbsoluteOrInherited(f64, &'static str),
    /// No bound at all ("Infinite ULP").
    Infinite,
}

/// One row: an operation, its bound, the argument range where the bound holds, and this
/// project's policy where the spec leaves a gap.
pub struct Rule {
    pub op: &'static str,
    pub bound: Bound,
    pub domain: &'static str,
    pub policy: &'static str,
}

/// 2^-126 and 2^126: the divisor range of `x / y` and of `atan2`'s `x`.
pub const DOMAIN_MIN: f64 = 1.1754943508222875e-38;
pub const DOMAIN_MAX: f64 = 8.507059173023462e37;
/// `sin`/`cos`'s bounded range: [−π, π].
pub const TRIG_RANGE: f64 = std::f64::consts::PI;

/// A rule of a correctly rounded operation, with no domain or policy.
const fn exact(op: &'static str) -> Rule {
    Rule {
        op,
        bound: Bound::CorrectlyRounded,
        domain: "",
        policy: "",
    }
}

/// A rule of an operation whose accuracy is inherited from `formula`.
const fn inherited(op: &'static str, formula: &'static str) -> Rule {
    Rule {
        op,
        bound: Bound::Inherited(formula),
        domain: "",
        policy: "",
    }
}

pub const TABLE: &[Rule] = &[
    exact("x + y"),
    exact("x - y"),
    exact("x * y"),
    Rule {
        op: "x / y",
        bound: Bound::Ulp(2.5),
        domain: "|y| in [2^-126, 2^126]",
        policy: "outside the range the result is unbounded: flagged, never bounded",
    },
    inherited("x % y", "x - y * trunc(x / y)"),
    Rule { op: "-x", bound: Bound::CorrectlyRounded, domain: "", policy: "exact" },
    Rule { op: "comparisons", bound: Bound::CorrectlyRounded, domain: "", policy: "correct result" },
    Rule {
        op: "literal",
        bound: Bound::CorrectlyRounded,
        domain: "",
        policy: "a literal (and a folded constant) is its written value rounded either way",
    },
    exact("f32(int)"),
    exact("abs"),
    Rule {
        op: "acos",
        bound: Bound::AbsoluteOrInherited(6.77e-5, "atan2(sqrt(1.0 - x * x), x)"),
        domain: "",
        policy: "where the inherited form leaves atan2's domain (x near 0) the absolute bound alone (beyond the spec)",
    },
    Rule {
        op: "asin",
        bound: Bound::AbsoluteOrInherited(6.81e-5, "atan2(x, sqrt(1.0 - x * x))"),
        domain: "",
        policy: "where the inherited form leaves atan2's domain (x near ±1) the absolute bound alone (beyond the spec)",
    },
    Rule { op: "atan", bound: Bound::Ulp(4096.0), domain: "", policy: "" },
    Rule {
        op: "atan2",
        bound: Bound::Ulp(4096.0),
        domain: "|x| in [2^-126, 2^126], y finite and normal",
        policy: "a zero y is taken as in the domain (beyond the spec: the spec's \"normal\" excludes zero); an x outside the range is flagged",
    },
    exact("ceil"),
    Rule { op: "clamp", bound: Bound::CorrectlyRounded, domain: "", policy: "min(max(x, lo), hi)" },
    Rule {
        op: "cos",
        bound: Bound::Absolute(0.00048828125),
        domain: "x in [-π, π]",
        policy: "outside [-π, π] unbounded; the envelope keeps only [-1 - 2^-11, 1 + 2^-11] (beyond the spec)",
    },
    inherited("cross", "x[i] * y[j] - x[j] * y[i]"),
    Rule {
        op: "determinant",
        bound: Bound::Infinite,
        domain: "",
        policy: "beyond the spec: inherited from the cofactor expansion along the first column (the evaluator's order)",
    },
    inherited("distance", "length(x - y)"),
    Rule {
        op: "dot",
        bound: Bound::Inherited("sum of x[i] * y[i]"),
        domain: "",
        policy: "summed left to right (reassociation excluded)",
    },
    Rule { op: "exp", bound: Bound::UlpAffine(3.0, 2.0), domain: "", policy: "" },
    Rule { op: "exp2", bound: Bound::UlpAffine(3.0, 2.0), domain: "", policy: "" },
    exact("floor"),
    Rule {
        op: "fma",
        bound: Bound::Inherited("x * y + z"),
        domain: "",
        policy: "a fused result lies inside the two-rounding interval",
    },
    inherited("fract", "x - floor(x)"),
    Rule {
        op: "inverseSqrt",
        bound: Bound::Ulp(2.0),
        domain: "x > 0",
        policy: "x ≤ 0 gives an infinity or NaN: flagged",
    },
    inherited("length", "sqrt(dot(x, x))"),
    Rule {
        op: "log",
        bound: Bound::AbsoluteInsideUlpOutside { abs: 4.76837158203125e-7, lo: 0.5, hi: 2.0, ulp: 3.0 },
        domain: "x > 0",
        policy: "",
    },
    Rule {
        op: "log2",
        bound: Bound::AbsoluteInsideUlpOutside { abs: 4.76837158203125e-7, lo: 0.5, hi: 2.0, ulp: 3.0 },
        domain: "x > 0",
        policy: "",
    },
    exact("max"),
    exact("min"),
    inherited("mix", "x * (1.0 - z) + y * z"),
    inherited("normalize", "x / length(x)"),
    inherited("pow", "exp2(y * log2(x))"),
    exact("round"),
    exact("saturate"),
    exact("sign"),
    Rule {
        op: "sin",
        bound: Bound::Absolute(0.00048828125),
        domain: "x in [-π, π]",
        policy: "outside [-π, π] unbounded; the envelope keeps only [-1 - 2^-11, 1 + 2^-11] (beyond the spec)",
    },
    Rule {
        op: "sqrt",
        bound: Bound::Inherited("1.0 / inverseSqrt(x)"),
        domain: "",
        policy: "sqrt(0) is 0 (beyond the spec: the inherited form divides by inverseSqrt(0) = inf)",
    },
    exact("step"),
    inherited("tan", "sin(x) / cos(x)"),
    exact("transpose"),
    exact("trunc"),
];

/// The row for `op` (a table entry must exist for every operation the envelope uses).
pub fn rule(op: &str) -> &'static Rule {
    TABLE
        .iter()
        .find(|r| r.op == op)
        .unwrap_or_else(|| panic!("no accuracy rule for `{op}` in src/eval/envelope/accuracy.rs"))
}

/// `op`'s ULP allowance (a `Bound::Ulp` row).
pub fn ulps(op: &str) -> f64 {
    match rule(op).bound {
        Bound::Ulp(k) => k,
        other => panic!("`{op}` is not a ULP bound: {other:?}"),
    }
}

/// `op`'s absolute allowance (a `Bound::Absolute` or `AbsoluteOrInherited` row).
pub fn absolute(op: &str) -> f64 {
    match rule(op).bound {
        Bound::Absolute(e) | Bound::AbsoluteOrInherited(e, _) => e,
        other => panic!("`{op}` is not an absolute bound: {other:?}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_row_named_once_and_the_constants_are_the_powers_of_two() {
        for (i, r) in TABLE.iter().enumerate() {
            assert!(TABLE[..i].iter().all(|q| q.op != r.op), "{} twice", r.op);
        }
        assert_eq!(DOMAIN_MIN, 2f64.powi(-126));
        assert_eq!(DOMAIN_MAX, 2f64.powi(126));
        assert_eq!(absolute("sin"), 2f64.powi(-11));
        match rule("log").bound {
            Bound::AbsoluteInsideUlpOutside { abs, .. } => assert_eq!(abs, 2f64.powi(-21)),
            _ => panic!("log"),
        }
        assert_eq!(ulps("atan"), 4096.0);
    }
}
