//! The Rust functions compiled kernels call for what Cranelift has no instruction for: the
//! very functions the interpreter (`../exec.rs`) calls, so that every bit matches.
//!
//! - transcendentals: the `libm` crate's, f32 and f64;
//! - `%` (fmod) and `fma` (`mul_add`): Rust's, as the interpreter's closures are.
//!
//! `min`/`max` are not called: they are compares and selects with Rust's rules (`lower.rs`,
//! `min_max`), since a call in a loop makes every live float spill around it.

/// A shim: its address and its argument count (each argument and the result in the
/// mode's float type).
#[derive(Clone, Copy)]
pub(super) struct Shim {
    pub addr: usize,
    pub args: usize,
}

macro_rules! shims {
    ($($name:ident: $t:ty, $f:expr, ($($a:ident),+);)*) => {
        $(
            extern "C" fn $name($($a: $t),+) -> $t {
                $f($($a),+)
            }
        )*
    };
}

shims! {
    sin32: f32, libm::sinf, (x);
    cos32: f32, libm::cosf, (x);
    tan32: f32, libm::tanf, (x);
    asin32: f32, libm::asinf, (x);
    acos32: f32, libm::acosf, (x);
    atan32: f32, libm::atanf, (x);
    exp32: f32, libm::expf, (x);
    exp2_32: f32, libm::exp2f, (x);
    log32: f32, libm::logf, (x);
    log2_32: f32, libm::log2f, (x);
    atan2_32: f32, libm::atan2f, (y, x);
    pow32: f32, libm::powf, (x, y);
    rem32: f32, |x: f32, y: f32| x % y, (x, y);
    fma32: f32, f32::mul_add, (x, y, z);
    sin64: f64, libm::sin, (x);
    cos64: f64, libm::cos, (x);
    tan64: f64, libm::tan, (x);
    asin64: f64, libm::asin, (x);
    acos64: f64, libm::acos, (x);
    atan64: f64, libm::atan, (x);
    exp64: f64, libm::exp, (x);
    exp2_64: f64, libm::exp2, (x);
    log64: f64, libm::log, (x);
    log2_64: f64, libm::log2, (x);
    atan2_64: f64, libm::atan2, (y, x);
    pow64: f64, libm::pow, (x, y);
    rem64: f64, |x: f64, y: f64| x % y, (x, y);
    fma64: f64, f64::mul_add, (x, y, z);
}

/// The functions compiled code calls, by what they compute.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(super) enum F {
    Sin,
    Cos,
    Tan,
    Asin,
    Acos,
    Atan,
    Exp,
    Exp2,
    Log,
    Log2,
    Atan2,
    Pow,
    Rem,
    Fma,
}

/// The shim of `f` in f32 (`wide == false`) or f64.
pub(super) fn shim(f: F, wide: bool) -> Shim {
    macro_rules! pick {
        ($n:expr, $a:ident, $b:ident) => {
            if wide {
                Shim {
                    addr: $b as *const () as usize,
                    args: $n,
                }
            } else {
                Shim {
                    addr: $a as *const () as usize,
                    args: $n,
                }
            }
        };
    }
    match f {
        F::Sin => pick!(1, sin32, sin64),
        F::Cos => pick!(1, cos32, cos64),
        F::Tan => pick!(1, tan32, tan64),
        F::Asin => pick!(1, asin32, asin64),
        F::Acos => pick!(1, acos32, acos64),
        F::Atan => pick!(1, atan32, atan64),
        F::Exp => pick!(1, exp32, exp64),
        F::Exp2 => pick!(1, exp2_32, exp2_64),
        F::Log => pick!(1, log32, log64),
        F::Log2 => pick!(1, log2_32, log2_64),
        F::Atan2 => pick!(2, atan2_32, atan2_64),
        F::Pow => pick!(2, pow32, pow64),
        F::Rem => pick!(2, rem32, rem64),
        F::Fma => pick!(3, fma32, fma64),
    }
}
