//! The envelope mode (docs/envelope.md): the kernel's IR evaluated on f32 intervals, in its
//! written order, each operation widened by the WGSL spec's allowance for it
//! (src/eval/envelope/accuracy.rs) and rounded outward. One configuration at a time: where a
//! condition's interval straddles, both ways are taken on copies of the state (locals and
//! globals) and joined where they meet again (after an `if`, at a loop's exit, at `return`).
//!
//! An interval holding an infinity or a NaN stops the walk ("undefined on a driver that
//! assumes finite math"), as does an operation outside the range where the spec bounds it;
//! the stop names the source line.

use crate::eval::envelope::accuracy::{self as acc, Bound};
use crate::eval::envelope::interval::{self as iv, Gap, Iv};
use crate::eval::program::{Const, Program, NO_LINE};
use crate::eval::walk::{Arms, Domain, Frame, Looping, Walker};
use naga::{BinaryOperator as B, Handle, MathFunction as M, RelationalFunction, ScalarKind, UnaryOperator as U};

type V = Vec<Iv>;

#[derive(Clone, Debug)]
pub(super) struct Ptr {
    slot: usize,
    /// Every component offset the pointer may have (a dynamic index over a range).
    offs: Vec<usize>,
    len: usize,
}

/// Why no interval is given.
#[derive(Clone, Debug, PartialEq)]
pub enum Stop {
    /// An intermediate may be infinite or NaN, or an operation left the range where the spec
    /// bounds it, at `line` (an index into [`Program::lines`]). `forked`: on a path taken only
    /// because a condition's interval straddled (the state there is wider than any real path's).
    Gap {
        gap: Gap,
        line: Option<usize>,
        forked: bool,
    },
    /// Too wide to inform: a loop that kept running on some path past the evaluator's limit,
    /// an integer operation on a range, a switch on a range.
    TooWide(String),
    /// An IR construct the envelope does not evaluate.
    Unsupported(String),
}

/// One configuration's envelope.
#[derive(Clone, Debug)]
pub struct Outcome {
    pub value: Result<Iv, Stop>,
    /// Lines (indices into [`Program::lines`]) whose operations used an allowance beyond
    /// correct rounding.
    pub loose: Vec<usize>,
}

/// Where `break` and `continue` take their states.
struct Ctl {
    is_loop: bool,
    brk: Option<Vec<V>>,
    cont: Option<Vec<V>>,
}

type R<T> = Result<T, Stop>;

/// The most iterations one loop statement may run (the evaluator's limit, exec.rs).
const LOOP_LIMIT: u64 = 1 << 24;

fn join_heaps(a: &mut [V], b: &[V]) {
    for (x, y) in a.iter_mut().zip(b) {
        for (p, q) in x.iter_mut().zip(y) {
            *p = p.hull(*q);
        }
    }
}

fn join_into(acc: &mut Option<Vec<V>>, heap: &[V]) {
    match acc {
        Some(a) => join_heaps(a, heap),
        None => *acc = Some(heap.to_vec()),
    }
}

/// A written value as f32: either neighbour (a point when representable).
fn either(x: f64) -> Iv {
    Iv::new(iv::down(x, 0.0), iv::up(x, 0.0))
}

/// The interval domain of the walker (`walk.rs`).
pub(super) struct Intervals<'p> {
    p: &'p Program,
    heap: Vec<V>,
    globals: Vec<Option<usize>>,
    line: u32,
    /// Whether some path still runs the statements that follow.
    live: bool,
    /// Where `break` and `continue` take their states, innermost last.
    ctl: Vec<Ctl>,
    forked: u32,
    /// A line whose operations are held to correct rounding ("where the freedom goes").
    strict: u32,
    loose: Vec<bool>,
}

impl<'p> Intervals<'p> {
    /// `texels`: the configuration's texture (one 0 untextured), read through `ll_texels`.
    pub(super) fn run(p: &'p Program, scene: V, texels: V, strict: Option<usize>) -> Outcome {
        let d = Intervals {
            p,
            heap: Vec::new(),
            globals: vec![None; p.module.global_variables.len()],
            line: NO_LINE,
            live: true,
            ctl: Vec::new(),
            forked: 0,
            strict: strict.map_or(NO_LINE, |s| s as u32),
            loose: vec![false; p.lines.len()],
        };
        let mut w = Walker::new(p, d);
        let ltc = |_: &mut Intervals| {
            // The LTC tables (binding 4), f32 texels, points.
            crate::input::ltc::device::ours()
                .iter()
                .map(|&x| Iv::point(f64::from(x)))
                .collect()
        };
        let value = w.run(scene, texels, ltc).and_then(|v| {
            v.and_then(|v| v.first().copied())
                .ok_or_else(|| Stop::Unsupported("`method` returned nothing".into()))
        });
        let d = w.d;
        Outcome {
            value,
            loose: (0..d.loose.len()).filter(|&i| d.loose[i]).collect(),
        }
    }

    fn zero_iv(&self, ty: Handle<naga::Type>) -> V {
        vec![Iv::point(0.0); self.p.flat[ty.index()]]
    }

    /// A module constant: a float one is its written digits rounded either way.
    fn constant_iv(&self, (v32, v64): &Const, ty: Handle<naga::Type>) -> V {
        let float = self.p.module.types[ty].inner.scalar_kind() == Some(ScalarKind::Float);
        match (float, v64) {
            (true, Ok(w)) => w.iter().map(|&x| either(x)).collect(),
            _ => v32.iter().map(|&x| Iv::point(x)).collect(),
        }
    }

    fn unsupported(&self, msg: &str) -> Stop {
        match self.p.lines.get(self.line as usize) {
            Some(l) => Stop::Unsupported(format!("{}:{}: envelope: {msg} (`{}`)", l.path, l.line, l.text.trim())),
            None => Stop::Unsupported(format!("envelope: {msg}")),
        }
    }

    fn gap(&self, gap: Gap) -> Stop {
        Stop::Gap {
            gap,
            line: (self.line != NO_LINE).then_some(self.line as usize),
            forked: self.forked > 0,
        }
    }

    /// A float result: stops on an infinity or NaN.
    fn fin(&self, v: Iv) -> R<Iv> {
        if v.non_finite() {
            Err(self.gap(Gap::NonFinite("an infinite or NaN intermediate")))
        } else {
            Ok(v)
        }
    }

    /// Whether the current operation gets its allowance (not on the strict line); notes the
    /// line as one that used an allowance.
    fn allowed(&mut self) -> bool {
        if self.line == self.strict {
            return false;
        }
        if let Some(l) = self.loose.get_mut(self.line as usize) {
            *l = true;
        }
        true
    }

    fn ulps(&mut self, op: &str) -> f64 {
        let k = acc::ulps(op);
        if self.allowed() {
            k
        } else {
            0.0
        }
    }

    fn plus(&self, a: Iv, b: Iv) -> R<Iv> {
        self.fin(iv::add(a, b))
    }
    fn minus(&self, a: Iv, b: Iv) -> R<Iv> {
        self.fin(iv::sub(a, b))
    }
    fn times(&self, a: Iv, b: Iv) -> R<Iv> {
        self.fin(iv::mul(a, b))
    }
    fn over(&mut self, a: Iv, b: Iv) -> R<Iv> {
        let k = self.ulps("x / y");
        let q = iv::div(a, b, k).map_err(|g| self.gap(g))?;
        self.fin(q)
    }
    /// `x * x` of one value: never negative (a product of two intervals would be).
    fn sq(&self, x: Iv) -> R<Iv> {
        let (lo, hi) = (x.mig(), x.mag());
        self.fin(Iv::new(iv::down(lo * lo, 0.0), iv::up(hi * hi, 0.0)).flush())
    }
    fn rsqrt(&mut self, x: Iv) -> R<Iv> {
        if x.lo <= 0.0 {
            return Err(self.gap(Gap::NonFinite("inverseSqrt of a value that may be ≤ 0")));
        }
        let (lo, hi) = (iv::f64_lower(1.0 / x.hi.sqrt()), iv::f64_upper(1.0 / x.lo.sqrt()));
        let k = self.ulps("inverseSqrt");
        self.fin(iv::widen_ulp(lo, hi, k))
    }
    /// `1.0 / inverseSqrt(x)`; sqrt(0) = 0 (the table's policy).
    fn sqrt(&mut self, x: Iv) -> R<Iv> {
        if x.lo < 0.0 {
            return Err(self.gap(Gap::NonFinite("sqrt of a value that may be < 0 (NaN)")));
        }
        if x.hi == 0.0 {
            return Ok(Iv::point(0.0));
        }
        let positive = Iv::new(if x.lo == 0.0 { x.hi } else { x.lo }, x.hi);
        let r = self.rsqrt(positive)?;
        let s = self.over(Iv::point(1.0), r)?;
        Ok(if x.lo == 0.0 { Iv::new(0.0, s.hi) } else { s })
    }
    /// A monotone function's exact range, widened by `bound`.
    fn ulp_fn(&mut self, lo: f64, hi: f64, k: f64) -> R<Iv> {
        let k = if self.allowed() { k } else { 0.0 };
        self.fin(iv::widen_ulp(iv::f64_lower(lo), iv::f64_upper(hi), k))
    }
    fn atan2(&mut self, y: Iv, x: Iv) -> R<Iv> {
        if x.mig() < acc::DOMAIN_MIN || x.mag() > acc::DOMAIN_MAX {
            return Err(self.gap(Gap::Domain("atan2 with |x| outside [2^-126, 2^126]")));
        }
        let pi = std::f64::consts::PI;
        let (lo, hi) = if x.hi < 0.0 && y.contains(0.0) {
            // The branch cut: every angle near ±π.
            (-pi, pi)
        } else {
            let c = [
                libm::atan2(y.lo, x.lo),
                libm::atan2(y.lo, x.hi),
                libm::atan2(y.hi, x.lo),
                libm::atan2(y.hi, x.hi),
            ];
            (
                c.iter().copied().fold(f64::INFINITY, f64::min),
                c.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            )
        };
        self.ulp_fn(lo, hi, acc::ulps("atan2"))
    }
    /// `acos`/`asin`: the hull of the absolute bound and the inherited atan2 form (the
    /// absolute bound alone where that form leaves atan2's domain).
    fn arc(&mut self, x: Iv, cos: bool) -> R<Iv> {
        if x.lo < -1.0 || x.hi > 1.0 {
            return Err(self.gap(Gap::NonFinite("acos/asin of a value that may be outside [-1, 1] (NaN)")));
        }
        let (lo, hi) = if cos {
            (libm::acos(x.hi), libm::acos(x.lo))
        } else {
            (libm::asin(x.lo), libm::asin(x.hi))
        };
        let (lo, hi) = (iv::f64_lower(lo), iv::f64_upper(hi));
        if !self.allowed() {
            return self.fin(iv::round_out(lo, hi));
        }
        let abs = iv::widen_abs(lo, hi, acc::absolute(if cos { "acos" } else { "asin" }));
        let inherited = (|| {
            let xx = self.times(x, x)?;
            let d = self.minus(Iv::point(1.0), xx)?;
            let s = self.sqrt(d)?;
            if cos {
                self.atan2(s, x)
            } else {
                self.atan2(x, s)
            }
        })();
        match inherited {
            Ok(i) => Ok(abs.hull(i)),
            Err(Stop::Gap {
                gap: Gap::Domain(_), ..
            }) => Ok(abs),
            Err(e) => Err(e),
        }
    }
    fn trig(&mut self, x: Iv, cos: bool) -> R<Iv> {
        let (lo, hi) = trig_range(x, cos);
        let eps = acc::absolute(if cos { "cos" } else { "sin" });
        if !self.allowed() {
            return self.fin(iv::round_out(iv::f64_lower(lo), iv::f64_upper(hi)));
        }
        if x.lo < -acc::TRIG_RANGE || x.hi > acc::TRIG_RANGE {
            return Ok(iv::widen_abs(-1.0, 1.0, eps));
        }
        self.fin(iv::widen_abs(iv::f64_lower(lo), iv::f64_upper(hi), eps))
    }
    fn exp(&mut self, x: Iv, base2: bool) -> R<Iv> {
        let f = if base2 { libm::exp2 } else { libm::exp };
        let Bound::UlpAffine(a, b) = acc::rule(if base2 { "exp2" } else { "exp" }).bound else {
            unreachable!("exp rows are affine ULP bounds")
        };
        self.ulp_fn(f(x.lo), f(x.hi), a + b * x.mag())
    }
    fn log(&mut self, x: Iv, base2: bool) -> R<Iv> {
        if x.lo <= 0.0 {
            return Err(self.gap(Gap::NonFinite("log of a value that may be ≤ 0")));
        }
        let f = if base2 { libm::log2 } else { libm::log };
        let Bound::AbsoluteInsideUlpOutside { abs, lo, hi, ulp } = acc::rule(if base2 { "log2" } else { "log" }).bound
        else {
            unreachable!("log rows are absolute inside, ULP outside")
        };
        let (a, b) = (iv::f64_lower(f(x.lo)), iv::f64_upper(f(x.hi)));
        if !self.allowed() {
            return self.fin(iv::round_out(a, b));
        }
        let inside = x.lo >= lo && x.hi <= hi;
        let outside = x.hi < lo || x.lo > hi;
        let mut r = iv::widen_ulp(a, b, ulp);
        if !outside {
            r = if inside {
                iv::widen_abs(a, b, abs)
            } else {
                r.hull(iv::widen_abs(a, b, abs))
            };
        }
        self.fin(r)
    }
}

/// What the caller of a function keeps across the call.
pub(super) struct Saved {
    heap: usize,
    line: u32,
    live: bool,
    ctl: Vec<Ctl>,
}

impl<'p> Domain for Intervals<'p> {
    type V = Iv;
    type P = Ptr;
    type Ret = Option<V>;
    type Err = Stop;
    type Saved = Saved;

    fn at(&mut self, line: u32, _emitted: bool) {
        self.line = line;
    }

    fn fail(&self, msg: String) -> Stop {
        self.unsupported(&msg)
    }

    fn fail_statement(&self, msg: String) -> Stop {
        self.unsupported(&msg)
    }

    fn live(&self) -> bool {
        self.live
    }

    fn literal(&mut self, lit: naga::Literal, written: &Result<f64, String>) -> R<Iv> {
        Ok(match lit {
            naga::Literal::F32(x) => match written {
                Ok(w) => either(*w),
                Err(_) => Iv::point(x as f64),
            },
            naga::Literal::U32(x) => Iv::point(x as f64),
            naga::Literal::I32(x) => Iv::point(x as f64),
            naga::Literal::Bool(x) => Iv::point(x as u8 as f64),
            other => return Err(self.unsupported(&format!("unsupported literal {other:?}"))),
        })
    }

    fn constant(&mut self, c: &Const, ty: Handle<naga::Type>) -> R<V> {
        Ok(self.constant_iv(c, ty))
    }

    fn override_value(&mut self, v: f64, _ty: &naga::TypeInner) -> R<Iv> {
        Ok(Iv::point(v))
    }

    fn zero(&mut self, ty: Handle<naga::Type>) -> R<V> {
        Ok(self.zero_iv(ty))
    }

    fn float(&mut self, x: f64) -> Iv {
        Iv::point(x)
    }

    fn add(&mut self, a: &Iv, b: &Iv) -> R<Iv> {
        self.plus(*a, *b)
    }
    fn sub(&mut self, a: &Iv, b: &Iv) -> R<Iv> {
        self.minus(*a, *b)
    }
    fn mul(&mut self, a: &Iv, b: &Iv) -> R<Iv> {
        self.times(*a, *b)
    }
    fn div(&mut self, a: &Iv, b: &Iv) -> R<Iv> {
        self.over(*a, *b)
    }
    /// Inherited from x - y * trunc(x / y).
    fn rem(&mut self, x: &Iv, y: &Iv) -> R<Iv> {
        let q = self.over(*x, *y)?;
        let t = Iv::new(q.lo.trunc(), q.hi.trunc());
        let m = self.times(*y, t)?;
        self.minus(*x, m)
    }

    fn int(&mut self, op: B, x: &Iv, y: &Iv, kind: Option<ScalarKind>) -> R<Iv> {
        let signed = kind == Some(ScalarKind::Sint);
        Ok(match op {
            _ if x.is_point() && y.is_point() => Iv::point(crate::eval::interp::exec::int_op(op, x.lo, y.lo, signed)),
            B::Add => Iv::new(x.lo + y.lo, x.hi + y.hi),
            B::Subtract => Iv::new(x.lo - y.hi, x.hi - y.lo),
            _ => return Err(Stop::TooWide(format!("an integer {op:?} on a range"))),
        })
    }

    fn compare(&mut self, op: B, x: &Iv, y: &Iv, _kind: Option<ScalarKind>) -> R<Iv> {
        let (x, y) = (*x, *y);
        let less = |x: Iv, y: Iv| iv::truth(x.hi < y.lo, x.lo >= y.hi);
        let less_eq = |x: Iv, y: Iv| iv::truth(x.hi <= y.lo, x.lo > y.hi);
        let equal = iv::truth(x.is_point() && y.is_point() && x.lo == y.lo, x.hi < y.lo || y.hi < x.lo);
        let not = |t: Iv| Iv::new(1.0 - t.hi, 1.0 - t.lo);
        Ok(match op {
            B::Equal => equal,
            B::NotEqual => not(equal),
            B::Less => less(x, y),
            B::LessEqual => less_eq(x, y),
            B::Greater => less(y, x),
            _ => less_eq(y, x),
        })
    }

    fn logical(&mut self, op: B, x: &Iv, y: &Iv) -> R<Iv> {
        Ok(match op {
            B::LogicalAnd => iv::truth(x.lo != 0.0 && y.lo != 0.0, x.hi == 0.0 || y.hi == 0.0),
            _ => iv::truth(x.lo != 0.0 || y.lo != 0.0, x.hi == 0.0 && y.hi == 0.0),
        })
    }

    fn unary(&mut self, op: U, x: &Iv, kind: Option<ScalarKind>) -> R<Iv> {
        match op {
            U::Negate => Ok(x.negated()),
            U::LogicalNot => Ok(Iv::new(1.0 - x.hi, 1.0 - x.lo)),
            U::BitwiseNot if x.is_point() => Ok(Iv::point(match kind {
                Some(ScalarKind::Sint) => !(x.lo as i32) as f64,
                _ => !(x.lo as u32) as f64,
            })),
            _ => Err(Stop::TooWide("a bitwise operation on a range".into())),
        }
    }

    fn select(&mut self, c: &Iv, a: &Iv, r: &Iv) -> R<Iv> {
        Ok(if c.lo != 0.0 {
            *a
        } else if c.hi == 0.0 {
            *r
        } else {
            a.hull(*r)
        })
    }

    fn relational(&mut self, f: RelationalFunction, a: &[Iv]) -> R<V> {
        Ok(match f {
            RelationalFunction::All => {
                vec![iv::truth(a.iter().all(|x| x.lo != 0.0), a.iter().any(|x| x.hi == 0.0))]
            }
            RelationalFunction::Any => {
                vec![iv::truth(a.iter().any(|x| x.lo != 0.0), a.iter().all(|x| x.hi == 0.0))]
            }
            // Every interval reaching here is finite (a non-finite one stopped the walk).
            RelationalFunction::IsNan | RelationalFunction::IsInf => vec![Iv::point(0.0); a.len()],
        })
    }

    fn convert(&mut self, to: ScalarKind, from: Option<ScalarKind>, x: &Iv) -> R<Iv> {
        let x = *x;
        let trunc = |x: Iv, lo: f64, hi: f64| Iv::new(x.lo.trunc().clamp(lo, hi), x.hi.trunc().clamp(lo, hi));
        Ok(match (to, from) {
            (ScalarKind::Float, Some(ScalarKind::Float)) => x,
            (ScalarKind::Float, _) => iv::round_out(x.lo, x.hi),
            (ScalarKind::Uint, Some(ScalarKind::Float)) => trunc(x, 0.0, u32::MAX as f64),
            (ScalarKind::Sint, Some(ScalarKind::Float)) => trunc(x, i32::MIN as f64, i32::MAX as f64),
            (ScalarKind::Uint, Some(ScalarKind::Sint)) if x.lo >= 0.0 => x,
            (ScalarKind::Sint, Some(ScalarKind::Uint)) if x.hi <= i32::MAX as f64 => x,
            (ScalarKind::Bool, _) => iv::truth(!x.contains(0.0), x.is_point() && x.lo == 0.0),
            (ScalarKind::Uint | ScalarKind::Sint, _) if x.is_point() => Iv::point(if to == ScalarKind::Uint {
                x.lo as i64 as i32 as u32 as f64
            } else {
                x.lo as i64 as u32 as i32 as f64
            }),
            _ => x,
        })
    }

    fn math1(&mut self, f: M, x: &Iv, _kind: Option<ScalarKind>) -> R<Iv> {
        let x = *x;
        let mono = |x: Iv, g: fn(f64) -> f64| Iv::new(g(x.lo), g(x.hi));
        match f {
            M::Abs => Ok(if x.contains(0.0) {
                Iv::new(0.0, x.mag())
            } else {
                Iv::new(x.mig(), x.mag())
            }),
            M::Sqrt => self.sqrt(x),
            M::InverseSqrt => self.rsqrt(x),
            M::Sin => self.trig(x, false),
            M::Cos => self.trig(x, true),
            M::Tan => {
                let (sn, cs) = (self.trig(x, false)?, self.trig(x, true)?);
                self.over(sn, cs)
            }
            M::Asin => self.arc(x, false),
            M::Acos => self.arc(x, true),
            M::Atan => self.ulp_fn(libm::atan(x.lo), libm::atan(x.hi), acc::ulps("atan")),
            M::Exp => self.exp(x, false),
            M::Exp2 => self.exp(x, true),
            M::Log => self.log(x, false),
            M::Log2 => self.log(x, true),
            M::Floor => Ok(mono(x, f64::floor)),
            M::Ceil => Ok(mono(x, f64::ceil)),
            M::Trunc => Ok(mono(x, f64::trunc)),
            M::Round => Ok(mono(x, f64::round_ties_even)),
            M::Fract => self.minus(x, mono(x, f64::floor)),
            M::Saturate => Ok(Iv::new(x.lo.clamp(0.0, 1.0), x.hi.clamp(0.0, 1.0))),
            _ => Ok(Iv::new(sign(x.lo), sign(x.hi))),
        }
    }

    fn math2(&mut self, f: M, x: &Iv, y: &Iv, _kind: Option<ScalarKind>) -> R<Iv> {
        let (x, y) = (*x, *y);
        match f {
            M::Min => Ok(Iv::new(x.lo.min(y.lo), x.hi.min(y.hi))),
            M::Max => Ok(Iv::new(x.lo.max(y.lo), x.hi.max(y.hi))),
            M::Atan2 => self.atan2(x, y),
            M::Pow => {
                // Inherited from exp2(y * log2(x)).
                let l = self.log(x, true)?;
                let m = self.times(y, l)?;
                self.exp(m, true)
            }
            // step(edge, x): 1 where x >= edge.
            _ => Ok(iv::truth(y.lo >= x.hi, y.hi < x.lo)),
        }
    }

    fn math3(&mut self, f: M, x: &Iv, y: &Iv, z: &Iv, _kind: Option<ScalarKind>) -> R<Iv> {
        let (x, y, z) = (*x, *y, *z);
        match f {
            M::Clamp => Ok(Iv::new(x.lo.max(y.lo).min(z.lo), x.hi.max(y.hi).min(z.hi))),
            _ => {
                let p = self.times(x, y)?;
                self.plus(p, z)
            }
        }
    }

    /// `dot(x, x)`, left to right, each term a square.
    fn dot_self(&mut self, a: &[Iv]) -> R<Iv> {
        let mut acc = self.sq(a[0])?;
        for &x in &a[1..] {
            let t = self.sq(x)?;
            acc = self.plus(acc, t)?;
        }
        Ok(acc)
    }

    /// Inherited from `sqrt(dot(x, x))` (vector) or `sqrt(x * x)` (scalar).
    fn length(&mut self, a: &[Iv]) -> R<Iv> {
        let d = self.dot_self(a)?;
        self.sqrt(d)
    }

    /// Inherited from x / length(x).
    fn normalize(&mut self, a: &[Iv]) -> R<V> {
        let l = self.length(a)?;
        a.iter().map(|&x| self.over(x, l)).collect()
    }

    fn squares(&self) -> bool {
        true
    }

    fn square(&mut self, x: &Iv) -> R<Iv> {
        self.sq(*x)
    }

    fn local(&mut self, ty: Handle<naga::Type>) -> R<Ptr> {
        let z = self.zero_iv(ty);
        self.heap.push(z);
        Ok(Ptr {
            slot: self.heap.len() - 1,
            offs: vec![0],
            len: self.p.flat[ty.index()],
        })
    }

    fn bind(&mut self, g: Handle<naga::GlobalVariable>, v: V) {
        self.globals[g.index()] = Some(self.heap.len());
        self.heap.push(v);
    }

    fn global(&mut self, g: Handle<naga::GlobalVariable>, len: usize) -> R<Ptr> {
        let slot =
            self.globals[g.index()].ok_or_else(|| self.unsupported("only private globals can be read on the CPU"))?;
        Ok(Ptr {
            slot,
            offs: vec![0],
            len,
        })
    }

    fn child(&mut self, ptr: &Ptr, off: usize, len: usize) -> Ptr {
        Ptr {
            slot: ptr.slot,
            offs: ptr.offs.iter().map(|o| o + off).collect(),
            len,
        }
    }

    fn held(&self, ptr: &Ptr) -> usize {
        self.heap[ptr.slot].len()
    }

    fn index(&mut self, ptr: &Ptr, idx: &Iv, count: usize, stride: usize, _signed: bool) -> R<Ptr> {
        let offs = range(idx, count)
            .flat_map(|k| ptr.offs.iter().map(move |o| o + k * stride))
            .collect();
        Ok(Ptr {
            slot: ptr.slot,
            offs,
            len: stride,
        })
    }

    fn index_value(&mut self, v: &[Iv], idx: &Iv, count: usize, stride: usize, _signed: bool) -> R<V> {
        let mut out: Option<V> = None;
        for k in range(idx, count) {
            let part = &v[k * stride..(k + 1) * stride];
            out = Some(match out {
                Some(o) => o.iter().zip(part).map(|(a, b)| a.hull(*b)).collect(),
                None => part.to_vec(),
            });
        }
        Ok(out.unwrap_or_default())
    }

    fn load(&mut self, ptr: &Ptr) -> R<V> {
        let src = &self.heap[ptr.slot];
        let mut out: V = src[ptr.offs[0]..ptr.offs[0] + ptr.len].to_vec();
        for &o in &ptr.offs[1..] {
            for c in 0..ptr.len {
                out[c] = out[c].hull(src[o + c]);
            }
        }
        Ok(out)
    }

    fn store(&mut self, ptr: &Ptr, v: &[Iv]) -> R<()> {
        let slot = &mut self.heap[ptr.slot];
        let strong = ptr.offs.len() == 1;
        for &o in &ptr.offs {
            for c in 0..ptr.len {
                slot[o + c] = if strong { v[c] } else { slot[o + c].hull(v[c]) };
            }
        }
        Ok(())
    }

    fn init(&mut self, ptr: &Ptr, v: V) {
        self.heap[ptr.slot] = v;
    }

    fn enter(&mut self, _result: Option<Handle<naga::Type>>) -> R<(Saved, Option<V>)> {
        let saved = Saved {
            heap: self.heap.len(),
            line: self.line,
            live: self.live,
            ctl: std::mem::take(&mut self.ctl),
        };
        Ok((saved, None))
    }

    fn leave(&mut self, saved: Saved, ret: Option<V>) -> Option<V> {
        self.heap.truncate(saved.heap);
        self.line = saved.line;
        self.live = saved.live;
        self.ctl = saved.ctl;
        ret
    }

    fn unwind(&mut self, saved: Saved) {
        self.live = saved.live;
        self.ctl = saved.ctl;
    }

    /// Where a condition's interval straddles, both ways on copies of the state, joined where
    /// they meet.
    fn if_(w: &mut Walker<'_, Self>, fr: &mut Frame<Self>, c: &Iv, arms: Arms) -> R<()> {
        let Arms { accept, reject } = arms;
        if c.lo != 0.0 {
            return w.block(fr, accept);
        }
        if c.hi == 0.0 {
            return w.block(fr, reject);
        }
        let before = w.d.heap.clone();
        w.d.forked += 1;
        let yes = w.block(fr, accept);
        let yes_live = std::mem::replace(&mut w.d.live, true);
        let after_yes = std::mem::replace(&mut w.d.heap, before);
        let no = w.block(fr, reject);
        let no_live = w.d.live;
        w.d.forked -= 1;
        yes?;
        no?;
        match (yes_live, no_live) {
            (true, true) => join_heaps(&mut w.d.heap, &after_yes),
            (true, false) => w.d.heap = after_yes,
            _ => {}
        }
        w.d.live = yes_live || no_live;
        Ok(())
    }

    fn switch(w: &mut Walker<'_, Self>, fr: &mut Frame<Self>, sel: &Iv, cases: &[naga::SwitchCase]) -> R<()> {
        let sel = *sel;
        if !sel.is_point() {
            return Err(Stop::TooWide("a switch on a range of values".into()));
        }
        let matches = |v: &naga::SwitchValue| match v {
            naga::SwitchValue::I32(i) => *i as f64 == sel.lo,
            naga::SwitchValue::U32(u) => *u as f64 == sel.lo,
            naga::SwitchValue::Default => false,
        };
        let start = cases
            .iter()
            .position(|c| matches(&c.value))
            .or_else(|| cases.iter().position(|c| c.value == naga::SwitchValue::Default));
        w.d.ctl.push(Ctl {
            is_loop: false,
            brk: None,
            cont: None,
        });
        let mut live = true;
        if let Some(start) = start {
            for case in &cases[start..] {
                w.block(fr, &case.body)?;
                live = w.d.live;
                if !live || !case.fall_through {
                    break;
                }
            }
        }
        let d = &mut w.d;
        let c = d.ctl.pop().expect("pushed above");
        if let Some(cont) = c.cont {
            match d.ctl.iter_mut().rev().find(|c| c.is_loop) {
                Some(outer) => join_into(&mut outer.cont, &cont),
                None => return Err(d.unsupported("`continue` outside a loop")),
            }
        }
        match (live, c.brk) {
            (true, Some(b)) => join_heaps(&mut d.heap, &b),
            (false, Some(b)) => {
                d.heap = b;
                live = true;
            }
            _ => {}
        }
        d.live = live;
        Ok(())
    }

    fn loop_(w: &mut Walker<'_, Self>, fr: &mut Frame<Self>, l: Looping) -> R<()> {
        let (body, continuing, break_if) = (l.body, l.continuing, l.break_if);
        w.d.ctl.push(Ctl {
            is_loop: true,
            brk: None,
            cont: None,
        });
        let forked_at = w.d.forked;
        let mut iterations = 0u64;
        let mut trips = || -> R<()> {
            loop {
                iterations += 1;
                if iterations > LOOP_LIMIT {
                    return Err(Stop::TooWide(format!(
                        "a loop kept running on some path after {LOOP_LIMIT} iterations"
                    )));
                }
                w.block(fr, body)?;
                let d = &mut w.d;
                let top = d.ctl.last_mut().expect("pushed above");
                if let Some(c) = top.cont.take() {
                    if d.live {
                        join_heaps(&mut d.heap, &c);
                    } else {
                        d.heap = c;
                        d.live = true;
                    }
                }
                if !d.live {
                    return Ok(());
                }
                w.block(fr, continuing)?;
                if !w.d.live {
                    return Ok(());
                }
                if let Some(b) = break_if {
                    let c = w.val(fr, b)?[0];
                    let d = &mut w.d;
                    let top = d.ctl.last_mut().expect("pushed above");
                    if c.lo != 0.0 {
                        join_into(&mut top.brk, &d.heap);
                        return Ok(());
                    }
                    if c.hi != 0.0 {
                        join_into(&mut top.brk, &d.heap);
                        if d.forked == forked_at {
                            d.forked += 1;
                        }
                    }
                }
            }
        };
        let result = trips();
        w.d.forked = forked_at;
        let c = w.d.ctl.pop().expect("pushed above");
        result?;
        match c.brk {
            Some(b) => {
                w.d.heap = b;
                w.d.live = true;
            }
            None => w.d.live = false,
        }
        Ok(())
    }

    fn break_(&mut self) -> R<()> {
        let top = self
            .ctl
            .last_mut()
            .ok_or_else(|| Stop::Unsupported("`break` outside a loop".into()))?;
        join_into(&mut top.brk, &self.heap);
        self.live = false;
        Ok(())
    }

    fn continue_(&mut self) -> R<()> {
        let top = self
            .ctl
            .iter_mut()
            .rev()
            .find(|c| c.is_loop)
            .ok_or_else(|| Stop::Unsupported("`continue` outside a loop".into()))?;
        join_into(&mut top.cont, &self.heap);
        self.live = false;
        Ok(())
    }

    fn return_(&mut self, ret: &mut Option<V>, v: Option<&[Iv]>) -> R<()> {
        if let Some(v) = v {
            *ret = Some(match ret.take() {
                Some(r) => r.iter().zip(v).map(|(a, b)| a.hull(*b)).collect(),
                None => v.to_vec(),
            });
        }
        self.live = false;
        Ok(())
    }
}

/// The elements an index interval may pick of `count`.
fn range(idx: &Iv, count: usize) -> std::ops::RangeInclusive<usize> {
    let k = |x: f64| (x.max(0.0) as usize).min(count - 1);
    k(idx.lo)..=k(idx.hi)
}

fn sign(x: f64) -> f64 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// The exact range of sin or cos over `x` (f64 ends, before any allowance).
fn trig_range(x: Iv, cos: bool) -> (f64, f64) {
    use std::f64::consts::{FRAC_PI_2, PI};
    if x.hi - x.lo >= 2.0 * PI {
        return (-1.0, 1.0);
    }
    let g = |t: f64| if cos { libm::cos(t) } else { libm::sin(t) };
    let (mut lo, mut hi) = (g(x.lo).min(g(x.hi)), g(x.lo).max(g(x.hi)));
    // Extremes inside: cos peaks at kπ (k even: 1, odd: -1); sin at π/2 + kπ.
    let shift = if cos { 0.0 } else { FRAC_PI_2 };
    let first = ((x.lo - shift) / PI).ceil() as i64;
    let last = ((x.hi - shift) / PI).floor() as i64;
    for k in first..=last {
        if k.rem_euclid(2) == 0 {
            hi = 1.0;
        } else {
            lo = -1.0;
        }
    }
    (lo, hi)
}
