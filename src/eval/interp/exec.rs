//! The lane engine: one naga IR operation at a time over a chunk of configurations
//! (structure of arrays, one `Vec<f64>` per scalar component), execution masks for
//! divergent control flow, as a GPU runs a workgroup.
//!
//! Every value is held as f64. Lanes `[0, split)` are f32 lanes: each float operation
//! there is done in `f32` (Rust's IEEE, correctly rounded `+ − × ÷ √ fma`; the `libm`
//! crate's f32 functions for transcendentals). Lanes `[split, n)` are f64 lanes (the
//! kernel promoted to double). With a shadow (attribution), lane `split + i` is the f64
//! shadow of f32 lane `i`: it follows lane i's control flow (every non-float value is
//! copied from the f32 half) and each float operation's local error is recorded there.

use crate::eval::program::{Const, Program, NO_LINE};
use crate::eval::walk::{Arms, Consts, Domain, Frame, Looping, Walker};
use crate::input::scene::Config;
use anyhow::{anyhow, bail, Result};
use naga::{BinaryOperator as B, Handle, MathFunction as M, RelationalFunction, ScalarKind, UnaryOperator as U};

/// One scalar component over the lanes, shared until written (copy on write).
pub(super) type Lanes = std::rc::Rc<Buf>;

/// The lanes of one component: a `Vec<f64>` that goes back to its thread's pool when it is
/// dropped, and comes from there when one is made, so that an operation does not cost a
/// large allocation and its release (every operation makes one, over all lanes).
#[derive(Debug)]
pub(super) struct Buf(Vec<f64>);

/// Buffers kept per thread, and the smallest kept (a one-lane component is not).
/// A float operation's three functions: `$name`, which runs the AVX2 build where the CPU
/// has it (`wide`) and the portable one elsewhere; `$avx2`, that build; `$lanes`, the
/// loop over the lanes that both inline (`$body`, with the receiver, the arguments, the
/// f64 and f32 functions and the rounding named by the caller).
macro_rules! float_op {
    ($(#[$doc:meta])* fn $name:ident / $avx2:ident / $lanes:ident ($s:ident, $($arg:ident),+; $f64f:ident, $f32f:ident, $round:ident) $body:block) => {
        float_op!(@fn [$($doc),*] $name ($s, $($arg),+; $f64f, $f32f, $round) {
            #[cfg(target_arch = "x86_64")]
            if $s.wide {
                // SAFETY: `wide` is set only where the CPU has AVX2 (`avx2`).
                return unsafe { $s.$avx2($($arg,)+ $f64f, $f32f, $round) };
            }
            $s.$lanes($($arg,)+ $f64f, $f32f, $round)
        });
        float_op!(@fn [cfg(target_arch = "x86_64"), target_feature(enable = "avx2")] $avx2 ($s, $($arg),+; $f64f, $f32f, $round) {
            $s.$lanes($($arg,)+ $f64f, $f32f, $round)
        });
        float_op!(@fn [inline(always)] $lanes ($s, $($arg),+; $f64f, $f32f, $round) $body);
    };
    (@fn [$($attr:meta),*] $name:ident ($s:ident, $($arg:ident),+; $f64f:ident, $f32f:ident, $round:ident) $body:block) => {
        $(#[$attr])*
        #[allow(clippy::too_many_arguments)]
        fn $name(
            &mut $s,
            $($arg: &[f64],)+
            $f64f: impl Fn($(float_op!(@f64 $arg)),+) -> f64,
            $f32f: impl Fn($(float_op!(@f32 $arg)),+) -> f32,
            $round: Round,
        ) -> Lanes $body
    };
    (@f64 $x:ident) => { f64 };
    (@f32 $x:ident) => { f32 };
}

const POOL_KEPT: usize = 512;
const POOL_MIN_LANES: usize = 16;

thread_local! {
    static POOL: std::cell::RefCell<Vec<Vec<f64>>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// An empty buffer with room for `n` lanes, from the pool where it has one.
fn buffer(n: usize) -> Vec<f64> {
    if n >= POOL_MIN_LANES {
        if let Some(mut v) = POOL.try_with(|p| p.borrow_mut().pop()).ok().flatten() {
            if v.capacity() >= n {
                v.clear();
                return v;
            }
        }
    }
    Vec::with_capacity(n)
}

impl Drop for Buf {
    fn drop(&mut self) {
        if self.0.capacity() >= POOL_MIN_LANES {
            let v = std::mem::take(&mut self.0);
            // A thread that is ending has no pool left: the buffer is freed.
            let _ = POOL.try_with(|p| {
                let mut p = p.borrow_mut();
                if p.len() < POOL_KEPT {
                    p.push(v);
                }
            });
        }
    }
}

impl Clone for Buf {
    fn clone(&self) -> Buf {
        let mut v = buffer(self.0.len());
        v.extend_from_slice(&self.0);
        Buf(v)
    }
}

impl std::ops::Deref for Buf {
    type Target = Vec<f64>;
    fn deref(&self) -> &Vec<f64> {
        &self.0
    }
}

impl std::ops::DerefMut for Buf {
    fn deref_mut(&mut self) -> &mut Vec<f64> {
        &mut self.0
    }
}

/// A shared component holding `v`.
pub(super) fn lanes(v: Vec<f64>) -> Lanes {
    std::rc::Rc::new(Buf(v))
}

/// Collects lanes into a shared component (its buffer from the pool).
trait CollectLanes: Iterator<Item = f64> + Sized {
    fn lanes(self) -> Lanes {
        let mut v = buffer(self.size_hint().0);
        v.extend(self);
        lanes(v)
    }
}
impl<I: Iterator<Item = f64>> CollectLanes for I {}

/// A value: its scalar components in declaration order (matrices column by column).
pub(super) type Val = Vec<Lanes>;

#[derive(Clone, Debug)]
enum Off {
    Uniform(usize),
    PerLane(Vec<usize>),
}

/// A pointer: into heap slot `slot`, at component offset `off`, `len` components.
#[derive(Clone, Debug)]
pub(super) struct Ptr {
    slot: usize,
    off: Off,
    len: usize,
}

/// Local error of one source line, for the f32 lane of each shadow (one entry per
/// configuration): the sum and max of its operations' bits, held as arrays so that one
/// operation's bits are added over all lanes in one vectorisable pass, and the count of its
/// operations: `every` (recorded on every lane) plus `count` (recorded on some lanes).
#[derive(Clone, Debug)]
pub(super) struct LineError {
    pub(super) sum: Vec<f64>,
    pub(super) max: Vec<f64>,
    count: Vec<u32>,
    every: u32,
}

impl LineError {
    fn new(k: usize) -> LineError {
        LineError {
            sum: vec![0.0; k],
            max: vec![0.0; k],
            count: vec![0; k],
            every: 0,
        }
    }

    /// Operations recorded on configuration `cfg`.
    pub(super) fn count(&self, cfg: usize) -> u32 {
        self.every + self.count[cfg]
    }
}

/// Local error per source line ([`LineError`]), None for a line with no recorded operation.
pub(super) type LineErrors = Vec<Option<LineError>>;

/// Which shadow lanes an operation's local error is recorded on (set per `Emit`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Shadow {
    /// No shadow lane is active (or there is no shadow): nothing is recorded.
    Off,
    /// Every shadow lane is active.
    All,
    /// Only the lanes in `Exec::mask`.
    Masked,
}

pub(super) struct Exec<'p> {
    p: &'p Program,
    n: usize,
    split: usize,
    shadow: bool,
    heap: Vec<Val>,
    globals: Vec<Option<usize>>,
    pub(super) errors: LineErrors,
    /// The line operations are recorded on (`NO_LINE`: none), and the line errors name.
    line: u32,
    loc: u32,
    /// The lanes that run the current statement.
    cur: Vec<bool>,
    /// Where `break` and `continue` go, innermost last.
    ctl: Vec<Ctl>,
    /// The lanes the operations of the current `Emit` are recorded on.
    mask: Vec<bool>,
    /// The shadow half of `mask`, summarised when it is set.
    shadow_on: Shadow,
    /// Scratch: one operation's ULP distances on the shadow lanes ([`ulp_distance`]), and
    /// their bits.
    ulps: Vec<u32>,
    bits: Vec<f64>,
    /// Straightforward recording, one lane at a time through [`ulp_bits`] (the reference the
    /// vectorised path is tested against, `tests.rs`).
    reference_record: bool,
    /// Whether the float operations' lane loops run in their AVX2 build ([`avx2`]).
    wide: bool,
    /// Per function, its constant expressions' values (filled on its first call).
    consts: Vec<Option<Consts<Exec<'p>>>>,
    zero_lanes: Lanes,
}

/// Where `break` and `continue` go.
struct Ctl {
    is_loop: bool,
    brk: Vec<bool>,
    cont: Vec<bool>,
}

fn any(m: &[bool]) -> bool {
    m.iter().any(|&b| b)
}

fn or_into(a: &mut [bool], b: &[bool]) {
    for (x, &y) in a.iter_mut().zip(b) {
        *x |= y;
    }
}

/// log2(1 + ulp distance) between two f32 values (docs/statistics.md bits); 32 when one is NaN.
pub fn ulp_bits(a: f32, b: f32) -> f64 {
    if a.is_nan() || b.is_nan() {
        return if a.is_nan() && b.is_nan() { 0.0 } else { 32.0 };
    }
    // Equal values (0 and −0 too) are 0 ULPs apart, log2(1) = 0: no branch on whether they
    // are equal, which the attribution's lanes take at random.
    let ord = |x: f32| {
        let i = x.to_bits() as i32;
        if i < 0 {
            -((i & 0x7fff_ffff) as i64)
        } else {
            i as i64
        }
    };
    let ulps = (ord(a) - ord(b)).unsigned_abs();
    match SMALL_ULP_BITS.get(ulps as usize) {
        Some(&bits) => bits,
        None => (ulps as f64 + 1.0).log2(),
    }
}

/// `log2(1 + k)` for the small ULP distances most operations lose, computed once by the same
/// expression as the general case (the same bits): the attribution calls `ulp_bits` for every
/// lane of every rounding operation, and `log2` was a tenth of its time.
static SMALL_ULP_BITS: std::sync::LazyLock<[f64; 256]> =
    std::sync::LazyLock::new(|| std::array::from_fn(|k| (k as f64 + 1.0).log2()));

/// [`ulp_distance`]'s code for "exactly one of the two is NaN" (32 bits); no two f32 values
/// that are not NaN are that far apart (−inf to +inf is 0xff00_0000).
const ONE_NAN: u32 = u32::MAX;

/// The ULP distance between two f32 values as [`ulp_bits`] counts it, with NaN coded (0 when
/// both are NaN, [`ONE_NAN`] when one is).
#[inline(always)]
pub(super) fn ulp_distance(a: f32, b: f32) -> u32 {
    match (a.is_nan(), b.is_nan()) {
        (false, false) => raw_distance(a, b),
        (true, true) => 0,
        _ => ONE_NAN,
    }
}

/// [`ulp_bits`] of a distance coded by [`ulp_distance`]; `small` is [`SMALL_ULP_BITS`].
#[inline(always)]
pub(super) fn bits_of(k: u32, small: &[f64; 256]) -> f64 {
    match small.get(k as usize) {
        Some(&bits) => bits,
        None => distant_bits(k),
    }
}

#[cold]
fn distant_bits(k: u32) -> f64 {
    if k == ONE_NAN {
        32.0
    } else {
        (k as f64 + 1.0).log2()
    }
}

/// An f32 value's bits as a signed integer that is monotonic in the value (−0 and 0 both 0),
/// as [`ulp_bits`] orders them, without a branch.
#[inline(always)]
fn ord(x: f32) -> i32 {
    let i = x.to_bits() as i32;
    let sign = i >> 31;
    (i ^ (sign & 0x7fff_ffff)).wrapping_sub(sign)
}

/// [`ulp_distance`] of two values that are not NaN (for NaN, some number): the distance of
/// two [`ord`]s, which fits in a u32 (−inf to +inf is 0xff00_0000), without a branch, so
/// that a loop over lanes vectorises.
#[inline(always)]
fn raw_distance(a: f32, b: f32) -> u32 {
    let (oa, ob) = (ord(a), ord(b));
    let d = oa.wrapping_sub(ob) as u32;
    if oa < ob {
        d.wrapping_neg()
    } else {
        d
    }
}

/// One operation's ULP distances on the shadow lanes, in `ulps` (one per lane), from each
/// lane's arguments (`args`), the operation in f32 on them (`local`) and the exact result
/// (`exact`); where `mask` is given, only on its lanes (0 elsewhere). Branch-free, one pass,
/// vectorisable, for the common case; a second pass codes NaN ([`ulp_distance`]) where a lane
/// met one. Returns the bitwise or of the distances (`u32::MAX` where NaN was met): an upper
/// bound of the largest, which chooses [`accumulate`]'s path.
#[inline(always)]
fn distances<T>(
    ulps: &mut Vec<u32>,
    args: impl Iterator<Item = T> + Clone,
    exact: &[f64],
    mask: Option<&[bool]>,
    cheap: bool,
    local: impl Fn(T) -> f32,
) -> u32 {
    if ulps.len() != exact.len() {
        ulps.clear();
        ulps.resize(exact.len(), 0);
    }
    let (mut nan, mut or) = (false, 0u32);
    match mask {
        None => {
            for (k, (t, &e)) in ulps.iter_mut().zip(args.clone().zip(exact)) {
                let (l, x) = (local(t), e as f32);
                *k = raw_distance(l, x);
                nan |= l.is_nan() | x.is_nan();
                or |= *k;
            }
        }
        // A cheap operation on every lane, then 0 selected on the inactive ones: no branch,
        // the loop vectorises (an inactive lane's arguments may be anything; a float
        // operation on them is harmless).
        Some(mask) if cheap => {
            for ((k, (t, &e)), &m) in ulps.iter_mut().zip(args.clone().zip(exact)).zip(mask) {
                let (l, x) = (local(t), e as f32);
                let d = if m { raw_distance(l, x) } else { 0 };
                *k = d;
                nan |= m & (l.is_nan() | x.is_nan());
                or |= d;
            }
        }
        // A library call only on the active lanes (0 on the others).
        Some(mask) => {
            for ((k, (t, &e)), &m) in ulps.iter_mut().zip(args.clone().zip(exact)).zip(mask) {
                let (d, n) = if m {
                    let (l, x) = (local(t), e as f32);
                    (raw_distance(l, x), l.is_nan() | x.is_nan())
                } else {
                    (0, false)
                };
                *k = d;
                nan |= n;
                or |= d;
            }
        }
    }
    if nan {
        for ((k, (t, &e)), i) in ulps.iter_mut().zip(args.zip(exact)).zip(0..) {
            if mask.is_none_or(|m| m[i]) {
                *k = ulp_distance(local(t), e as f32);
            }
        }
        return u32::MAX;
    }
    or
}

/// Adds one operation's bits (`ulps` coded by [`ulp_distance`], one per configuration) to a
/// line's sums, counts and maxima, on every lane or on the lanes in `mask`: the same
/// additions, in the same order per configuration, as one [`ulp_bits`] call per lane. `or`:
/// [`distances`]' bound of the largest distance. `bits`: scratch for the lanes' bits.
///
/// An inactive lane's distance is 0 ([`distances`]), so its bits are 0: adding them leaves its
/// sum as it was (a sum of non-negative bits from +0 is never −0, and s + 0 = s for every
/// other s) and its max too (never below +0): the masked case is the same branch-free passes,
/// with each lane's count raised by its mask.
#[inline(always)]
fn accumulate(e: &mut LineError, ulps: &[u32], mask: Option<&[bool]>, or: u32, bits: &mut Vec<f64>) {
    let small: &[f64; 256] = &SMALL_ULP_BITS;
    if or < 4 {
        // Every distance at most 3 (most operations): the bits by selection, no look-up, and
        // one pass that vectorises.
        let t = [small[0], small[1], small[2], small[3]];
        for ((sum, max), &k) in e.sum.iter_mut().zip(e.max.iter_mut()).zip(ulps) {
            let b = if k == 0 {
                t[0]
            } else if k == 1 {
                t[1]
            } else if k == 2 {
                t[2]
            } else {
                t[3]
            };
            *sum += b;
            // An unconditional store (a conditional one vectorises to a slow masked store).
            *max = max.max(b);
        }
    } else {
        // The bits looked up first (a table of 256), then added in a pass that vectorises.
        bits.clear();
        if or < 256 {
            bits.extend(ulps.iter().map(|&k| small[(k & 255) as usize]));
        } else {
            bits.extend(ulps.iter().map(|&k| bits_of(k, small)));
        }
        for ((sum, max), &b) in e.sum.iter_mut().zip(e.max.iter_mut()).zip(bits.iter()) {
            *sum += b;
            *max = max.max(b);
        }
    }
    match mask {
        None => e.every += 1,
        Some(mask) => {
            for (count, &on) in e.count.iter_mut().zip(mask) {
                *count += u32::from(on);
            }
        }
    }
}

/// Whether a float operation rounds, so that its local error is recorded, and what its f32
/// form on the shadow's arguments costs where only some lanes are active.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Round {
    /// Exact in f32 (abs, floor, min, a conversion…): nothing is recorded.
    Exact,
    /// Rounded and cheap (`+ − × ÷ √`, inverseSqrt, fract): computed on every lane and
    /// selected, without a branch.
    Cheap,
    /// Rounded, a library call (`sin`, `atan2`, `fma`, `%`…): computed on the active lanes only.
    Call,
}

/// Whether the CPU has AVX2: the float operations' lane loops then run in their AVX2 build
/// (twice the lanes per instruction; IEEE operations, so the same bits). Checked once.
fn avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        static AVX2: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
        *AVX2.get_or_init(|| std::arch::is_x86_feature_detected!("avx2"))
    }
    #[cfg(not(target_arch = "x86_64"))]
    false
}

/// Whether every lane of `mask` is on: a pass without an early exit, which vectorises (the
/// masks are all on far more often than not).
fn all(mask: &[bool]) -> bool {
    mask.iter().fold(true, |acc, &m| acc & m)
}

impl<'p> Exec<'p> {
    pub(super) fn new(p: &'p Program, n: usize, split: usize, shadow: bool) -> Exec<'p> {
        Exec {
            p,
            n,
            split,
            shadow,
            heap: Vec::new(),
            globals: vec![None; p.module.global_variables.len()],
            errors: vec![None; p.lines.len()],
            line: NO_LINE,
            loc: NO_LINE,
            cur: vec![true; n],
            ctl: Vec::new(),
            mask: vec![true; n],
            shadow_on: Shadow::Off,
            ulps: Vec::with_capacity(n - split.min(n)),
            bits: Vec::with_capacity(n - split.min(n)),
            reference_record: false,
            wide: avx2(),
            consts: vec![None; p.module.functions.len()],
            zero_lanes: lanes(vec![0.0; n]),
        }
    }

    /// Records each operation's local error one lane at a time through [`ulp_bits`] (the
    /// straightforward reference path, [`Exec::record_reference`]) instead of the vectorised
    /// [`distances`] and [`accumulate`].
    pub(super) fn reference_record(&mut self, on: bool) {
        self.reference_record = on;
    }

    /// Runs the float operations' lane loops in their AVX2 build (where the CPU has it) or
    /// in the baseline one: the same operations, the same bits (the tests run both).
    pub(super) fn wide(&mut self, on: bool) {
        self.wide = on && avx2();
    }

    /// A constant: `v32` on the f32 lanes, `v64` on the f64 lanes.
    fn fill(&self, v32: f64, v64: f64) -> Lanes {
        let s = self.split;
        (0..self.n).map(|i| if i < s { v32 } else { v64 }).lanes()
    }

    /// A module constant; its written digits are needed only when there are f64 lanes.
    fn constant_lanes(&self, (v32, v64): &Const) -> Result<Val, String> {
        if self.split == self.n {
            return Ok(v32.iter().map(|&a| self.fill(a, a)).collect());
        }
        let v64 = v64.as_ref().map_err(Clone::clone)?;
        Ok(v32.iter().zip(v64).map(|(&a, &b)| self.fill(a, b)).collect())
    }

    /// Non-float results: the shadow lanes take the f32 lanes' values, so that they
    /// branch, select and index as the f32 lanes do.
    fn follow(&self, l: &mut Lanes) {
        if self.shadow {
            let (a, b) = std::rc::Rc::make_mut(l).split_at_mut(self.split);
            b.copy_from_slice(a);
        }
    }

    /// Whether this operation's local error is recorded, and on which shadow lanes.
    fn recording(&self) -> Shadow {
        if !self.shadow || self.line == NO_LINE {
            Shadow::Off
        } else {
            self.shadow_on
        }
    }

    /// Sets the mask of the operations that follow (an `Emit`'s) to the current lanes, and
    /// what the attribution records them on.
    fn set_mask(&mut self) {
        if !self.shadow {
            return;
        }
        self.mask.clone_from_slice(&self.cur);
        let shadow = &self.mask[self.split..self.n];
        self.shadow_on = if all(shadow) {
            Shadow::All
        } else if any(shadow) {
            Shadow::Masked
        } else {
            Shadow::Off
        };
    }

    /// Records the local error of one operation on every active shadow lane, one lane at a
    /// time (the reference for [`distances`] and [`accumulate`]): `local(i)` is the operation
    /// in f32 on lane i's shadow arguments rounded to f32, `exact` the shadow's result.
    fn record_reference(&mut self, exact: &[f64], local: impl Fn(usize) -> f32) {
        let s = self.split;
        if self.line == NO_LINE || !any(&self.mask[s..self.n]) {
            return;
        }
        let e = self.errors[self.line as usize].get_or_insert_with(|| LineError::new(s));
        for (cfg, &on) in self.mask[s..self.n].iter().enumerate() {
            if !on {
                continue;
            }
            let i = s + cfg;
            let bits = ulp_bits(local(i), exact[i] as f32);
            e.sum[cfg] += bits;
            e.count[cfg] += 1;
            e.max[cfg] = e.max[cfg].max(bits);
        }
    }

    /// The local error of an operation on the shadow lanes, where it is recorded: `args`
    /// gives each shadow lane's arguments (in lane order), `local` the operation in f32 on
    /// them rounded to f32, `exact` the operation's result on all lanes (the shadow's the
    /// exact one). `reference(i)`: `local` on lane i, for [`Exec::record_reference`].
    #[inline(always)]
    fn local_error<T>(
        &mut self,
        args: impl Iterator<Item = T> + Clone,
        exact: &[f64],
        rounding: Round,
        local: impl Fn(T) -> f32,
        reference: impl Fn(usize) -> f32,
    ) {
        let on = self.recording();
        if on == Shadow::Off {
            return;
        }
        if self.reference_record {
            return self.record_reference(exact, reference);
        }
        let (s, n) = (self.split, self.n);
        let mask = (on == Shadow::Masked).then(|| &self.mask[s..n]);
        let or = distances(
            &mut self.ulps,
            args,
            &exact[s..n],
            mask,
            rounding == Round::Cheap,
            local,
        );
        let e = self.errors[self.line as usize].get_or_insert_with(|| LineError::new(s));
        accumulate(e, &self.ulps, mask, or, &mut self.bits);
    }

    /// The lanes of a float operation: the f32 lanes' arguments `low` through `f32f` (each
    /// argument rounded to f32 in it), the f64 lanes' `high` through `f64f`, and the local
    /// error of the f64 lanes recorded as `rounding` says ([`Exec::local_error`]).
    #[inline(always)]
    fn lanes_of<T>(
        &mut self,
        low: impl Iterator<Item = T>,
        high: impl Iterator<Item = T> + Clone,
        f64f: impl Fn(T) -> f64,
        f32f: impl Fn(T) -> f32,
        rounding: Round,
        reference: impl Fn(usize) -> f32,
    ) -> Lanes {
        let mut v = buffer(self.n);
        v.extend(low.map(|t| f32f(t) as f64));
        v.extend(high.clone().map(&f64f));
        if rounding != Round::Exact {
            self.local_error(high, &v, rounding, f32f, reference);
        }
        lanes(v)
    }

    float_op! {
        /// A float operation of one argument, component by component; `rounding`: whether its
        /// local error is recorded, and how ([`Round`]).
        fn f1 / f1_avx2 / f1_lanes (self, a; f64f, f32f, rounding) {
            let (s, n) = (self.split, self.n);
            let one = |lo: usize, hi: usize| a[lo..hi].iter().copied();
            let f32t = |x: f64| f32f(x as f32);
            self.lanes_of(one(0, s), one(s, n), f64f, f32t, rounding, |i| f32f(a[i] as f32))
        }
    }

    float_op! {
        /// A float operation of two arguments (as [`Exec::f1`]).
        fn f2 / f2_avx2 / f2_lanes (self, a, b; f64f, f32f, rounding) {
            let (s, n) = (self.split, self.n);
            let two = |lo: usize, hi: usize| a[lo..hi].iter().zip(&b[lo..hi]).map(|(&x, &y)| (x, y));
            let f64t = |(x, y): (f64, f64)| f64f(x, y);
            let f32t = |(x, y): (f64, f64)| f32f(x as f32, y as f32);
            self.lanes_of(two(0, s), two(s, n), f64t, f32t, rounding, |i| f32f(a[i] as f32, b[i] as f32))
        }
    }

    float_op! {
        /// A float operation of three arguments (as [`Exec::f1`]).
        fn f3 / f3_avx2 / f3_lanes (self, a, b, c; f64f, f32f, rounding) {
            let (s, n) = (self.split, self.n);
            let three = |lo: usize, hi: usize| {
                let ab = a[lo..hi].iter().zip(&b[lo..hi]);
                ab.zip(&c[lo..hi]).map(|((&x, &y), &z)| (x, y, z))
            };
            let f64t = |(x, y, z): (f64, f64, f64)| f64f(x, y, z);
            let f32t = |(x, y, z): (f64, f64, f64)| f32f(x as f32, y as f32, z as f32);
            let reference = |i: usize| f32f(a[i] as f32, b[i] as f32, c[i] as f32);
            self.lanes_of(three(0, s), three(s, n), f64t, f32t, rounding, reference)
        }
    }

    fn fadd(&mut self, a: &[f64], b: &[f64]) -> Lanes {
        self.f2(a, b, |x, y| x + y, |x, y| x + y, Round::Cheap)
    }
    fn fsub(&mut self, a: &[f64], b: &[f64]) -> Lanes {
        self.f2(a, b, |x, y| x - y, |x, y| x - y, Round::Cheap)
    }
    fn fmul(&mut self, a: &[f64], b: &[f64]) -> Lanes {
        self.f2(a, b, |x, y| x * y, |x, y| x * y, Round::Cheap)
    }
    fn fdiv(&mut self, a: &[f64], b: &[f64]) -> Lanes {
        self.f2(a, b, |x, y| x / y, |x, y| x / y, Round::Cheap)
    }
    fn rsqrt(&mut self, a: &[f64]) -> Lanes {
        // Correctly rounded in f32 (the f64 quotient of an f32 argument, rounded once).
        self.f1(
            a,
            |x| 1.0 / x.sqrt(),
            |x| (1.0 / (x as f64).sqrt()) as f32,
            Round::Cheap,
        )
    }
    /// Runs `method` on `scene` (one value per lane) and returns its result, and the
    /// engine (its recorded local errors). `texels`: each lane's texture ([`texel_lanes`]),
    /// read through `ll_texels`.
    pub(super) fn run(self, scene: Val, texels: Val) -> (Result<Vec<f64>>, Exec<'p>) {
        let mut w = Walker::new(self.p, self);
        let v = w.run(scene, texels, |_| ltc_tables());
        let v = v.and_then(|v| {
            let v = v.ok_or_else(|| anyhow!("`method` returned nothing"))?;
            Ok(v[0].to_vec())
        });
        (v, w.d)
    }

    /// An error at the current expression's line.
    fn located(&self, msg: &str) -> anyhow::Error {
        match self.p.lines.get(self.loc as usize) {
            Some(l) => anyhow!("{}:{}: CPU evaluator: {msg} (`{}`)", l.path, l.line, l.text.trim()),
            None => anyhow!("CPU evaluator: {msg}"),
        }
    }

    /// A float operation's lanes where every lane takes `f`'s value (exact in f32).
    fn map(a: &[f64], f: impl Fn(f64) -> f64) -> Lanes {
        a.iter().map(|&x| f(x)).lanes()
    }
}

/// [`Exec::run`]'s LTC tables, made once per thread (its components are `Rc`s): one one-lane
/// component per float. The harness's LTC tables as the kernel reads them through `ll_ltc`
/// (binding 4, `input::ltc::device`): the same f32 texels on every lane, f32 and f64 lanes
/// alike (the table is data a shader reads as f32), held once as one-lane components that a
/// load gives every lane.
fn ltc_tables() -> Val {
    thread_local! {
        static T: Val = crate::input::ltc::device::ours()
            .iter()
            .map(|&x| lanes(vec![f64::from(x)]))
            .collect();
    }
    T.with(Clone::clone)
}

/// The texels of each lane's texture: component k of lane i is texel k of lane i's
/// configuration (f32 lanes read them rounded), padded with 0 to the longest; each lane's
/// texels start at 0, so its scene's `tex_offset` is 0 (`SceneInput::new`).
pub(super) fn texel_lanes(configs: &[&Config], n: usize, split: usize, shadow_f32: bool) -> Val {
    let len = configs
        .iter()
        .filter_map(|c| c.texture.as_ref().map(|t| t.texels.len()))
        .max()
        .unwrap_or(0)
        .max(1);
    let mut comps = vec![vec![0.0; n]; len];
    let half = if shadow_f32 { split } else { n };
    for (i, c) in configs.iter().enumerate() {
        let Some(t) = &c.texture else { continue };
        for (k, &x) in t.texels.iter().enumerate() {
            for lane in [i, i + half] {
                if lane < n {
                    comps[k][lane] = if lane < split || shadow_f32 { x as f32 as f64 } else { x };
                }
            }
        }
    }
    comps.into_iter().map(lanes).collect()
}

/// Each lane's scene (f32 lanes, and an attribution's shadow, read it in f32).
pub(super) fn scene_lanes(p: &Program, configs: &[&Config], n: usize, split: usize, shadow_f32: bool) -> Val {
    let total: usize = p.scene.iter().map(|s| s.2).sum();
    let mut comps = vec![vec![0.0; n]; total];
    let half = if shadow_f32 { split } else { n };
    for (i, c) in configs.iter().enumerate() {
        let input = crate::input::scene::SceneInput::new(c);
        for (name, off, _) in &p.scene {
            let v = input.member(name).expect("checked in prepare");
            for (k, x) in v.into_iter().enumerate() {
                let r = x as f32 as f64;
                for lane in [i, i + half] {
                    if lane < n {
                        comps[off + k][lane] = if lane < split || shadow_f32 { r } else { x };
                    }
                }
            }
        }
    }
    comps.into_iter().map(lanes).collect()
}

/// What the caller of a function keeps across the call: its heap, its lanes, its `break`
/// and `continue` targets.
pub(super) struct Saved {
    heap: usize,
    cur: Vec<bool>,
    ctl: Vec<Ctl>,
}

impl<'p> Domain for Exec<'p> {
    type V = Lanes;
    type P = Ptr;
    type Ret = Option<Val>;
    type Err = anyhow::Error;
    type Saved = Saved;

    fn at(&mut self, line: u32, emitted: bool) {
        self.loc = line;
        self.line = if emitted { line } else { NO_LINE };
    }

    fn fail(&self, msg: String) -> anyhow::Error {
        self.located(&msg)
    }

    fn fail_statement(&self, msg: String) -> anyhow::Error {
        anyhow!("CPU evaluator: {msg}")
    }

    fn live(&self) -> bool {
        any(&self.cur)
    }

    fn emit(&mut self) {
        self.set_mask();
    }

    fn literal(&mut self, lit: naga::Literal, written: &Result<f64, String>) -> Result<Lanes> {
        Ok(match lit {
            naga::Literal::F32(x) => {
                let v64 = match self.split == self.n {
                    true => x as f64,
                    false => written.clone().map_err(|m| self.located(&m))?,
                };
                self.fill(x as f64, v64)
            }
            naga::Literal::U32(x) => self.fill(x as f64, x as f64),
            naga::Literal::I32(x) => self.fill(x as f64, x as f64),
            naga::Literal::Bool(x) => self.fill(x as u8 as f64, x as u8 as f64),
            other => return Err(self.located(&format!("unsupported literal {other:?}"))),
        })
    }

    fn constant(&mut self, c: &Const, _ty: Handle<naga::Type>) -> Result<Val> {
        self.constant_lanes(c).map_err(|m| self.located(&m))
    }

    fn override_value(&mut self, v: f64, _ty: &naga::TypeInner) -> Result<Lanes> {
        Ok(self.fill(v, v))
    }

    fn zero(&mut self, ty: Handle<naga::Type>) -> Result<Val> {
        Ok(vec![self.zero_lanes.clone(); self.p.flat[ty.index()]])
    }

    fn float(&mut self, x: f64) -> Lanes {
        self.fill(x, x)
    }

    /// Non-float results: the shadow lanes take the f32 lanes' values.
    fn settle(&mut self, v: &mut [Lanes], float: bool) {
        if !float && self.shadow {
            for l in v {
                self.follow(l);
            }
        }
    }

    fn add(&mut self, a: &Lanes, b: &Lanes) -> Result<Lanes> {
        Ok(self.fadd(a, b))
    }
    fn sub(&mut self, a: &Lanes, b: &Lanes) -> Result<Lanes> {
        Ok(self.fsub(a, b))
    }
    fn mul(&mut self, a: &Lanes, b: &Lanes) -> Result<Lanes> {
        Ok(self.fmul(a, b))
    }
    fn div(&mut self, a: &Lanes, b: &Lanes) -> Result<Lanes> {
        Ok(self.fdiv(a, b))
    }
    fn rem(&mut self, a: &Lanes, b: &Lanes) -> Result<Lanes> {
        Ok(self.f2(a, b, |p, q| p % q, |p, q| p % q, Round::Call))
    }

    fn int(&mut self, op: B, a: &Lanes, b: &Lanes, kind: Option<ScalarKind>) -> Result<Lanes> {
        let signed = kind == Some(ScalarKind::Sint);
        Ok(a.iter().zip(b.iter()).map(|(&p, &q)| int_op(op, p, q, signed)).lanes())
    }

    fn compare(&mut self, op: B, a: &Lanes, b: &Lanes, _kind: Option<ScalarKind>) -> Result<Lanes> {
        let cmp =
            |f: fn(f64, f64) -> bool| -> Lanes { a.iter().zip(b.iter()).map(|(&p, &q)| f(p, q) as u8 as f64).lanes() };
        Ok(match op {
            B::Equal => cmp(|p, q| p == q),
            B::NotEqual => cmp(|p, q| p != q),
            B::Less => cmp(|p, q| p < q),
            B::LessEqual => cmp(|p, q| p <= q),
            B::Greater => cmp(|p, q| p > q),
            _ => cmp(|p, q| p >= q),
        })
    }

    fn logical(&mut self, op: B, a: &Lanes, b: &Lanes) -> Result<Lanes> {
        let f: fn(f64, f64) -> bool = match op {
            B::LogicalAnd => |p, q| p != 0.0 && q != 0.0,
            _ => |p, q| p != 0.0 || q != 0.0,
        };
        Ok(a.iter().zip(b.iter()).map(|(&p, &q)| f(p, q) as u8 as f64).lanes())
    }

    fn unary(&mut self, op: U, l: &Lanes, kind: Option<ScalarKind>) -> Result<Lanes> {
        Ok(match (op, kind == Some(ScalarKind::Float)) {
            (U::Negate, true) => Self::map(l, |x| -x),
            (U::Negate, false) => Self::map(l, |x| -(x as i64 as i32 as f64)),
            (U::LogicalNot, _) => Self::map(l, |x| (x == 0.0) as u8 as f64),
            (U::BitwiseNot, _) => match kind {
                Some(ScalarKind::Sint) => Self::map(l, |x| !(x as i32) as f64),
                _ => Self::map(l, |x| !(x as u32) as f64),
            },
        })
    }

    fn select(&mut self, c: &Lanes, a: &Lanes, r: &Lanes) -> Result<Lanes> {
        Ok((0..self.n).map(|i| if c[i] != 0.0 { a[i] } else { r[i] }).lanes())
    }

    fn relational(&mut self, f: RelationalFunction, a: &[Lanes]) -> Result<Val> {
        Ok(match f {
            RelationalFunction::All => {
                vec![(0..self.n).map(|i| a.iter().all(|l| l[i] != 0.0) as u8 as f64).lanes()]
            }
            RelationalFunction::Any => {
                vec![(0..self.n).map(|i| a.iter().any(|l| l[i] != 0.0) as u8 as f64).lanes()]
            }
            RelationalFunction::IsNan => a.iter().map(|l| Self::map(l, |x| x.is_nan() as u8 as f64)).collect(),
            RelationalFunction::IsInf => a
                .iter()
                .map(|l| Self::map(l, |x| x.is_infinite() as u8 as f64))
                .collect(),
        })
    }

    fn convert(&mut self, to: ScalarKind, from: Option<ScalarKind>, l: &Lanes) -> Result<Lanes> {
        Ok(match (to, from) {
            (ScalarKind::Float, Some(ScalarKind::Float)) => l.clone(),
            (ScalarKind::Float, _) => self.f1(l, |x| x, |x| x, Round::Exact),
            (ScalarKind::Uint, Some(ScalarKind::Float)) => {
                Self::map(l, |x| nan0(x.trunc().clamp(0.0, u32::MAX as f64)))
            }
            (ScalarKind::Sint, Some(ScalarKind::Float)) => {
                Self::map(l, |x| nan0(x.trunc().clamp(i32::MIN as f64, i32::MAX as f64)))
            }
            (ScalarKind::Uint, Some(ScalarKind::Sint)) => Self::map(l, |x| x as i32 as u32 as f64),
            (ScalarKind::Sint, Some(ScalarKind::Uint)) => Self::map(l, |x| x as u32 as i32 as f64),
            (ScalarKind::Bool, _) => Self::map(l, |x| (x != 0.0) as u8 as f64),
            _ => l.clone(),
        })
    }

    fn math1(&mut self, f: M, l: &Lanes, _kind: Option<ScalarKind>) -> Result<Lanes> {
        let sign = |x: f64| {
            if x > 0.0 {
                1.0
            } else if x < 0.0 {
                -1.0
            } else {
                0.0
            }
        };
        let sign32 = |x: f32| sign(f64::from(x)) as f32;
        Ok(match f {
            M::Abs => self.f1(l, f64::abs, f32::abs, Round::Exact),
            M::Sqrt => self.f1(l, f64::sqrt, f32::sqrt, Round::Cheap),
            M::InverseSqrt => self.rsqrt(l),
            M::Sin => self.f1(l, libm::sin, libm::sinf, Round::Call),
            M::Cos => self.f1(l, libm::cos, libm::cosf, Round::Call),
            M::Tan => self.f1(l, libm::tan, libm::tanf, Round::Call),
            M::Asin => self.f1(l, libm::asin, libm::asinf, Round::Call),
            M::Acos => self.f1(l, libm::acos, libm::acosf, Round::Call),
            M::Atan => self.f1(l, libm::atan, libm::atanf, Round::Call),
            M::Exp => self.f1(l, libm::exp, libm::expf, Round::Call),
            M::Exp2 => self.f1(l, libm::exp2, libm::exp2f, Round::Call),
            M::Log => self.f1(l, libm::log, libm::logf, Round::Call),
            M::Log2 => self.f1(l, libm::log2, libm::log2f, Round::Call),
            M::Floor => self.f1(l, f64::floor, f32::floor, Round::Exact),
            M::Ceil => self.f1(l, f64::ceil, f32::ceil, Round::Exact),
            M::Trunc => self.f1(l, f64::trunc, f32::trunc, Round::Exact),
            M::Round => self.f1(l, f64::round_ties_even, f32::round_ties_even, Round::Exact),
            M::Fract => self.f1(l, |x| x - x.floor(), |x| x - x.floor(), Round::Cheap),
            M::Saturate => self.f1(l, |x| x.clamp(0.0, 1.0), |x| x.clamp(0.0, 1.0), Round::Exact),
            _ => self.f1(l, sign, sign32, Round::Exact),
        })
    }

    fn math2(&mut self, f: M, x: &Lanes, y: &Lanes, _kind: Option<ScalarKind>) -> Result<Lanes> {
        Ok(match f {
            // WGSL min/max of a NaN: either; IEEE minNum here.
            M::Min => self.f2(x, y, f64::min, f32::min, Round::Exact),
            M::Max => self.f2(x, y, f64::max, f32::max, Round::Exact),
            M::Atan2 => self.f2(x, y, libm::atan2, libm::atan2f, Round::Call),
            M::Pow => self.f2(x, y, libm::pow, libm::powf, Round::Call),
            _ => self.f2(
                x,
                y,
                |e, v| (v >= e) as u8 as f64,
                |e, v| (v >= e) as u8 as f32,
                Round::Exact,
            ),
        })
    }

    fn math3(&mut self, f: M, x: &Lanes, y: &Lanes, z: &Lanes, _kind: Option<ScalarKind>) -> Result<Lanes> {
        Ok(match f {
            M::Clamp => self.f3(
                x,
                y,
                z,
                |v, lo, hi| v.max(lo).min(hi),
                |v, lo, hi| v.max(lo).min(hi),
                Round::Exact,
            ),
            _ => self.f3(x, y, z, f64::mul_add, f32::mul_add, Round::Call),
        })
    }

    fn local(&mut self, ty: Handle<naga::Type>) -> Result<Ptr> {
        let z = self.zero(ty)?;
        self.heap.push(z);
        Ok(Ptr {
            slot: self.heap.len() - 1,
            off: Off::Uniform(0),
            len: self.p.flat[ty.index()],
        })
    }

    fn bind(&mut self, g: Handle<naga::GlobalVariable>, v: Val) {
        self.globals[g.index()] = Some(self.heap.len());
        self.heap.push(v);
    }

    fn global(&mut self, g: Handle<naga::GlobalVariable>, len: usize) -> Result<Ptr> {
        let slot =
            self.globals[g.index()].ok_or_else(|| self.located("only private globals can be read on the CPU"))?;
        Ok(Ptr {
            slot,
            off: Off::Uniform(0),
            len,
        })
    }

    fn child(&mut self, ptr: &Ptr, off: usize, len: usize) -> Ptr {
        let off = match &ptr.off {
            Off::Uniform(o) => Off::Uniform(o + off),
            Off::PerLane(o) => Off::PerLane(o.iter().map(|x| x + off).collect()),
        };
        Ptr {
            slot: ptr.slot,
            off,
            len,
        }
    }

    fn held(&self, ptr: &Ptr) -> usize {
        self.heap[ptr.slot].len()
    }

    fn index(&mut self, ptr: &Ptr, idx: &Lanes, count: usize, stride: usize, _signed: bool) -> Result<Ptr> {
        let off = (0..self.n)
            .map(|i| {
                let k = (idx[i].max(0.0) as usize).min(count - 1);
                k * stride
                    + match &ptr.off {
                        Off::Uniform(o) => *o,
                        Off::PerLane(o) => o[i],
                    }
            })
            .collect();
        Ok(Ptr {
            slot: ptr.slot,
            off: Off::PerLane(off),
            len: stride,
        })
    }

    fn index_value(&mut self, v: &[Lanes], idx: &Lanes, count: usize, stride: usize, _signed: bool) -> Result<Val> {
        Ok((0..stride)
            .map(|c| {
                (0..self.n)
                    .map(|i| v[(idx[i].max(0.0) as usize).min(count - 1) * stride + c][i])
                    .lanes()
            })
            .collect())
    }

    fn load(&mut self, ptr: &Ptr) -> Result<Val> {
        let src = &self.heap[ptr.slot];
        // A one-lane component (the shared LTC tables, `ll_ltc`) is every lane's value.
        let n = self.n;
        Ok(match &ptr.off {
            Off::Uniform(o) => src[*o..*o + ptr.len]
                .iter()
                .map(|l| {
                    if l.len() == n {
                        l.clone()
                    } else {
                        std::iter::repeat_n(l[0], n).lanes()
                    }
                })
                .collect(),
            Off::PerLane(o) => (0..ptr.len)
                .map(|c| {
                    (0..n)
                        .map(|i| {
                            let l = &src[o[i] + c];
                            l[if l.len() == n { i } else { 0 }]
                        })
                        .lanes()
                })
                .collect(),
        })
    }

    fn store(&mut self, ptr: &Ptr, v: &[Lanes]) -> Result<()> {
        let mask = &self.cur;
        let slot = &mut self.heap[ptr.slot];
        match &ptr.off {
            Off::Uniform(o) => {
                for c in 0..ptr.len {
                    assign(&mut slot[o + c], &v[c], mask);
                }
            }
            Off::PerLane(o) => {
                for c in 0..ptr.len {
                    for i in 0..self.n {
                        if mask[i] {
                            std::rc::Rc::make_mut(&mut slot[o[i] + c])[i] = v[c][i];
                        }
                    }
                }
            }
        }
        Ok(())
    }

    fn init(&mut self, ptr: &Ptr, v: Val) {
        self.heap[ptr.slot] = v;
    }

    fn enter(&mut self, result: Option<Handle<naga::Type>>) -> Result<(Saved, Option<Val>)> {
        let ret = result.map(|t| self.zero(t)).transpose()?;
        let saved = Saved {
            heap: self.heap.len(),
            cur: self.cur.clone(),
            ctl: std::mem::take(&mut self.ctl),
        };
        Ok((saved, ret))
    }

    fn leave(&mut self, saved: Saved, ret: Option<Val>) -> Option<Val> {
        self.heap.truncate(saved.heap);
        self.cur = saved.cur;
        self.ctl = saved.ctl;
        ret
    }

    fn cached(&mut self, fun: Handle<naga::Function>) -> Option<Consts<Self>> {
        self.consts[fun.index()].take()
    }

    fn keep(&mut self, fun: Handle<naga::Function>, consts: impl FnOnce() -> Consts<Self>) {
        self.consts[fun.index()] = Some(consts());
    }

    fn if_(w: &mut Walker<'_, Self>, fr: &mut Frame<Self>, c: &Lanes, arms: Arms) -> Result<()> {
        let Arms { accept, reject } = arms;
        let mask = std::mem::take(&mut w.d.cur);
        let mut yes: Vec<bool> = mask.iter().zip(c.iter()).map(|(&m, &c)| m && c != 0.0).collect();
        let mut no: Vec<bool> = mask.iter().zip(c.iter()).map(|(&m, &c)| m && c == 0.0).collect();
        if any(&yes) {
            w.d.cur = yes;
            w.block(fr, accept)?;
            yes = std::mem::take(&mut w.d.cur);
        }
        if any(&no) {
            w.d.cur = no;
            w.block(fr, reject)?;
            no = std::mem::take(&mut w.d.cur);
        }
        or_into(&mut yes, &no);
        w.d.cur = yes;
        Ok(())
    }

    fn switch(w: &mut Walker<'_, Self>, fr: &mut Frame<Self>, sel: &Lanes, cases: &[naga::SwitchCase]) -> Result<()> {
        let n = w.d.n;
        let value = |v: &naga::SwitchValue| match v {
            naga::SwitchValue::I32(i) => Some(*i as f64),
            naga::SwitchValue::U32(u) => Some(*u as f64),
            naga::SwitchValue::Default => None,
        };
        let listed: Vec<f64> = cases.iter().filter_map(|c| value(&c.value)).collect();
        w.d.ctl.push(Ctl {
            is_loop: false,
            brk: vec![false; n],
            cont: vec![false; n],
        });
        let mask = std::mem::take(&mut w.d.cur);
        let mut out = vec![false; n];
        let mut carry = vec![false; n];
        for case in cases {
            let mut m: Vec<bool> = (0..n)
                .map(|i| {
                    mask[i]
                        && match value(&case.value) {
                            Some(v) => sel[i] == v,
                            None => !listed.contains(&sel[i]),
                        }
                })
                .collect();
            or_into(&mut m, &carry);
            if any(&m) {
                w.d.cur = m;
                w.block(fr, &case.body)?;
                m = std::mem::take(&mut w.d.cur);
            }
            if case.fall_through {
                carry = m;
            } else {
                or_into(&mut out, &m);
                carry = vec![false; n];
            }
        }
        let c = w.d.ctl.pop().expect("pushed above");
        or_into(&mut out, &c.brk);
        if let Some(outer) = w.d.ctl.iter_mut().rev().find(|c| c.is_loop) {
            or_into(&mut outer.cont, &c.cont);
        }
        w.d.cur = out;
        Ok(())
    }

    fn loop_(w: &mut Walker<'_, Self>, fr: &mut Frame<Self>, l: Looping) -> Result<()> {
        let (body, continuing, break_if) = (l.body, l.continuing, l.break_if);
        let n = w.d.n;
        w.d.ctl.push(Ctl {
            is_loop: true,
            brk: vec![false; n],
            cont: vec![false; n],
        });
        let mut iterations = 0u64;
        while any(&w.d.cur) {
            iterations += 1;
            if iterations > 1 << 24 {
                bail!("CPU evaluator: a loop ran more than 2^24 iterations");
            }
            w.block(fr, body)?;
            let d = &mut w.d;
            let top = d.ctl.last_mut().expect("pushed above");
            or_into(&mut d.cur, &top.cont);
            top.cont.fill(false);
            w.block(fr, continuing)?;
            // naga's `break_if` is emitted in the continuing block, which runs only
            // while some lane is still in the loop: when every lane left the body
            // by `break` (or `return`), nothing is left to test (and on the first
            // pass the condition has no value yet).
            if let Some(b) = break_if.filter(|_| any(&w.d.cur)) {
                let c = w.val(fr, b)?[0].clone();
                let d = &mut w.d;
                let top = d.ctl.last_mut().expect("pushed above");
                for i in 0..n {
                    if d.cur[i] && c[i] != 0.0 {
                        d.cur[i] = false;
                        top.brk[i] = true;
                    }
                }
            }
        }
        w.d.cur = w.d.ctl.pop().expect("pushed above").brk;
        Ok(())
    }

    fn break_(&mut self) -> Result<()> {
        let top = self.ctl.last_mut().ok_or_else(|| anyhow!("`break` outside a loop"))?;
        or_into(&mut top.brk, &self.cur);
        self.cur.fill(false);
        Ok(())
    }

    fn continue_(&mut self) -> Result<()> {
        let top = self
            .ctl
            .iter_mut()
            .rev()
            .find(|c| c.is_loop)
            .ok_or_else(|| anyhow!("`continue` outside a loop"))?;
        or_into(&mut top.cont, &self.cur);
        self.cur.fill(false);
        Ok(())
    }

    fn return_(&mut self, ret: &mut Option<Val>, v: Option<&[Lanes]>) -> Result<()> {
        if let Some(v) = v {
            let ret = ret.as_mut().ok_or_else(|| anyhow!("return value in a void function"))?;
            for (r, x) in ret.iter_mut().zip(v) {
                assign(r, x, &self.cur);
            }
        }
        self.cur.fill(false);
        Ok(())
    }
}

/// `dst = src` on the lanes in `mask`; shares `src` when every lane is.
fn assign(dst: &mut Lanes, src: &Lanes, mask: &[bool]) {
    if all(mask) {
        *dst = src.clone();
        return;
    }
    let d = std::rc::Rc::make_mut(dst);
    for (i, &m) in mask.iter().enumerate() {
        if m {
            d[i] = src[i];
        }
    }
}

fn nan0(x: f64) -> f64 {
    if x.is_nan() {
        0.0
    } else {
        x
    }
}

/// WGSL integer arithmetic: wrapping, `x / 0 = x`, `x % 0 = 0`; also bool `&`, `|`, `^`.
pub(super) fn int_op(op: B, p: f64, q: f64, signed: bool) -> f64 {
    if signed {
        let (a, b) = (p as i64 as i32, q as i64 as i32);
        (match op {
            B::Add => a.wrapping_add(b),
            B::Subtract => a.wrapping_sub(b),
            B::Multiply => a.wrapping_mul(b),
            B::Divide => {
                if b == 0 {
                    a
                } else {
                    a.wrapping_div(b)
                }
            }
            B::Modulo => {
                if b == 0 {
                    0
                } else {
                    a.wrapping_rem(b)
                }
            }
            B::And => a & b,
            B::InclusiveOr => a | b,
            B::ExclusiveOr => a ^ b,
            B::ShiftLeft => a.wrapping_shl(b as u32),
            _ => a.wrapping_shr(b as u32),
        }) as f64
    } else {
        let (a, b) = (p as i64 as u32, q as i64 as u32);
        (match op {
            B::Add => a.wrapping_add(b),
            B::Subtract => a.wrapping_sub(b),
            B::Multiply => a.wrapping_mul(b),
            B::Divide => a.checked_div(b).unwrap_or(a),
            B::Modulo => a.checked_rem(b).unwrap_or(0),
            B::And => a & b,
            B::InclusiveOr => a | b,
            B::ExclusiveOr => a ^ b,
            B::ShiftLeft => a.wrapping_shl(b),
            _ => a.wrapping_shr(b),
        }) as f64
    }
}

#[cfg(test)]
mod tests {
    use crate::eval::interp::{program, Engine, Mode};
    use crate::input::scene::{Config, Material};
    use crate::kernel::methods::Method;
    use crate::kernel::KernelFile;

    /// A loop whose continuing block ends in `break if`, left by the body's `break` on the
    /// first pass when `scene.p1.x` ≤ 0.
    const BREAK_IF: &str = "\
//! id: test.break_if
//! target: line

fn method(scene: Scene) -> f32 {
    var i = 0;
    var acc = 0.0;
    loop {
        if (f32(i) >= scene.p1.x) { break; }
        acc += 0.5 + f32(i);
        continuing {
            let j = i + 1;
            i = j;
            break if j >= 4;
        }
    }
    return acc;
}
";

    /// The interpreter (the specification) on `break if`, by hand: x = 0 leaves on the first
    /// pass (0); x = 2.5 leaves by `break` at i = 3 (0.5 + 1.5 + 2.5 = 4.5); x = 10 leaves by
    /// `break if` after i = 3 (0.5 + 1.5 + 2.5 + 3.5 = 8), in f32 and f64, one lane at a time
    /// and all three in one call (lanes that leave differently).
    #[test]
    fn a_loop_with_break_if_gives_the_hand_computed_values() {
        let m = Method {
            label: "test.break_if".to_string(),
            kernel: KernelFile::parse("user/test.break_if.wgsl", BREAK_IF).unwrap(),
            params: Vec::new(),
            inner: None,
            judged: None,
        };
        let p = program(&m).unwrap();
        let at = |x: f64| Config {
            id: String::new(),
            p1: [x, 0.2, 1.0],
            p2: [0.5, -0.3, 1.2],
            radius: None,
            rect: None,
            material: Material::Diffuse,
            texture: None,
        };
        let cases = [(0.0, 0.0), (2.5, 4.5), (10.0, 8.0)];
        let configs: Vec<Config> = cases.iter().map(|&(x, _)| at(x)).collect();
        for mode in [Mode::F32, Mode::F64] {
            for (c, &(x, want)) in configs.iter().zip(&cases) {
                let got = p.eval_on(&[c], mode, Engine::Interpreter).unwrap();
                assert_eq!(got, vec![want], "{mode:?} at x = {x}");
            }
            let all: Vec<&Config> = configs.iter().collect();
            let got = p.eval_on(&all, mode, Engine::Interpreter).unwrap();
            assert_eq!(got, cases.iter().map(|c| c.1).collect::<Vec<_>>(), "{mode:?}");
        }
    }
}
