//! The envelope mode (docs/envelope.md): the kernel's IR evaluated on f32 intervals, in its
//! written order, each operation widened by the WGSL spec's allowance for it
//! (src/eval/envelope/accuracy.rs) and rounded outward. One configuration at a time: where a
//! condition's interval straddles, both ways are taken on copies of the state (locals and
//! globals) and joined where they meet again (after an `if`, at a loop's exit, at `return`).
//!
//! An interval holding an infinity or a NaN stops the walk ("undefined on a driver that
//! assumes finite math"), as does an operation outside the range where the spec bounds it;
//! the stop names the source line.

use super::{Program, NO_LINE};
use crate::eval::envelope::accuracy::{self as acc, Bound};
use crate::eval::envelope::interval::{self as iv, Gap, Iv};
use naga::{
    BinaryOperator as B, Expression as E, Handle, MathFunction as M, ScalarKind, Statement as S, TypeInner,
    UnaryOperator as U,
};

type V = Vec<Iv>;

#[derive(Clone, Debug)]
struct Ptr {
    slot: usize,
    /// Every component offset the pointer may have (a dynamic index over a range).
    offs: Vec<usize>,
    len: usize,
}

#[derive(Clone, Debug)]
enum Slot {
    Val(V),
    Ptr(Ptr),
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

struct Frame {
    fun: Handle<naga::Function>,
    vals: Vec<Option<Slot>>,
    ret: Option<V>,
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

fn kind(inner: &TypeInner) -> Option<ScalarKind> {
    inner.scalar_kind()
}

/// A written value as f32: either neighbour (a point when representable).
fn either(x: f64) -> Iv {
    Iv::new(iv::down(x, 0.0), iv::up(x, 0.0))
}

pub(super) struct Walk<'p> {
    p: &'p Program,
    heap: Vec<V>,
    globals: Vec<Option<usize>>,
    line: u32,
    forked: u32,
    /// A line whose operations are held to correct rounding ("where the freedom goes").
    strict: u32,
    loose: Vec<bool>,
}

impl<'p> Walk<'p> {
    /// `texels`: the configuration's texture (one 0 untextured), read through `ll_texels`.
    pub(super) fn run(p: &'p Program, scene: V, texels: V, strict: Option<usize>) -> Outcome {
        let mut w = Walk {
            p,
            heap: Vec::new(),
            globals: vec![None; p.module.global_variables.len()],
            line: NO_LINE,
            forked: 0,
            strict: strict.map_or(NO_LINE, |s| s as u32),
            loose: vec![false; p.lines.len()],
        };
        let value = w.start(scene, texels);
        Outcome {
            value,
            loose: (0..w.loose.len()).filter(|&i| w.loose[i]).collect(),
        }
    }

    fn start(&mut self, scene: V, texels: V) -> R<Iv> {
        let p = self.p;
        let mut texels = Some(texels);
        for (h, g) in p.module.global_variables.iter() {
            if g.name.as_deref() == Some("ll_texels") {
                self.globals[h.index()] = Some(self.heap.len());
                self.heap.push(texels.take().unwrap_or_default());
                continue;
            }
            if g.name.as_deref() == Some("ll_ltc") {
                // The LTC tables (binding 4), f32 texels, points; unbound when no function reads them.
                if p.reads_ltc {
                    self.globals[h.index()] = Some(self.heap.len());
                    self.heap.push(
                        crate::input::ltc::device::ours()
                            .iter()
                            .map(|&x| Iv::point(f64::from(x)))
                            .collect(),
                    );
                }
                continue;
            }
            if g.space != naga::AddressSpace::Private {
                continue;
            }
            let v = match g.init {
                Some(init) => self.constant(&p.global_consts[init.index()], g.ty),
                None => self.zero(g.ty),
            };
            self.globals[h.index()] = Some(self.heap.len());
            let v = match g.name.as_deref() {
                Some("ll_scene") => scene.clone(),
                Some("Minv") => {
                    let (off, len) = p.scene_minv;
                    scene[off..off + len].to_vec()
                }
                _ => v,
            };
            self.heap.push(v);
        }
        let v = self.call(p.method, vec![Slot::Val(scene)])?;
        v.and_then(|v| v.first().copied())
            .ok_or_else(|| Stop::Unsupported("`method` returned nothing".into()))
    }

    fn zero(&self, ty: Handle<naga::Type>) -> V {
        vec![Iv::point(0.0); self.p.flat[ty.index()]]
    }

    /// A module constant: a float one is its written digits rounded either way.
    fn constant(&self, (v32, v64): &super::Const, ty: Handle<naga::Type>) -> V {
        let float = self.p.module.types[ty].inner.scalar_kind() == Some(ScalarKind::Float);
        match (float, v64) {
            (true, Ok(w)) => w.iter().map(|&x| either(x)).collect(),
            _ => v32.iter().map(|&x| Iv::point(x)).collect(),
        }
    }

    fn inner(&self, fun: Handle<naga::Function>, h: Handle<naga::Expression>) -> &'p TypeInner {
        self.p.info[fun][h].ty.inner_with(&self.p.module.types)
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

    fn add(&self, a: Iv, b: Iv) -> R<Iv> {
        self.fin(iv::add(a, b))
    }
    fn sub(&self, a: Iv, b: Iv) -> R<Iv> {
        self.fin(iv::sub(a, b))
    }
    fn mul(&self, a: Iv, b: Iv) -> R<Iv> {
        self.fin(iv::mul(a, b))
    }
    fn div(&mut self, a: Iv, b: Iv) -> R<Iv> {
        let k = self.ulps("x / y");
        let q = iv::div(a, b, k).map_err(|g| self.gap(g))?;
        self.fin(q)
    }
    /// `x * x` of one value: never negative (a product of two intervals would be).
    fn square(&self, x: Iv) -> R<Iv> {
        let (lo, hi) = (x.mig(), x.mag());
        self.fin(Iv::new(iv::down(lo * lo, 0.0), iv::up(hi * hi, 0.0)).flush())
    }
    /// `dot(x, x)`, left to right, each term a square.
    fn dot_self(&mut self, a: &[Iv]) -> R<Iv> {
        let mut acc = self.square(a[0])?;
        for &x in &a[1..] {
            let t = self.square(x)?;
            acc = self.add(acc, t)?;
        }
        Ok(acc)
    }
    fn dot(&mut self, a: &[Iv], b: &[Iv]) -> R<Iv> {
        let mut acc = self.mul(a[0], b[0])?;
        for k in 1..a.len() {
            let t = self.mul(a[k], b[k])?;
            acc = self.add(acc, t)?;
        }
        Ok(acc)
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
        let s = self.div(Iv::point(1.0), r)?;
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
            let xx = self.mul(x, x)?;
            let d = self.sub(Iv::point(1.0), xx)?;
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

    fn call(&mut self, fun: Handle<naga::Function>, args: Vec<Slot>) -> R<Option<V>> {
        let p = self.p;
        let f = &p.module.functions[fun];
        let heap_top = self.heap.len();
        let mut fr = Frame {
            fun,
            vals: vec![None; f.expressions.len()],
            ret: None,
        };
        let mut locals = Vec::with_capacity(f.local_variables.len());
        for (_, lv) in f.local_variables.iter() {
            locals.push(self.heap.len());
            let z = self.zero(lv.ty);
            self.heap.push(z);
        }
        let fp = &p.funs[fun.index()];
        let saved_line = self.line;
        for (h, e) in f.expressions.iter() {
            if fp.emitted[h.index()] || matches!(e, E::CallResult(_)) {
                continue;
            }
            let v = match e {
                E::FunctionArgument(i) => args[*i as usize].clone(),
                E::LocalVariable(lv) => Slot::Ptr(Ptr {
                    slot: locals[lv.index()],
                    offs: vec![0],
                    len: p.flat[f.local_variables[*lv].ty.index()],
                }),
                _ => {
                    self.line = fp.line[h.index()];
                    self.eval(&mut fr, h)?;
                    continue;
                }
            };
            fr.vals[h.index()] = Some(v);
        }
        for (lv, v) in f.local_variables.iter() {
            if let Some(init) = v.init {
                if fr.vals[init.index()].is_none() {
                    self.line = fp.line[init.index()];
                    self.eval(&mut fr, init)?;
                }
                let val = self.val(&fr, init)?.clone();
                self.heap[locals[lv.index()]] = val;
            }
        }
        let mut ctl = Vec::new();
        self.block(&mut fr, &f.body, &mut ctl)?;
        self.heap.truncate(heap_top);
        self.line = saved_line;
        Ok(fr.ret)
    }

    fn val<'f>(&self, fr: &'f Frame, h: Handle<naga::Expression>) -> R<&'f V> {
        match fr.vals[h.index()].as_ref() {
            Some(Slot::Val(v)) => Ok(v),
            _ => Err(self.unsupported("a value used before it is computed, or a pointer")),
        }
    }

    fn ptr<'f>(&self, fr: &'f Frame, h: Handle<naga::Expression>) -> R<&'f Ptr> {
        match fr.vals[h.index()].as_ref() {
            Some(Slot::Ptr(p)) => Ok(p),
            _ => Err(self.unsupported("not a pointer")),
        }
    }

    /// Runs `block` on the current state; false when no path leaves it normally (each
    /// `return`, `break` and `continue` has put its state where it goes).
    fn block(&mut self, fr: &mut Frame, block: &naga::Block, ctl: &mut Vec<Ctl>) -> R<bool> {
        for st in block.iter() {
            match st {
                S::Emit(range) => {
                    for h in range.clone() {
                        self.line = self.p.funs[fr.fun.index()].line[h.index()];
                        self.eval(fr, h)?;
                    }
                }
                S::Block(b) => {
                    if !self.block(fr, b, ctl)? {
                        return Ok(false);
                    }
                }
                S::If {
                    condition,
                    accept,
                    reject,
                } => {
                    let c = self.val(fr, *condition)?[0];
                    let live = if c.lo != 0.0 {
                        self.block(fr, accept, ctl)?
                    } else if c.hi == 0.0 {
                        self.block(fr, reject, ctl)?
                    } else {
                        // Straddles: both ways, joined where they meet.
                        let before = self.heap.clone();
                        self.forked += 1;
                        let yes = self.block(fr, accept, ctl);
                        let after_yes = std::mem::replace(&mut self.heap, before);
                        let no = self.block(fr, reject, ctl);
                        self.forked -= 1;
                        let (yes, no) = (yes?, no?);
                        match (yes, no) {
                            (true, true) => join_heaps(&mut self.heap, &after_yes),
                            (true, false) => self.heap = after_yes,
                            _ => {}
                        }
                        yes || no
                    };
                    if !live {
                        return Ok(false);
                    }
                }
                S::Switch { selector, cases } => {
                    let sel = self.val(fr, *selector)?[0];
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
                    ctl.push(Ctl {
                        is_loop: false,
                        brk: None,
                        cont: None,
                    });
                    let mut live = true;
                    if let Some(start) = start {
                        for case in &cases[start..] {
                            live = self.block(fr, &case.body, ctl)?;
                            if !live || !case.fall_through {
                                break;
                            }
                        }
                    }
                    let c = ctl.pop().expect("pushed above");
                    if let Some(cont) = c.cont {
                        match ctl.iter_mut().rev().find(|c| c.is_loop) {
                            Some(outer) => join_into(&mut outer.cont, &cont),
                            None => return Err(self.unsupported("`continue` outside a loop")),
                        }
                    }
                    match (live, c.brk) {
                        (true, Some(b)) => join_heaps(&mut self.heap, &b),
                        (false, Some(b)) => {
                            self.heap = b;
                            live = true;
                        }
                        _ => {}
                    }
                    if !live {
                        return Ok(false);
                    }
                }
                S::Loop {
                    body,
                    continuing,
                    break_if,
                } => {
                    ctl.push(Ctl {
                        is_loop: true,
                        brk: None,
                        cont: None,
                    });
                    let forked_at = self.forked;
                    let mut iterations = 0u64;
                    let result = (|| -> R<()> {
                        loop {
                            iterations += 1;
                            if iterations > LOOP_LIMIT {
                                return Err(Stop::TooWide(format!(
                                    "a loop kept running on some path after {LOOP_LIMIT} iterations"
                                )));
                            }
                            let mut live = self.block(fr, body, ctl)?;
                            let top = ctl.last_mut().expect("pushed above");
                            if let Some(c) = top.cont.take() {
                                if live {
                                    join_heaps(&mut self.heap, &c);
                                } else {
                                    self.heap = c;
                                    live = true;
                                }
                            }
                            if !live {
                                return Ok(());
                            }
                            if !self.block(fr, continuing, ctl)? {
                                return Ok(());
                            }
                            if let Some(b) = break_if {
                                let c = self.val(fr, *b)?[0];
                                let top = ctl.last_mut().expect("pushed above");
                                if c.lo != 0.0 {
                                    join_into(&mut top.brk, &self.heap);
                                    return Ok(());
                                }
                                if c.hi != 0.0 {
                                    join_into(&mut top.brk, &self.heap);
                                    if self.forked == forked_at {
                                        self.forked += 1;
                                    }
                                }
                            }
                        }
                    })();
                    self.forked = forked_at;
                    let c = ctl.pop().expect("pushed above");
                    result?;
                    match c.brk {
                        Some(b) => self.heap = b,
                        None => return Ok(false),
                    }
                }
                S::Break => {
                    let top = ctl
                        .last_mut()
                        .ok_or_else(|| Stop::Unsupported("`break` outside a loop".into()))?;
                    join_into(&mut top.brk, &self.heap);
                    return Ok(false);
                }
                S::Continue => {
                    let top = ctl
                        .iter_mut()
                        .rev()
                        .find(|c| c.is_loop)
                        .ok_or_else(|| Stop::Unsupported("`continue` outside a loop".into()))?;
                    join_into(&mut top.cont, &self.heap);
                    return Ok(false);
                }
                S::Return { value } => {
                    if let Some(v) = value {
                        let v = self.val(fr, *v)?.clone();
                        fr.ret = Some(match fr.ret.take() {
                            Some(r) => r.iter().zip(&v).map(|(a, b)| a.hull(*b)).collect(),
                            None => v,
                        });
                    }
                    return Ok(false);
                }
                S::Store { pointer, value } => {
                    let ptr = self.ptr(fr, *pointer)?.clone();
                    let v = self.val(fr, *value)?.clone();
                    let slot = &mut self.heap[ptr.slot];
                    let strong = ptr.offs.len() == 1;
                    for &o in &ptr.offs {
                        for c in 0..ptr.len {
                            slot[o + c] = if strong { v[c] } else { slot[o + c].hull(v[c]) };
                        }
                    }
                }
                S::Call {
                    function,
                    arguments,
                    result,
                } => {
                    let args = arguments
                        .iter()
                        .map(|a| {
                            fr.vals[a.index()]
                                .clone()
                                .ok_or_else(|| self.unsupported("argument not computed"))
                        })
                        .collect::<R<Vec<_>>>()?;
                    let r = self.call(*function, args)?;
                    if let (Some(h), Some(r)) = (result, r) {
                        fr.vals[h.index()] = Some(Slot::Val(r));
                    }
                }
                other => return Err(self.unsupported(&format!("unsupported statement {other:?}"))),
            }
        }
        Ok(true)
    }

    fn eval(&mut self, fr: &mut Frame, h: Handle<naga::Expression>) -> R<()> {
        let p = self.p;
        let fun = fr.fun;
        let f = &p.module.functions[fun];
        let e = &f.expressions[h];
        let ty = self.inner(fun, h);
        let float = kind(ty) == Some(ScalarKind::Float);
        let slot = match e {
            E::Literal(l) => Slot::Val(vec![match *l {
                naga::Literal::F32(x) => match &p.funs[fun.index()].lit64[h.index()] {
                    Ok(w) => either(*w),
                    Err(_) => Iv::point(x as f64),
                },
                naga::Literal::U32(x) => Iv::point(x as f64),
                naga::Literal::I32(x) => Iv::point(x as f64),
                naga::Literal::Bool(x) => Iv::point(x as u8 as f64),
                other => return Err(self.unsupported(&format!("unsupported literal {other:?}"))),
            }]),
            E::Constant(c) => {
                let k = &p.module.constants[*c];
                Slot::Val(self.constant(&p.global_consts[k.init.index()], k.ty))
            }
            E::Override(o) => Slot::Val(vec![Iv::point(p.overrides[o.index()])]),
            E::ZeroValue(t) => Slot::Val(self.zero(*t)),
            E::Compose { components, .. } => {
                let mut out = Vec::new();
                for c in components {
                    out.extend(self.val(fr, *c)?.iter().copied());
                }
                Slot::Val(out)
            }
            E::Splat { size, value } => Slot::Val(vec![self.val(fr, *value)?[0]; *size as usize]),
            E::Swizzle { size, vector, pattern } => {
                let v = self.val(fr, *vector)?;
                Slot::Val(pattern[..*size as usize].iter().map(|c| v[*c as usize]).collect())
            }
            E::AccessIndex { base, index } => {
                let bty = self.inner(fun, *base);
                match fr.vals[base.index()].as_ref() {
                    Some(Slot::Ptr(ptr)) => {
                        let (off, len) = p.child(&p.pointee(bty), *index as usize);
                        Slot::Ptr(Ptr {
                            slot: ptr.slot,
                            offs: ptr.offs.iter().map(|o| o + off).collect(),
                            len,
                        })
                    }
                    Some(Slot::Val(v)) => {
                        let (off, len) = p.child(bty, *index as usize);
                        Slot::Val(v[off..off + len].to_vec())
                    }
                    None => return Err(self.unsupported("base not computed")),
                }
            }
            E::Access { base, index } => {
                let bty = self.inner(fun, *base);
                let idx = self.val(fr, *index)?[0];
                let range = |count: usize| {
                    let k = |x: f64| (x.max(0.0) as usize).min(count - 1);
                    k(idx.lo)..=k(idx.hi)
                };
                match fr.vals[base.index()].as_ref() {
                    Some(Slot::Ptr(ptr)) => {
                        let (count, stride) = p.elements(&p.pointee(bty));
                        let count = if count == 0 {
                            (self.heap[ptr.slot].len() / stride.max(1)).max(1)
                        } else {
                            count
                        };
                        let offs = range(count)
                            .flat_map(|k| ptr.offs.iter().map(move |o| o + k * stride))
                            .collect();
                        Slot::Ptr(Ptr {
                            slot: ptr.slot,
                            offs,
                            len: stride,
                        })
                    }
                    Some(Slot::Val(v)) => {
                        let (count, stride) = p.elements(bty);
                        let mut out: Option<V> = None;
                        for k in range(count) {
                            let part = &v[k * stride..(k + 1) * stride];
                            out = Some(match out {
                                Some(o) => o.iter().zip(part).map(|(a, b)| a.hull(*b)).collect(),
                                None => part.to_vec(),
                            });
                        }
                        Slot::Val(out.unwrap_or_default())
                    }
                    None => return Err(self.unsupported("base not computed")),
                }
            }
            E::GlobalVariable(g) => {
                let slot = self.globals[g.index()]
                    .ok_or_else(|| self.unsupported("only private globals can be read on the CPU"))?;
                Slot::Ptr(Ptr {
                    slot,
                    offs: vec![0],
                    len: p.flat[p.module.global_variables[*g].ty.index()],
                })
            }
            E::Load { pointer } => {
                let ptr = self.ptr(fr, *pointer)?;
                let src = &self.heap[ptr.slot];
                let mut out: V = src[ptr.offs[0]..ptr.offs[0] + ptr.len].to_vec();
                for &o in &ptr.offs[1..] {
                    for c in 0..ptr.len {
                        out[c] = out[c].hull(src[o + c]);
                    }
                }
                Slot::Val(out)
            }
            E::Unary { op, expr } => {
                let a = self.val(fr, *expr)?;
                let out = a
                    .iter()
                    .map(|x| match (op, float) {
                        (U::Negate, _) => Ok(x.negated()),
                        (U::LogicalNot, _) => Ok(Iv::new(1.0 - x.hi, 1.0 - x.lo)),
                        (U::BitwiseNot, _) if x.is_point() => Ok(Iv::point(match kind(ty) {
                            Some(ScalarKind::Sint) => !(x.lo as i32) as f64,
                            _ => !(x.lo as u32) as f64,
                        })),
                        _ => Err(Stop::TooWide("a bitwise operation on a range".into())),
                    })
                    .collect::<R<V>>()?;
                Slot::Val(out)
            }
            E::Binary { op, left, right } => {
                let lt = self.inner(fun, *left);
                let rt = self.inner(fun, *right);
                let (a, b) = (self.val(fr, *left)?.clone(), self.val(fr, *right)?.clone());
                if left == right && *op == B::Multiply && float && a.len() == b.len() {
                    // One value times itself: a square per component.
                    Slot::Val(a.iter().map(|&x| self.square(x)).collect::<R<V>>()?)
                } else {
                    Slot::Val(self.binary(*op, lt, rt, &a, &b)?)
                }
            }
            E::Select {
                condition,
                accept,
                reject,
            } => {
                let c = self.val(fr, *condition)?;
                let a = self.val(fr, *accept)?;
                let r = self.val(fr, *reject)?;
                Slot::Val(
                    (0..a.len())
                        .map(|k| {
                            let ck = c[k.min(c.len() - 1)];
                            if ck.lo != 0.0 {
                                a[k]
                            } else if ck.hi == 0.0 {
                                r[k]
                            } else {
                                a[k].hull(r[k])
                            }
                        })
                        .collect(),
                )
            }
            E::Relational { fun: rf, argument } => {
                let a = self.val(fr, *argument)?;
                let out = match rf {
                    naga::RelationalFunction::All => {
                        vec![iv::truth(a.iter().all(|x| x.lo != 0.0), a.iter().any(|x| x.hi == 0.0))]
                    }
                    naga::RelationalFunction::Any => {
                        vec![iv::truth(a.iter().any(|x| x.lo != 0.0), a.iter().all(|x| x.hi == 0.0))]
                    }
                    // Every interval reaching here is finite (a non-finite one stopped the walk).
                    naga::RelationalFunction::IsNan | naga::RelationalFunction::IsInf => {
                        vec![Iv::point(0.0); a.len()]
                    }
                };
                Slot::Val(out)
            }
            E::Math {
                fun: mf,
                arg,
                arg1,
                arg2,
                ..
            } => {
                let a = self.val(fr, *arg)?.clone();
                let b = arg1.map(|x| self.val(fr, x).cloned()).transpose()?;
                let c = arg2.map(|x| self.val(fr, x).cloned()).transpose()?;
                let at = self.inner(fun, *arg);
                if *mf == M::Dot && *arg1 == Some(*arg) {
                    Slot::Val(vec![self.dot_self(&a)?])
                } else {
                    Slot::Val(self.math(*mf, at, &a, b.as_ref(), c.as_ref())?)
                }
            }
            E::As {
                expr,
                kind: to,
                convert,
            } => {
                if convert.is_none() {
                    return Err(self.unsupported("bitcast is not supported"));
                }
                let from = kind(self.inner(fun, *expr));
                let a = self.val(fr, *expr)?;
                let trunc = |x: Iv, lo: f64, hi: f64| Iv::new(x.lo.trunc().clamp(lo, hi), x.hi.trunc().clamp(lo, hi));
                let out = a
                    .iter()
                    .map(|&x| match (to, from) {
                        (ScalarKind::Float, Some(ScalarKind::Float)) => x,
                        (ScalarKind::Float, _) => iv::round_out(x.lo, x.hi),
                        (ScalarKind::Uint, Some(ScalarKind::Float)) => trunc(x, 0.0, u32::MAX as f64),
                        (ScalarKind::Sint, Some(ScalarKind::Float)) => trunc(x, i32::MIN as f64, i32::MAX as f64),
                        (ScalarKind::Uint, Some(ScalarKind::Sint)) if x.lo >= 0.0 => x,
                        (ScalarKind::Sint, Some(ScalarKind::Uint)) if x.hi <= i32::MAX as f64 => x,
                        (ScalarKind::Bool, _) => iv::truth(!x.contains(0.0), x.is_point() && x.lo == 0.0),
                        (ScalarKind::Uint | ScalarKind::Sint, _) if x.is_point() => {
                            Iv::point(if *to == ScalarKind::Uint {
                                x.lo as i64 as i32 as u32 as f64
                            } else {
                                x.lo as i64 as u32 as i32 as f64
                            })
                        }
                        _ => x,
                    })
                    .collect();
                Slot::Val(out)
            }
            E::CallResult(_) => return Err(self.unsupported("call result read before the call")),
            other => return Err(self.unsupported(&format!("unsupported expression {other:?}"))),
        };
        fr.vals[h.index()] = Some(slot);
        Ok(())
    }

    fn binary(&mut self, op: B, lt: &TypeInner, rt: &TypeInner, a: &V, b: &V) -> R<V> {
        use TypeInner as T;
        let k = kind(lt);
        let float = k == Some(ScalarKind::Float);
        match (op, lt, rt) {
            (B::Multiply, T::Matrix { columns, rows, .. }, T::Vector { .. }) => {
                let r = *rows as usize;
                let mut out = Vec::new();
                for i in 0..r {
                    let mut acc = self.mul(a[i], b[0])?;
                    for j in 1..*columns as usize {
                        let t = self.mul(a[j * r + i], b[j])?;
                        acc = self.add(acc, t)?;
                    }
                    out.push(acc);
                }
                return Ok(out);
            }
            (B::Multiply, T::Vector { .. }, T::Matrix { columns, rows, .. }) => {
                let r = *rows as usize;
                return (0..*columns as usize)
                    .map(|j| self.dot(a, &b[j * r..(j + 1) * r]))
                    .collect();
            }
            (
                B::Multiply,
                T::Matrix {
                    columns: ac, rows: ar, ..
                },
                T::Matrix { columns: bc, .. },
            ) => {
                let (ar, ac) = (*ar as usize, *ac as usize);
                let mut out = Vec::new();
                for j in 0..*bc as usize {
                    for i in 0..ar {
                        let mut acc = self.mul(a[i], b[j * ac])?;
                        for kk in 1..ac {
                            let t = self.mul(a[kk * ar + i], b[j * ac + kk])?;
                            acc = self.add(acc, t)?;
                        }
                        out.push(acc);
                    }
                }
                return Ok(out);
            }
            _ => {}
        }
        let len = a.len().max(b.len());
        let pick = |v: &V, i: usize| v[if v.len() == 1 { 0 } else { i }];
        let mut out = Vec::with_capacity(len);
        for i in 0..len {
            let (x, y) = (pick(a, i), pick(b, i));
            let less = |x: Iv, y: Iv| iv::truth(x.hi < y.lo, x.lo >= y.hi);
            let less_eq = |x: Iv, y: Iv| iv::truth(x.hi <= y.lo, x.lo > y.hi);
            let equal = iv::truth(x.is_point() && y.is_point() && x.lo == y.lo, x.hi < y.lo || y.hi < x.lo);
            let not = |t: Iv| Iv::new(1.0 - t.hi, 1.0 - t.lo);
            let l = match op {
                B::Add if float => self.add(x, y)?,
                B::Subtract if float => self.sub(x, y)?,
                B::Multiply if float => self.mul(x, y)?,
                B::Divide if float => self.div(x, y)?,
                B::Modulo if float => {
                    // Inherited from x - y * trunc(x / y).
                    let q = self.div(x, y)?;
                    let t = Iv::new(q.lo.trunc(), q.hi.trunc());
                    let m = self.mul(y, t)?;
                    self.sub(x, m)?
                }
                B::Equal => equal,
                B::NotEqual => not(equal),
                B::Less => less(x, y),
                B::LessEqual => less_eq(x, y),
                B::Greater => less(y, x),
                B::GreaterEqual => less_eq(y, x),
                B::LogicalAnd => iv::truth(x.lo != 0.0 && y.lo != 0.0, x.hi == 0.0 || y.hi == 0.0),
                B::LogicalOr => iv::truth(x.lo != 0.0 || y.lo != 0.0, x.hi == 0.0 && y.hi == 0.0),
                _ if x.is_point() && y.is_point() => {
                    Iv::point(super::exec::int_op(op, x.lo, y.lo, k == Some(ScalarKind::Sint)))
                }
                B::Add => Iv::new(x.lo + y.lo, x.hi + y.hi),
                B::Subtract => Iv::new(x.lo - y.hi, x.hi - y.lo),
                _ => return Err(Stop::TooWide(format!("an integer {op:?} on a range"))),
            };
            out.push(l);
        }
        Ok(out)
    }

    fn math(&mut self, f: M, at: &TypeInner, a: &V, b: Option<&V>, c: Option<&V>) -> R<V> {
        let need = |v: Option<&V>| {
            v.cloned()
                .ok_or_else(|| Stop::Unsupported(format!("{f:?}: missing argument")))
        };
        let pick = |v: &V, i: usize| v[if v.len() == 1 { 0 } else { i }];
        let each = |s: &mut Self, g: &dyn Fn(&mut Self, Iv) -> R<Iv>| a.iter().map(|&x| g(s, x)).collect::<R<V>>();
        let mono = |x: Iv, g: fn(f64) -> f64| Iv::new(g(x.lo), g(x.hi));
        Ok(match f {
            M::Abs => each(self, &|_, x| {
                Ok(if x.contains(0.0) {
                    Iv::new(0.0, x.mag())
                } else {
                    Iv::new(x.mig(), x.mag())
                })
            })?,
            M::Sqrt => each(self, &|s, x| s.sqrt(x))?,
            M::InverseSqrt => each(self, &|s, x| s.rsqrt(x))?,
            M::Sin => each(self, &|s, x| s.trig(x, false))?,
            M::Cos => each(self, &|s, x| s.trig(x, true))?,
            M::Tan => each(self, &|s, x| {
                let (sn, cs) = (s.trig(x, false)?, s.trig(x, true)?);
                s.div(sn, cs)
            })?,
            M::Asin => each(self, &|s, x| s.arc(x, false))?,
            M::Acos => each(self, &|s, x| s.arc(x, true))?,
            M::Atan => each(self, &|s, x| {
                s.ulp_fn(libm::atan(x.lo), libm::atan(x.hi), acc::ulps("atan"))
            })?,
            M::Exp => each(self, &|s, x| s.exp(x, false))?,
            M::Exp2 => each(self, &|s, x| s.exp(x, true))?,
            M::Log => each(self, &|s, x| s.log(x, false))?,
            M::Log2 => each(self, &|s, x| s.log(x, true))?,
            M::Floor => each(self, &|_, x| Ok(mono(x, f64::floor)))?,
            M::Ceil => each(self, &|_, x| Ok(mono(x, f64::ceil)))?,
            M::Trunc => each(self, &|_, x| Ok(mono(x, f64::trunc)))?,
            M::Round => each(self, &|_, x| Ok(mono(x, f64::round_ties_even)))?,
            M::Fract => each(self, &|s, x| s.sub(x, mono(x, f64::floor)))?,
            M::Saturate => each(self, &|_, x| Ok(Iv::new(x.lo.clamp(0.0, 1.0), x.hi.clamp(0.0, 1.0))))?,
            M::Sign => each(self, &|_, x| Ok(Iv::new(sign(x.lo), sign(x.hi))))?,
            M::Min | M::Max | M::Atan2 | M::Pow | M::Step => {
                let b = need(b)?;
                (0..a.len())
                    .map(|i| {
                        let (x, y) = (pick(a, i), pick(&b, i));
                        match f {
                            M::Min => Ok(Iv::new(x.lo.min(y.lo), x.hi.min(y.hi))),
                            M::Max => Ok(Iv::new(x.lo.max(y.lo), x.hi.max(y.hi))),
                            M::Atan2 => self.atan2(x, y),
                            M::Pow => {
                                // Inherited from exp2(y * log2(x)).
                                let l = self.log(x, true)?;
                                let m = self.mul(y, l)?;
                                self.exp(m, true)
                            }
                            // step(edge, x): 1 where x >= edge.
                            _ => Ok(iv::truth(y.lo >= x.hi, y.hi < x.lo)),
                        }
                    })
                    .collect::<R<V>>()?
            }
            M::Clamp | M::Fma | M::Mix => {
                let (b, c) = (need(b)?, need(c)?);
                (0..a.len())
                    .map(|i| {
                        let (x, y, z) = (pick(a, i), pick(&b, i), pick(&c, i));
                        match f {
                            M::Clamp => Ok(Iv::new(x.lo.max(y.lo).min(z.lo), x.hi.max(y.hi).min(z.hi))),
                            M::Fma => {
                                let p = self.mul(x, y)?;
                                self.add(p, z)
                            }
                            _ => {
                                let u = self.sub(Iv::point(1.0), z)?;
                                let p = self.mul(x, u)?;
                                let q = self.mul(y, z)?;
                                self.add(p, q)
                            }
                        }
                    })
                    .collect::<R<V>>()?
            }
            M::Dot => {
                let b = need(b)?;
                vec![self.dot(a, &b)?]
            }
            M::Cross => {
                let b = need(b)?;
                let mut out = Vec::new();
                for (i, j) in [(1, 2), (2, 0), (0, 1)] {
                    let p = self.mul(a[i], b[j])?;
                    let q = self.mul(a[j], b[i])?;
                    out.push(self.sub(p, q)?);
                }
                out
            }
            M::Length => vec![self.length(a)?],
            M::Distance => {
                let b = need(b)?;
                let diff = (0..a.len()).map(|i| self.sub(a[i], b[i])).collect::<R<V>>()?;
                vec![self.length(&diff)?]
            }
            M::Normalize => {
                // Inherited from x / length(x).
                let l = self.length(a)?;
                a.iter().map(|&x| self.div(x, l)).collect::<R<V>>()?
            }
            M::Determinant => {
                // Beyond the spec ("infinite ULP"): inherited from the cofactor expansion along
                // the first column, the evaluator's order (accuracy.rs).
                let m = a;
                match m.len() {
                    4 => {
                        let p = self.mul(m[0], m[3])?;
                        let q = self.mul(m[2], m[1])?;
                        vec![self.sub(p, q)?]
                    }
                    9 => {
                        let e = |c: usize, r: usize| m[3 * c + r];
                        let minor = |s: &mut Self, c1: usize, c2: usize, r1: usize, r2: usize| -> R<Iv> {
                            let p = s.mul(e(c1, r1), e(c2, r2))?;
                            let q = s.mul(e(c2, r1), e(c1, r2))?;
                            s.sub(p, q)
                        };
                        let m0 = minor(self, 1, 2, 1, 2)?;
                        let m1 = minor(self, 1, 2, 0, 2)?;
                        let m2 = minor(self, 1, 2, 0, 1)?;
                        let t0 = self.mul(e(0, 0), m0)?;
                        let t1 = self.mul(e(0, 1), m1)?;
                        let t2 = self.mul(e(0, 2), m2)?;
                        let s = self.sub(t0, t1)?;
                        vec![self.add(s, t2)?]
                    }
                    n => return Err(self.unsupported(&format!("determinant of a {n}-component matrix"))),
                }
            }
            M::Transpose => {
                let TypeInner::Matrix { columns, rows, .. } = at else {
                    return Err(self.unsupported("transpose of a non-matrix"));
                };
                let (c, r) = (*columns as usize, *rows as usize);
                (0..r)
                    .flat_map(|i| (0..c).map(move |j| (i, j)))
                    .map(|(i, j)| a[j * r + i])
                    .collect()
            }
            other => return Err(self.unsupported(&format!("math function {other:?} is not supported"))),
        })
    }

    /// Inherited from `sqrt(dot(x, x))` (vector) or `sqrt(x * x)` (scalar).
    fn length(&mut self, a: &[Iv]) -> R<Iv> {
        let d = self.dot_self(a)?;
        self.sqrt(d)
    }
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
