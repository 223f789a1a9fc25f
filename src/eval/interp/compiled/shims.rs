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
    ($($f:ident: ($($a:ident),+) $f32:expr, $f64:expr;)*) => {
        /// The functions compiled code calls, by what they compute.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        pub(super) enum F {
            $($f),*
        }

        /// The shim of `f` in f32 (`wide == false`) or f64.
        pub(super) fn shim(f: F, wide: bool) -> Shim {
            match f {
                $(F::$f => {
                    extern "C" fn narrow($($a: f32),+) -> f32 {
                        $f32($($a),+)
                    }
                    extern "C" fn double($($a: f64),+) -> f64 {
                        $f64($($a),+)
                    }
                    let addr = if wide { double as *const () as usize } else { narrow as *const () as usize };
                    Shim { addr, args: [$(stringify!($a)),+].len() }
                })*
            }
        }
    };
}

shims! {
    Sin: (x) libm::sinf, libm::sin;
    Cos: (x) libm::cosf, libm::cos;
    Tan: (x) libm::tanf, libm::tan;
    Asin: (x) libm::asinf, libm::asin;
    Acos: (x) libm::acosf, libm::acos;
    Atan: (x) libm::atanf, libm::atan;
    Exp: (x) libm::expf, libm::exp;
    Exp2: (x) libm::exp2f, libm::exp2;
    Log: (x) libm::logf, libm::log;
    Log2: (x) libm::log2f, libm::log2;
    Atan2: (y, x) libm::atan2f, libm::atan2;
    Pow: (x, y) libm::powf, libm::pow;
    Rem: (x, y) |x: f32, y: f32| x % y, |x: f64, y: f64| x % y;
    Fma: (x, y, z) f32::mul_add, f64::mul_add;
}
