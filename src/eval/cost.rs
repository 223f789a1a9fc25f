//! A deterministic cost for each method: an operation count from the naga IR of its
//! composed kernel (prelude + method + the harness entry point `ll_main`), beside the
//! measured GPU timings, which depend on the machine. A cost model, not a measurement.
//!
//! The count is a value domain of the one walker (`walk.rs`): the walker gives the IR its
//! meaning and decomposes the composite built-ins into scalar operations; this domain's
//! values carry no number, its operations count, and its control flow follows the
//! costliest path (below) instead of lanes. What the walker does not decompose is charged
//! by the table of [`math_work`].
//!
//! # What is counted
//!
//! The operations **one invocation** of the entry point executes: its body and, at every
//! call site, the callee's count (nested calls inlined in turn; WGSL forbids recursion),
//! each loop body times its static trip count. Expressions are counted once, where they are emitted
//! (`Statement::Emit`), so a `let` used ten times costs once, and a `let` inside a loop
//! costs once per trip. Constants, arguments, loads, stores, swizzles, splats, compositions
//! and indexing are free (register moves or memory, which is not modelled).
//!
//! Vector and matrix operations count **per component** (closer to the cost on scalar
//! hardware, where a `vec3` add is three adds): `a + b` on `vec3` is 3.
//!
//! - `arithmetic`: binary operators (`+ - * / %`, comparisons, bit and logical operators,
//!   shifts), unary operators, `select`, `all`/`any`/`isNan`/`isInf`, value conversions
//!   (`f32(k)`; bitcasts are free). Matrix products count their multiply-adds:
//!   `mat3x3 * vec3` is 9 multiplies + 6 adds = 15. A division counts 1 like a multiply.
//!   The geometric built-ins are folded in by their component cost rather than counted
//!   as one call, since what `dot` costs depends on its size: `dot` of n components is
//!   2n−1, `cross` 9, `length` 2n−1 plus a `sqrt`, `distance` n more, `normalize` 2n−1 and
//!   n multiplies plus an `inverseSqrt`, `determinant` 3/14/63 for 2×2/3×3/4×4, `outer`
//!   one multiply per component, `reflect` 4n, `faceForward` 3n, `refract` 6n+4 plus a
//!   `sqrt`, `transpose` 0.
//! - `transcendental`: `sin cos tan asin acos atan atan2`, the hyperbolics, `exp exp2 log
//!   log2 pow sqrt inverseSqrt`, per component, including the `sqrt`/`inverseSqrt` inside
//!   `length`, `distance`, `normalize` and `refract`. [`OpCount::transcendental_fns`]
//!   breaks the count down by built-in: a native `inverseSqrt` and a library `atan` (a
//!   polynomial with range reduction) are not the same price, and the single weight below
//!   does not pretend to know the driver's.
//! - `other_math`: the remaining built-ins, one op per component: `abs min max clamp
//!   saturate sign step smoothstep mix fma floor ceil round trunc fract modf frexp ldexp
//!   radians degrees quantizeToF16`, the bit built-ins; packing and unpacking and the
//!   packed 8-bit dots are 1 per call.
//! - `branches`: `if` and `switch` statements executed (`select` is a conditional move,
//!   counted in `arithmetic`). naga lowers the short-circuiting `&&` and `||` to an `if`
//!   when their right side is not constant, so each counts as a branch; and a `for` loop's
//!   condition is an `if … else { break }` at the top of its body, so a loop of N trips
//!   adds N + 1 branches.
//! - `loops`: loop statements entered (a loop inside a 10-trip loop is entered 10 times);
//!   `loop_trips`: the total number of loop-body executions, `None` when any loop reached
//!   from the entry point has no static trip count.
//! - `calls`: function calls executed (the callee's work is inlined into the other fields).
//!
//! # Control flow
//!
//! - **Branches count the more expensive path** (by `total`), so the count is an upper
//!   bound of the work of one invocation on any path, not both arms of a divergent warp.
//!   Paths are followed through early `return`s: `if (d == 0.0) { return 0.0; } …` counts
//!   the path that goes on. One path is taken as a whole, so the fields of a count always
//!   belong to the same path. A `switch` counts its costliest case.
//! - **Loops**: a static trip count is recognised for the counter pattern WGSL's `for`
//!   lowers to: the first statement of the body (after the condition's emits) is an `if`
//!   one of whose arms is a lone `break` and the other empty, on a comparison (`<`, `<=`,
//!   `>`, `>=`, `!=`, `==`, possibly under `!`) of an integer local variable with a value
//!   known at compile time (literals, `const`s, `override`s and arithmetic on them); the
//!   continuing block adds or subtracts a known step to the counter (its only store
//!   there: `for (…; …; i += k)`, not `while (…) { …; i += k; }`), the body does not store
//!   it, and its start is known: the last store on the straight-line way to the loop, or
//!   its declaration, without crossing an enclosing loop. A count that would wrap the
//!   counter's type is not static. The body then counts N times, plus the condition that
//!   ends the loop; a `break` elsewhere in the body is ignored (upper bound). Any other loop (`while` on a runtime value, `break if`, a
//!   bound read from the scene) counts its body **once** and makes `loop_trips` `None`.
//! - `override` constants: [`method_cost`] resolves them with the method's parameters as
//!   the pipeline does (naga's `process_overrides`, which also folds what depends only on
//!   them, as the driver would: `Program::folded`).
//!
//! # The single number
//!
//! `total = arithmetic + other_math + 8 × transcendental + branches`. Calls are free
//! (drivers inline them), and loops add nothing beyond their trips' work, which is already
//! counted. The weight 8 sits between a native `sqrt`/`inverseSqrt`/`sin` (a quarter-rate
//! special-function instruction: ~4 simple ops of throughput) and a library `atan`/`acos`
//! (a dozen or more instructions); it is a convention for ranking, not a measurement.
//!
//! Every count includes the harness entry point's own work (the bounds check `ll_i >=
//! ll_count`: 1 arithmetic, 1 branch, and the call of `method`), the same for every method.

use crate::eval::program::Program;
use crate::eval::walk::{evaluates, Arms, Domain, Frame, Looping, Walker, R};
use crate::kernel::methods::Method;
use crate::kernel::KernelFile;
use naga::{
    BinaryOperator, Block, Expression, Function, Handle, Literal, MathFunction, RelationalFunction, ScalarKind,
    Statement, TypeInner, UnaryOperator,
};
use std::collections::{BTreeMap, HashMap};

/// The weight of one transcendental in [`OpCount::total`]; every other counted op weighs 1.
pub const TRANSCENDENTAL_WEIGHT: u64 = 8;

/// The operations one invocation of an entry point executes (see the module doc for what
/// each field counts and the weights of `total`).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct OpCount {
    /// Operators, comparisons, selects, conversions; geometric built-ins by component cost.
    pub arithmetic: u64,
    /// Trigonometric, exponential, logarithmic, `sqrt` and `inverseSqrt`, per component.
    pub transcendental: u64,
    /// The other built-ins (`min`, `max`, `abs`, `clamp`, `floor`, `fma`, …), per component.
    pub other_math: u64,
    /// `if` and `switch` statements executed (loop conditions included).
    pub branches: u64,
    /// Loop statements entered.
    pub loops: u64,
    /// Loop-body executions in all, when every loop's trip count is static.
    pub loop_trips: Option<u64>,
    /// Function calls executed.
    pub calls: u64,
    /// `arithmetic + other_math + 8 × transcendental + branches`.
    pub total: u64,
    /// `transcendental` by built-in, under its WGSL name (`atan`, `inverseSqrt`, …).
    pub transcendental_fns: BTreeMap<String, u64>,
}

/// The cost of `kernel` with its parameters set to `params` (in header order; those not
/// given keep the header's defaults): the kernel is composed as the GPU runs it (a
/// composite with the default line method), its overrides resolved, and `ll_main` counted.
pub fn method_cost(kernel: &KernelFile, params: &[f64]) -> anyhow::Result<OpCount> {
    count(&Program::folded(kernel, params, None)?)
}

/// The cost of a resolved method: its kernel with its params and, for a composite
/// (`//! uses: line`), its inner line method with the inner's params.
pub fn method_cost_of(method: &Method) -> anyhow::Result<OpCount> {
    let inner = method.inner.as_deref().map(|m| (&m.kernel, m.params.as_slice()));
    count(&Program::folded(&method.kernel, &method.params, inner)?)
}

/// What `ll_main` (compose.rs) does before it calls `method`: the bounds check `ll_i >=
/// ll_count` (1 arithmetic) and its `if` (1 branch), whose early `return` is the other way
/// out. The call itself is counted where the walker makes it.
fn entry_check() -> Work {
    Work {
        arithmetic: 1,
        branches: 1,
        ..Work::default()
    }
}

/// Counts one invocation of the entry point of `p`: `method` walked by [`Walker`] over the
/// counting domain, after the entry point's own check.
fn count(p: &Program) -> anyhow::Result<OpCount> {
    let mut trips = HashMap::new();
    for (h, f) in p.module.functions.iter() {
        loop_trips(&p.module, f, &f.body, false, &mut Vec::new(), &mut |body, n| {
            trips.insert((h.index(), body as *const Block), n);
        });
    }
    let cost = Cost {
        p,
        emitted: false,
        flow: Flow {
            normal: Some(entry_check()),
            ret: Some(entry_check()),
            ..Flow::default()
        },
        trips,
        dynamic_loop: false,
    };
    let scene = vec![(); p.scene.iter().map(|(_, _, len)| len).sum()];
    let mut walker = Walker::new(p, cost);
    walker.run(scene, Vec::new(), |_| Vec::new())?;
    let Cost { flow, dynamic_loop, .. } = walker.d;
    Ok(costlier(flow.normal, flow.ret)
        .unwrap_or_default()
        .into_count(dynamic_loop))
}

/// The work along one path; adds and scales field by field.
#[derive(Clone, Debug, Default)]
struct Work {
    arithmetic: u64,
    transcendental: u64,
    other_math: u64,
    branches: u64,
    loops: u64,
    loop_trips: u64,
    calls: u64,
    transcendental_fns: BTreeMap<&'static str, u64>,
}

impl Work {
    fn arithmetic(n: u64) -> Work {
        Work {
            arithmetic: n,
            ..Work::default()
        }
    }

    fn other(n: u64) -> Work {
        Work {
            other_math: n,
            ..Work::default()
        }
    }

    fn transcendental(name: &'static str, n: u64) -> Work {
        Work {
            transcendental: n,
            transcendental_fns: BTreeMap::from([(name, n)]),
            ..Work::default()
        }
    }

    fn total(&self) -> u64 {
        self.arithmetic
            .saturating_add(self.other_math)
            .saturating_add(self.transcendental.saturating_mul(TRANSCENDENTAL_WEIGHT))
            .saturating_add(self.branches)
    }

    fn plus(mut self, other: &Work) -> Work {
        self.arithmetic = self.arithmetic.saturating_add(other.arithmetic);
        self.transcendental = self.transcendental.saturating_add(other.transcendental);
        self.other_math = self.other_math.saturating_add(other.other_math);
        self.branches = self.branches.saturating_add(other.branches);
        self.loops = self.loops.saturating_add(other.loops);
        self.loop_trips = self.loop_trips.saturating_add(other.loop_trips);
        self.calls = self.calls.saturating_add(other.calls);
        for (name, n) in &other.transcendental_fns {
            let entry = self.transcendental_fns.entry(name).or_default();
            *entry = entry.saturating_add(*n);
        }
        self
    }

    fn times(mut self, n: u64) -> Work {
        for field in [
            &mut self.arithmetic,
            &mut self.transcendental,
            &mut self.other_math,
            &mut self.branches,
            &mut self.loops,
            &mut self.loop_trips,
            &mut self.calls,
        ] {
            *field = field.saturating_mul(n);
        }
        self.transcendental_fns
            .values_mut()
            .for_each(|v| *v = v.saturating_mul(n));
        self.transcendental_fns.retain(|_, v| *v > 0);
        self
    }

    fn into_count(self, dynamic_loop: bool) -> OpCount {
        OpCount {
            total: self.total(),
            arithmetic: self.arithmetic,
            transcendental: self.transcendental,
            other_math: self.other_math,
            branches: self.branches,
            loops: self.loops,
            loop_trips: (!dynamic_loop).then_some(self.loop_trips),
            calls: self.calls,
            transcendental_fns: self
                .transcendental_fns
                .into_iter()
                .map(|(k, v)| (k.to_string(), v))
                .collect(),
        }
    }
}

/// The more expensive of two paths, by `total` and then field by field (so that of two
/// paths of the same total the one with more calls or trips wins; the first on a full tie);
/// a path that cannot happen is `None`.
fn costlier(a: Option<Work>, b: Option<Work>) -> Option<Work> {
    let key = |w: &Work| {
        (
            w.total(),
            w.transcendental,
            w.arithmetic,
            w.other_math,
            w.branches,
            w.loop_trips,
            w.loops,
            w.calls,
        )
    };
    match (a, b) {
        (Some(a), Some(b)) => Some(if key(&b) > key(&a) { b } else { a }),
        (a, b) => a.or(b),
    }
}

/// The most expensive path to each way out of the statements walked so far.
#[derive(Clone, Debug, Default)]
struct Flow {
    /// Falling through to the next statement.
    normal: Option<Work>,
    /// `return` (or `discard`).
    ret: Option<Work>,
    /// `break` (out of the enclosing loop or switch).
    brk: Option<Work>,
    /// `continue`.
    cont: Option<Work>,
}

impl Flow {
    fn straight(work: Option<Work>) -> Flow {
        Flow {
            normal: work,
            ..Flow::default()
        }
    }

    /// Either `self` or `other`, whichever costs more, for each way out.
    fn or(self, other: Flow) -> Flow {
        Flow {
            normal: costlier(self.normal, other.normal),
            ret: costlier(self.ret, other.ret),
            brk: costlier(self.brk, other.brk),
            cont: costlier(self.cont, other.cont),
        }
    }

    /// `work` done before every way out.
    fn after(self, work: &Work) -> Flow {
        let before = |w: Option<Work>| w.map(|w| work.clone().plus(&w));
        Flow {
            normal: before(self.normal),
            ret: before(self.ret),
            brk: before(self.brk),
            cont: before(self.cont),
        }
    }

    /// `self` (the statements before) followed by `next`, a statement walked from where
    /// `self` falls through (its paths include `self.normal`).
    fn then(self, next: Flow) -> Flow {
        Flow {
            normal: next.normal,
            ret: costlier(self.ret, next.ret),
            brk: costlier(self.brk, next.brk),
            cont: costlier(self.cont, next.cont),
        }
    }
}

/// The counting domain: each of the walker's scalar operations counted where an `Emit`
/// evaluates it, along the costliest path to each way out (module doc). Values carry no
/// number, only their components; a pointer is the component count it points at.
struct Cost<'p> {
    p: &'p Program,
    /// Whether the current expression is one an `Emit` evaluates (only those count).
    emitted: bool,
    /// The paths through the current function so far.
    flow: Flow,
    /// Each loop's static trip count, by function and loop body ([`static_trips`]).
    trips: HashMap<(usize, *const Block), Option<u64>>,
    /// A loop without a static trip count was reached.
    dynamic_loop: bool,
}

impl Cost<'_> {
    /// `w` on the current path, if the current expression is counted.
    fn count(&mut self, w: Work) -> R<Vec<()>, Self> {
        if self.emitted {
            self.flow.normal = self.flow.normal.take().map(|n| n.plus(&w));
        }
        Ok(Vec::new())
    }

    fn op(&mut self, w: Work) -> R<(), Self> {
        self.count(w).map(drop)
    }

    /// The components of a value of type `ty`.
    fn size(&self, ty: &TypeInner) -> usize {
        match ty {
            TypeInner::Struct { members, .. } => members.iter().map(|m| self.p.flat[m.ty.index()]).sum(),
            TypeInner::Array { .. } => {
                let (n, stride) = self.p.elements(ty);
                n.max(1) * stride
            }
            other => components(other) as usize,
        }
    }

    /// The flow walked by `walk` from `start`, the current flow put aside meanwhile.
    fn from(
        w: &mut Walker<'_, Self>,
        start: Option<Work>,
        walk: impl FnOnce(&mut Walker<'_, Self>) -> R<(), Self>,
    ) -> R<Flow, Self> {
        let outer = std::mem::replace(&mut w.d.flow, Flow::straight(start));
        let r = walk(w);
        let inner = std::mem::replace(&mut w.d.flow, outer);
        r.map(|()| inner)
    }
}

/// Scalars in a value: 1 for a scalar (or anything else), n for a vector, c·r for a matrix.
fn components(ty: &TypeInner) -> u64 {
    match *ty {
        TypeInner::Vector { size, .. } => size as u64,
        TypeInner::Matrix { columns, rows, .. } => columns as u64 * rows as u64,
        _ => 1,
    }
}

fn unit(n: usize) -> Vec<()> {
    vec![(); n]
}

impl<'p> Domain for Cost<'p> {
    type V = ();
    type P = usize;
    /// The components of the function's return value.
    type Ret = Option<usize>;
    type Err = anyhow::Error;
    /// The caller's flow.
    type Saved = Flow;

    fn at(&mut self, _line: u32, emitted: bool) {
        self.emitted = emitted;
    }
    fn fail(&self, msg: String) -> anyhow::Error {
        anyhow::anyhow!("op count: {msg}")
    }
    fn fail_statement(&self, msg: String) -> anyhow::Error {
        anyhow::anyhow!("op count: {msg}")
    }
    fn live(&self) -> bool {
        self.flow.normal.is_some()
    }

    fn literal(&mut self, _lit: Literal, _written: &Result<f64, String>) -> R<(), Self> {
        Ok(())
    }
    fn constant(&mut self, c: &crate::eval::program::Const, _ty: Handle<naga::Type>) -> R<Vec<()>, Self> {
        Ok(unit(c.0.len()))
    }
    fn override_value(&mut self, _v: f64, _ty: &TypeInner) -> R<(), Self> {
        Ok(())
    }
    fn zero(&mut self, ty: Handle<naga::Type>) -> R<Vec<()>, Self> {
        Ok(unit(self.p.flat[ty.index()]))
    }
    fn float(&mut self, _x: f64) {}

    fn add(&mut self, _a: &(), _b: &()) -> R<(), Self> {
        self.op(Work::arithmetic(1))
    }
    fn sub(&mut self, _a: &(), _b: &()) -> R<(), Self> {
        self.op(Work::arithmetic(1))
    }
    fn mul(&mut self, _a: &(), _b: &()) -> R<(), Self> {
        self.op(Work::arithmetic(1))
    }
    fn div(&mut self, _a: &(), _b: &()) -> R<(), Self> {
        self.op(Work::arithmetic(1))
    }
    fn rem(&mut self, _a: &(), _b: &()) -> R<(), Self> {
        self.op(Work::arithmetic(1))
    }
    fn int(&mut self, _op: BinaryOperator, _a: &(), _b: &(), _kind: Option<ScalarKind>) -> R<(), Self> {
        self.op(Work::arithmetic(1))
    }
    fn compare(&mut self, _op: BinaryOperator, _a: &(), _b: &(), _kind: Option<ScalarKind>) -> R<(), Self> {
        self.op(Work::arithmetic(1))
    }
    fn logical(&mut self, _op: BinaryOperator, _a: &(), _b: &()) -> R<(), Self> {
        self.op(Work::arithmetic(1))
    }
    fn unary(&mut self, _op: UnaryOperator, _a: &(), _kind: Option<ScalarKind>) -> R<(), Self> {
        self.op(Work::arithmetic(1))
    }
    fn select(&mut self, _c: &(), _a: &(), _b: &()) -> R<(), Self> {
        self.op(Work::arithmetic(1))
    }
    fn relational(&mut self, f: RelationalFunction, a: &[()]) -> R<Vec<()>, Self> {
        let n = a.len() as u64;
        Ok(match f {
            RelationalFunction::All | RelationalFunction::Any => {
                self.op(Work::arithmetic(n.saturating_sub(1).max(1)))?;
                unit(1)
            }
            RelationalFunction::IsNan | RelationalFunction::IsInf => {
                self.op(Work::arithmetic(n))?;
                unit(a.len())
            }
        })
    }
    fn convert(&mut self, _to: ScalarKind, _from: Option<ScalarKind>, _a: &()) -> R<(), Self> {
        self.op(Work::arithmetic(1))
    }
    fn math1(&mut self, f: MathFunction, _a: &(), _kind: Option<ScalarKind>) -> R<(), Self> {
        self.op(math_work(f, 1, 1))
    }
    fn math2(&mut self, f: MathFunction, _a: &(), _b: &(), _kind: Option<ScalarKind>) -> R<(), Self> {
        self.op(math_work(f, 1, 1))
    }
    fn math3(&mut self, f: MathFunction, _a: &(), _b: &(), _c: &(), _kind: Option<ScalarKind>) -> R<(), Self> {
        self.op(math_work(f, 1, 1))
    }
    /// The built-ins the walker does not decompose, and those whose decomposition is not
    /// what the table charges (`mix` is one op per component, not four), by
    /// [`math_work`]'s table.
    fn math_special(
        &mut self,
        f: MathFunction,
        at: &TypeInner,
        ty: &TypeInner,
        _args: [Option<&[()]>; 3],
    ) -> Option<R<Vec<()>, Self>> {
        use MathFunction as M;
        let n = components(at);
        // `mix` is one op per component in the table, not its four; `distance` of scalars
        // a subtraction and an `abs`.
        let walked = evaluates(f, at) && f != M::Mix && !(f == M::Distance && n == 1);
        if walked {
            return None;
        }
        let out = self.size(ty);
        Some(self.op(math_work(f, n, components(ty))).map(|()| unit(out)))
    }

    fn opaque(&mut self, e: &Expression, ty: &TypeInner) -> Option<R<Vec<()>, Self>> {
        let n = self.size(ty);
        Some(match e {
            Expression::Derivative { .. } => self.op(Work::arithmetic(n as u64)).map(|()| unit(n)),
            // Bitcasts, images, atomics' and subgroups' results, array lengths: not modelled.
            _ => Ok(unit(n)),
        })
    }

    fn opaque_statement(w: &mut Walker<'_, Self>, fr: &mut Frame<Self>, st: &Statement) -> Option<R<(), Self>> {
        Some(match st {
            Statement::Kill => w.d.return_(&mut fr.ret, None),
            // Memory barriers, atomics, image stores, subgroups: not modelled.
            _ => Ok(()),
        })
    }

    fn local(&mut self, ty: Handle<naga::Type>) -> R<usize, Self> {
        Ok(self.p.flat[ty.index()])
    }
    fn bind(&mut self, _g: Handle<naga::GlobalVariable>, _v: Vec<()>) {}
    fn global(&mut self, _g: Handle<naga::GlobalVariable>, len: usize) -> R<usize, Self> {
        Ok(len)
    }
    fn child(&mut self, _p: &usize, _off: usize, len: usize) -> usize {
        len
    }
    fn held(&self, p: &usize) -> usize {
        *p
    }
    fn index(&mut self, _p: &usize, _idx: &(), _count: usize, stride: usize, _signed: bool) -> R<usize, Self> {
        Ok(stride)
    }
    fn index_value(&mut self, _v: &[()], _idx: &(), _count: usize, stride: usize, _signed: bool) -> R<Vec<()>, Self> {
        Ok(unit(stride))
    }
    fn load(&mut self, p: &usize) -> R<Vec<()>, Self> {
        Ok(unit(*p))
    }
    fn store(&mut self, _p: &usize, _v: &[()]) -> R<(), Self> {
        Ok(())
    }
    fn init(&mut self, _p: &usize, _v: Vec<()>) {}

    fn enter(&mut self, result: Option<Handle<naga::Type>>) -> R<(Flow, Option<usize>), Self> {
        let caller = std::mem::replace(&mut self.flow, Flow::straight(Some(Work::default())));
        Ok((caller, result.map(|t| self.p.flat[t.index()])))
    }
    /// The callee's costlier way out, inlined at the call with the call itself.
    fn leave(&mut self, caller: Flow, ret: Option<usize>) -> Option<Vec<()>> {
        let callee = std::mem::replace(&mut self.flow, caller);
        let work = costlier(callee.normal, callee.ret).unwrap_or_default();
        let call = Work {
            calls: 1,
            ..Work::default()
        };
        self.flow.normal = self.flow.normal.take().map(|n| n.plus(&call).plus(&work));
        ret.map(unit)
    }

    /// Both arms, from the branch; each way out the costlier of the two.
    fn if_(w: &mut Walker<'_, Self>, fr: &mut Frame<Self>, _cond: &(), arms: Arms) -> R<(), Self> {
        let start = w.d.flow.normal.clone().map(|n| n.plus(&branch()));
        let accept = Cost::from(w, start.clone(), |w| w.block(fr, arms.accept))?;
        let reject = Cost::from(w, start, |w| w.block(fr, arms.reject))?;
        let before = std::mem::take(&mut w.d.flow);
        w.d.flow = before.then(accept.or(reject));
        Ok(())
    }

    /// The costliest case, from the branch (a `break` in a case leaves the switch).
    fn switch(w: &mut Walker<'_, Self>, fr: &mut Frame<Self>, _sel: &(), cases: &[naga::SwitchCase]) -> R<(), Self> {
        let start = w.d.flow.normal.clone().map(|n| n.plus(&branch()));
        let mut all: Option<Flow> = None;
        for case in cases {
            let mut flow = Cost::from(w, start.clone(), |w| w.block(fr, &case.body))?;
            flow.normal = costlier(flow.normal, flow.brk.take());
            all = Some(match all {
                Some(f) => f.or(flow),
                None => flow,
            });
        }
        let before = std::mem::take(&mut w.d.flow);
        w.d.flow = before.then(all.unwrap_or_else(|| Flow::straight(start)));
        Ok(())
    }

    /// The body and the continuing block once each, from zero, scaled by the static trip
    /// count (once where there is none).
    fn loop_(w: &mut Walker<'_, Self>, fr: &mut Frame<Self>, l: Looping) -> R<(), Self> {
        let trips = match l.break_if {
            None => {
                w.d.trips
                    .get(&(fr.fun.index(), l.body as *const Block))
                    .copied()
                    .flatten()
            }
            Some(_) => None,
        };
        w.d.dynamic_loop |= trips.is_none();
        let n = trips.unwrap_or(1);
        let b = Cost::from(w, Some(Work::default()), |w| w.block(fr, l.body))?;
        let c = Cost::from(w, Some(Work::default()), |w| w.block(fr, l.continuing))?;
        // One whole trip: the body to its end or a `continue`, then the continuing block.
        let trip = then(&costlier(b.normal, b.cont), &c.normal);
        // Leaving: the `break` (the failed loop condition) after the last trip, or a
        // `break if` at the end of one.
        let exit = costlier(b.brk, l.break_if.and(c.normal.as_ref().map(|_| Work::default())));
        let trips_work = trip.clone().unwrap_or_default().times(n);
        let entered = Work {
            loops: 1,
            loop_trips: n,
            ..Work::default()
        };
        let flow = Flow {
            normal: exit.map(|e| trips_work.plus(&e).plus(&entered)),
            // The most expensive return: in the last trip.
            ret: match n {
                0 => None,
                n => b
                    .ret
                    .map(|r| trip.clone().unwrap_or_default().times(n - 1).plus(&r).plus(&entered)),
            },
            brk: None,
            cont: None,
        };
        let mut before = std::mem::take(&mut w.d.flow);
        let prefix = before.normal.take().unwrap_or_default();
        w.d.flow = before.then(flow.after(&prefix));
        Ok(())
    }

    fn break_(&mut self) -> R<(), Self> {
        self.flow.brk = costlier(self.flow.brk.take(), self.flow.normal.take());
        Ok(())
    }
    fn continue_(&mut self) -> R<(), Self> {
        self.flow.cont = costlier(self.flow.cont.take(), self.flow.normal.take());
        Ok(())
    }
    fn return_(&mut self, _ret: &mut Option<usize>, _v: Option<&[()]>) -> R<(), Self> {
        self.flow.ret = costlier(self.flow.ret.take(), self.flow.normal.take());
        Ok(())
    }
}

fn branch() -> Work {
    Work {
        branches: 1,
        ..Work::default()
    }
}

fn then(a: &Option<Work>, b: &Option<Work>) -> Option<Work> {
    Some(a.clone()?.plus(b.as_ref()?))
}

/// A built-in's cost, `n` the components of its first argument, `out` of its result: the
/// table of the module doc, per component (what the walker's decompositions make of the
/// geometric ones is the same count).
fn math_work(fun: MathFunction, n: u64, out: u64) -> Work {
    use MathFunction as M;
    let dot = 2 * n - 1;
    let determinant = |size: u64| match size {
        2 => 3,
        3 => 14,
        _ => 63,
    };
    match fun {
        M::Cos => Work::transcendental("cos", n),
        M::Cosh => Work::transcendental("cosh", n),
        M::Sin => Work::transcendental("sin", n),
        M::Sinh => Work::transcendental("sinh", n),
        M::Tan => Work::transcendental("tan", n),
        M::Tanh => Work::transcendental("tanh", n),
        M::Acos => Work::transcendental("acos", n),
        M::Asin => Work::transcendental("asin", n),
        M::Atan => Work::transcendental("atan", n),
        M::Atan2 => Work::transcendental("atan2", n),
        M::Asinh => Work::transcendental("asinh", n),
        M::Acosh => Work::transcendental("acosh", n),
        M::Atanh => Work::transcendental("atanh", n),
        M::Exp => Work::transcendental("exp", n),
        M::Exp2 => Work::transcendental("exp2", n),
        M::Log => Work::transcendental("log", n),
        M::Log2 => Work::transcendental("log2", n),
        M::Pow => Work::transcendental("pow", n),
        M::Sqrt => Work::transcendental("sqrt", n),
        M::InverseSqrt => Work::transcendental("inverseSqrt", n),

        M::Dot => Work::arithmetic(dot),
        M::Cross => Work::arithmetic(9),
        // Of a scalar: `abs`.
        M::Length if n == 1 => Work::other(1),
        M::Length => Work::arithmetic(dot).plus(&Work::transcendental("sqrt", 1)),
        M::Distance if n == 1 => Work::arithmetic(1).plus(&Work::other(1)),
        M::Distance => Work::arithmetic(n + dot).plus(&Work::transcendental("sqrt", 1)),
        M::Normalize => Work::arithmetic(dot + n).plus(&Work::transcendental("inverseSqrt", 1)),
        M::Outer => Work::arithmetic(out),
        M::FaceForward => Work::arithmetic(3 * n),
        M::Reflect => Work::arithmetic(4 * n),
        M::Refract => Work::arithmetic(6 * n + 4).plus(&Work::transcendental("sqrt", 1)),
        M::Transpose => Work::default(),
        // `n` is the matrix's components: its side is their square root.
        M::Determinant => Work::arithmetic(determinant(n.isqrt())),
        // Not produced from WGSL: cofactors, their dot with a row, a reciprocal, a scale.
        M::Inverse => Work::arithmetic({
            let c = n.isqrt();
            let cofactor = if c == 2 { 0 } else { determinant(c - 1) };
            c * c * cofactor + (2 * c - 1) + 1 + c * c
        }),

        M::Pack4x8snorm
        | M::Pack4x8unorm
        | M::Pack2x16snorm
        | M::Pack2x16unorm
        | M::Pack2x16float
        | M::Pack4xI8
        | M::Pack4xU8
        | M::Pack4xI8Clamp
        | M::Pack4xU8Clamp
        | M::Unpack4x8snorm
        | M::Unpack4x8unorm
        | M::Unpack2x16snorm
        | M::Unpack2x16unorm
        | M::Unpack2x16float
        | M::Unpack4xI8
        | M::Unpack4xU8
        | M::Dot4I8Packed
        | M::Dot4U8Packed => Work::other(1),

        M::Abs
        | M::Min
        | M::Max
        | M::Clamp
        | M::Saturate
        | M::Radians
        | M::Degrees
        | M::Ceil
        | M::Floor
        | M::Round
        | M::Fract
        | M::Trunc
        | M::Modf
        | M::Frexp
        | M::Ldexp
        | M::Sign
        | M::Fma
        | M::Mix
        | M::Step
        | M::SmoothStep
        | M::QuantizeToF16
        | M::CountTrailingZeros
        | M::CountLeadingZeros
        | M::CountOneBits
        | M::ReverseBits
        | M::ExtractBits
        | M::InsertBits
        | M::FirstTrailingBit
        | M::FirstLeadingBit => Work::other(n),
    }
}

/// Calls `found` with every loop's body in `block` and its static trip count, `path` the
/// enclosing blocks with the index of the statement walked in each and whether the block
/// is a loop's (what [`static_trips`] searches back through for the counter's start).
fn loop_trips<'b>(
    module: &naga::Module,
    fun: &'b Function,
    block: &'b Block,
    in_loop: bool,
    path: &mut Vec<(&'b Block, usize, bool)>,
    found: &mut dyn FnMut(&'b Block, Option<u64>),
) {
    for (i, st) in block.iter().enumerate() {
        path.push((block, i, in_loop));
        match st {
            Statement::Loop {
                body,
                continuing,
                break_if,
            } => {
                let n = match break_if {
                    None => static_trips(module, fun, path, body, continuing),
                    Some(_) => None,
                };
                found(body, n);
                loop_trips(module, fun, body, true, path, found);
                loop_trips(module, fun, continuing, true, path, found);
            }
            other => each_block(other, &mut |b| loop_trips(module, fun, b, false, path, found)),
        }
        path.pop();
    }
}

// ---------------------------------------------------------------------------------------
// Static trip counts.

/// The trip count of the loop at the end of `path` when it is a counted loop (module doc).
fn static_trips(
    module: &naga::Module,
    fun: &Function,
    path: &[(&Block, usize, bool)],
    body: &Block,
    continuing: &Block,
) -> Option<u64> {
    let exprs = &fun.expressions;
    // The loop condition: the body's first statement after the emits.
    let Statement::If {
        condition,
        accept,
        reject,
    } = body.iter().find(|st| !matches!(st, Statement::Emit(_)))?
    else {
        return None;
    };
    let lone_break = |b: &Block| matches!(b.iter().as_slice(), [Statement::Break]);
    // Whether the loop goes on when `condition` holds.
    let on_true = match (accept.is_empty(), reject.is_empty()) {
        (true, false) if lone_break(reject) => true,
        (false, true) if lone_break(accept) => false,
        _ => return None,
    };
    let (mut op, counter, bound) = comparison(exprs, *condition)?;
    if !on_true {
        op = negate(op)?;
    }
    let bound = int_value(module, exprs, bound)?;

    // The step: the continuing block's only store to the counter, `i = i ± k`.
    let mut steps = Vec::new();
    stores_to(exprs, counter, continuing, &mut steps);
    let [step_value] = steps.as_slice() else {
        return None;
    };
    let step = step(module, exprs, counter, *step_value)?;

    // The body leaves the counter alone.
    let mut in_body = Vec::new();
    stores_to(exprs, counter, body, &mut in_body);
    if !in_body.is_empty() || passed_to_call(exprs, counter, &fun.body) {
        return None;
    }
    let start = match last_store_before(exprs, counter, path)? {
        Some(value) => int_value(module, exprs, value)?,
        None => match fun.local_variables[counter].init {
            Some(init) => int_value(module, exprs, init)?,
            None => 0,
        },
    };

    let range = int_range(&module.types[fun.local_variables[counter].ty].inner)?;
    trips(op, start, bound, step, range)
}

/// The value last stored to `var` on the straight-line way to the end of `path`, searching
/// back through the enclosing blocks: `Some(None)` when none is (the declaration's value
/// holds), `None` when it cannot be known (a store inside a preceding `if` or loop, or the
/// search would leave an enclosing loop, whose later trips would see the value it left).
fn last_store_before(
    exprs: &naga::Arena<Expression>,
    var: Handle<naga::LocalVariable>,
    path: &[(&Block, usize, bool)],
) -> Option<Option<Handle<Expression>>> {
    for &(block, index, in_loop) in path.iter().rev() {
        for st in block.iter().as_slice()[..index].iter().rev() {
            match st {
                Statement::Store { pointer, value } if local_of(exprs, *pointer) == Some(var) => {
                    return Some(Some(*value))
                }
                _ => {
                    let mut stored = Vec::new();
                    each_block(st, &mut |b| stores_to(exprs, var, b, &mut stored));
                    if !stored.is_empty() {
                        return None;
                    }
                }
            }
        }
        if in_loop {
            return None;
        }
    }
    Some(None)
}

/// Loop `while counter op bound`: `(op, counter, bound)` from `condition` when it compares
/// a load of a local variable with another expression (either side; under `!` too).
fn comparison(
    exprs: &naga::Arena<Expression>,
    condition: Handle<Expression>,
) -> Option<(BinaryOperator, Handle<naga::LocalVariable>, Handle<Expression>)> {
    match exprs[condition] {
        Expression::Unary {
            op: UnaryOperator::LogicalNot,
            expr,
        } => {
            let (op, counter, bound) = comparison(exprs, expr)?;
            Some((negate(op)?, counter, bound))
        }
        Expression::Binary { op, left, right } => {
            let loaded = |e: Handle<Expression>| match exprs[e] {
                Expression::Load { pointer } => local_of(exprs, pointer),
                _ => None,
            };
            match (loaded(left), loaded(right)) {
                (Some(counter), None) => Some((op, counter, right)),
                (None, Some(counter)) => Some((mirror(op)?, counter, left)),
                _ => None,
            }
        }
        _ => None,
    }
}

/// `!(a op b)` as `a op' b` (integers: no NaN).
fn negate(op: BinaryOperator) -> Option<BinaryOperator> {
    use BinaryOperator as B;
    Some(match op {
        B::Less => B::GreaterEqual,
        B::LessEqual => B::Greater,
        B::Greater => B::LessEqual,
        B::GreaterEqual => B::Less,
        B::Equal => B::NotEqual,
        B::NotEqual => B::Equal,
        _ => return None,
    })
}

/// `a op b` as `b op' a`.
fn mirror(op: BinaryOperator) -> Option<BinaryOperator> {
    use BinaryOperator as B;
    Some(match op {
        B::Less => B::Greater,
        B::LessEqual => B::GreaterEqual,
        B::Greater => B::Less,
        B::GreaterEqual => B::LessEqual,
        B::Equal | B::NotEqual => op,
        _ => return None,
    })
}

fn local_of(exprs: &naga::Arena<Expression>, pointer: Handle<Expression>) -> Option<Handle<naga::LocalVariable>> {
    match exprs[pointer] {
        Expression::LocalVariable(v) => Some(v),
        _ => None,
    }
}

/// The values stored to `var` anywhere in `block`.
fn stores_to(
    exprs: &naga::Arena<Expression>,
    var: Handle<naga::LocalVariable>,
    block: &Block,
    out: &mut Vec<Handle<Expression>>,
) {
    for st in block.iter() {
        match st {
            Statement::Store { pointer, value } if local_of(exprs, *pointer) == Some(var) => out.push(*value),
            _ => each_block(st, &mut |b| stores_to(exprs, var, b, out)),
        }
    }
}

fn passed_to_call(exprs: &naga::Arena<Expression>, var: Handle<naga::LocalVariable>, block: &Block) -> bool {
    block.iter().any(|st| match st {
        Statement::Call { arguments, .. } => arguments.iter().any(|a| local_of(exprs, *a) == Some(var)),
        _ => {
            let mut found = false;
            each_block(st, &mut |b| found |= passed_to_call(exprs, var, b));
            found
        }
    })
}

/// Calls `f` on each block nested directly in `st`.
fn each_block<'b>(st: &'b Statement, f: &mut dyn FnMut(&'b Block)) {
    match st {
        Statement::Block(b) => f(b),
        Statement::If { accept, reject, .. } => {
            f(accept);
            f(reject);
        }
        Statement::Switch { cases, .. } => cases.iter().for_each(|c| f(&c.body)),
        Statement::Loop { body, continuing, .. } => {
            f(body);
            f(continuing);
        }
        _ => {}
    }
}

/// The step of `counter = counter ± k` (or `k + counter`).
fn step(
    module: &naga::Module,
    exprs: &naga::Arena<Expression>,
    counter: Handle<naga::LocalVariable>,
    value: Handle<Expression>,
) -> Option<i128> {
    let Expression::Binary { op, left, right } = exprs[value] else {
        return None;
    };
    let is_counter = |e: Handle<Expression>| match exprs[e] {
        Expression::Load { pointer } => local_of(exprs, pointer) == Some(counter),
        _ => false,
    };
    match op {
        BinaryOperator::Add if is_counter(left) => int_value(module, exprs, right),
        BinaryOperator::Add if is_counter(right) => int_value(module, exprs, left),
        BinaryOperator::Subtract if is_counter(left) => int_value(module, exprs, right).map(|k| -k),
        _ => None,
    }
}

/// The values an integer counter's type holds.
fn int_range(ty: &TypeInner) -> Option<(i128, i128)> {
    match *ty {
        TypeInner::Scalar(naga::Scalar { kind, width }) => {
            let bits = u32::from(width) * 8;
            match kind {
                ScalarKind::Uint => Some((0, (1i128 << bits) - 1)),
                ScalarKind::Sint => Some((-(1i128 << (bits - 1)), (1i128 << (bits - 1)) - 1)),
                _ => None,
            }
        }
        _ => None,
    }
}

/// Trips of `for (i = start; i op bound; i += step)`, `None` when the counter would wrap
/// (or never reach the end) before the condition fails.
fn trips(op: BinaryOperator, start: i128, bound: i128, step: i128, (lo, hi): (i128, i128)) -> Option<u64> {
    use BinaryOperator as B;
    let holds = |i: i128| match op {
        B::Less => i < bound,
        B::LessEqual => i <= bound,
        B::Greater => i > bound,
        B::GreaterEqual => i >= bound,
        B::Equal => i == bound,
        B::NotEqual => i != bound,
        _ => false,
    };
    if !(lo..=hi).contains(&start) || !holds(start) {
        return Some(0);
    }
    if step == 0 {
        return None;
    }
    let n = match op {
        B::Less | B::LessEqual if step > 0 => {
            let last = if op == B::Less { bound - 1 } else { bound };
            (last - start) / step + 1
        }
        B::Greater | B::GreaterEqual if step < 0 => {
            let last = if op == B::Greater { bound + 1 } else { bound };
            (start - last) / -step + 1
        }
        B::NotEqual if (bound - start) % step == 0 && (bound - start) / step > 0 => (bound - start) / step,
        B::Equal => 1,
        _ => return None,
    };
    // The counter's value when the condition fails must be representable.
    let end = start + n * step;
    ((lo..=hi).contains(&end) && !holds(end)).then(|| u64::try_from(n).ok())?
}

/// An integer known at compile time: literals, constants, overrides (their values after
/// `process_overrides`, else their defaults), and arithmetic on them.
fn int_value(module: &naga::Module, exprs: &naga::Arena<Expression>, h: Handle<Expression>) -> Option<i128> {
    match value(module, exprs, h, 0)? {
        Value::Int(i) => Some(i),
        Value::Float(_) => None,
    }
}

#[derive(Clone, Copy)]
enum Value {
    Int(i128),
    Float(f64),
}

fn value(module: &naga::Module, exprs: &naga::Arena<Expression>, h: Handle<Expression>, depth: u32) -> Option<Value> {
    if depth > 64 {
        return None;
    }
    let global = |h: Handle<Expression>| value(module, &module.global_expressions, h, depth + 1);
    let here = |h: Handle<Expression>| value(module, exprs, h, depth + 1);
    Some(match exprs[h] {
        Expression::Literal(literal) => match literal {
            Literal::I32(v) => Value::Int(v.into()),
            Literal::U32(v) => Value::Int(v.into()),
            Literal::I64(v) | Literal::AbstractInt(v) => Value::Int(v.into()),
            Literal::U64(v) => Value::Int(v.into()),
            Literal::I16(v) => Value::Int(v.into()),
            Literal::U16(v) => Value::Int(v.into()),
            Literal::F32(v) => Value::Float(v.into()),
            Literal::F64(v) | Literal::AbstractFloat(v) => Value::Float(v),
            Literal::F16(v) => Value::Float(v.into()),
            Literal::Bool(_) => return None,
        },
        Expression::Constant(c) => global(module.constants[c].init)?,
        Expression::Override(o) => global(module.overrides[o].init?)?,
        Expression::ZeroValue(ty) => match module.types[ty].inner {
            TypeInner::Scalar(naga::Scalar {
                kind: ScalarKind::Float | ScalarKind::AbstractFloat,
                ..
            }) => Value::Float(0.0),
            TypeInner::Scalar(_) => Value::Int(0),
            _ => return None,
        },
        Expression::Unary {
            op: UnaryOperator::Negate,
            expr,
        } => match here(expr)? {
            Value::Int(i) => Value::Int(-i),
            Value::Float(f) => Value::Float(-f),
        },
        Expression::Binary { op, left, right } => {
            use BinaryOperator as B;
            match (here(left)?, here(right)?) {
                (Value::Int(a), Value::Int(b)) => Value::Int(match op {
                    B::Add => a + b,
                    B::Subtract => a - b,
                    B::Multiply => a.checked_mul(b)?,
                    B::Divide => a.checked_div(b)?,
                    B::Modulo => a.checked_rem(b)?,
                    _ => return None,
                }),
                (Value::Float(a), Value::Float(b)) => Value::Float(match op {
                    B::Add => a + b,
                    B::Subtract => a - b,
                    B::Multiply => a * b,
                    B::Divide => a / b,
                    _ => return None,
                }),
                _ => return None,
            }
        }
        Expression::Math {
            fun, arg, arg1, arg2, ..
        } => {
            let a = here(arg)?;
            let b = || arg1.and_then(here);
            let pick = |a: Value, b: Value, max: bool| match (a, b) {
                (Value::Int(a), Value::Int(b)) => Some(Value::Int(if max { a.max(b) } else { a.min(b) })),
                (Value::Float(a), Value::Float(b)) => Some(Value::Float(if max { a.max(b) } else { a.min(b) })),
                _ => None,
            };
            match fun {
                MathFunction::Max => pick(a, b()?, true)?,
                MathFunction::Min => pick(a, b()?, false)?,
                MathFunction::Clamp => pick(pick(a, b()?, true)?, here(arg2?)?, false)?,
                MathFunction::Abs => match a {
                    Value::Int(i) => Value::Int(i.abs()),
                    Value::Float(f) => Value::Float(f.abs()),
                },
                _ => return None,
            }
        }
        Expression::As {
            expr,
            kind,
            convert: Some(_),
        } => match (here(expr)?, kind) {
            (Value::Int(i), ScalarKind::Sint | ScalarKind::Uint) => Value::Int(i),
            (Value::Float(f), ScalarKind::Sint | ScalarKind::Uint) if f.is_finite() => Value::Int(f.trunc() as i128),
            (Value::Int(i), ScalarKind::Float) => Value::Float(i as f64),
            (Value::Float(f), ScalarKind::Float) => Value::Float(f),
            _ => return None,
        },
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::builtin_kernels;
    use crate::kernel::ENTRY_NAME;

    /// A kernel with the given body of `method` (and declarations before it).
    fn kernel(decls: &str, body: &str, params: &str) -> KernelFile {
        let header = if params.is_empty() {
            String::new()
        } else {
            format!("//! params: {params}\n")
        };
        let text = format!(
            "//! id: test.cost\n//! target: line\n{header}{decls}\nfn method(scene: Scene) -> f32 {{\n{body}\n}}\n"
        );
        KernelFile::parse("test.wgsl", &text).unwrap()
    }

    fn cost(decls: &str, body: &str) -> OpCount {
        method_cost(&kernel(decls, body, ""), &[]).unwrap()
    }

    /// What `ll_main` itself does around `method`: `ll_i >= ll_count`, its `if`, the call.
    /// Transcendental counts by name.
    fn named(pairs: &[(&str, u64)]) -> BTreeMap<String, u64> {
        pairs.iter().map(|&(k, v)| (k.to_string(), v)).collect()
    }

    /// The own count of a method whose body is `b`.
    fn body(b: &str) -> OpCount {
        own(&cost("", b))
    }

    fn harness() -> OpCount {
        cost("", "return 0.0;")
    }

    /// `c` minus the harness's own work.
    fn own(c: &OpCount) -> OpCount {
        let h = harness();
        let mut c = c.clone();
        c.arithmetic -= h.arithmetic;
        c.branches -= h.branches;
        c.calls -= h.calls;
        c.total -= h.total;
        c
    }

    #[test]
    fn the_harness_entry_point_costs_a_comparison_a_branch_and_a_call() {
        let h = harness();
        assert_eq!(
            h,
            OpCount {
                arithmetic: 1,
                branches: 1,
                calls: 1,
                loop_trips: Some(0),
                total: 2,
                ..OpCount::default()
            }
        );
    }

    #[test]
    fn scalar_arithmetic_counts_each_operator() {
        let c = own(&cost("", "return scene.p1.x * scene.p2.y + 1.0;"));
        assert_eq!((c.arithmetic, c.transcendental, c.other_math), (2, 0, 0));
        assert_eq!((c.branches, c.calls, c.total), (0, 0, 2));
    }

    #[test]
    fn vectors_count_per_component_and_geometry_by_its_parts() {
        // 3 adds, then dot3 = 3 multiplies + 2 adds.
        let c = own(&cost("", "let v = scene.p1 + scene.p2;\nreturn dot(v, v);"));
        assert_eq!((c.arithmetic, c.transcendental), (8, 0));
        // length3 = dot3 + sqrt.
        let c = own(&cost("", "return length(scene.p1);"));
        assert_eq!((c.arithmetic, c.transcendental), (5, 1));
        assert_eq!(c.transcendental_fns, named(&[("sqrt", 1)]));
        assert_eq!(c.total, 5 + TRANSCENDENTAL_WEIGHT);
        // normalize3 = dot3 + inverseSqrt + 3 multiplies; then .x and max (other math).
        let c = own(&cost("", "return max(normalize(scene.p1).x, 0.0);"));
        assert_eq!((c.arithmetic, c.transcendental, c.other_math), (8, 1, 1));
        assert_eq!(c.transcendental_fns, named(&[("inverseSqrt", 1)]));
        // mat3x3 · vec3 = 9 multiplies + 6 adds; vec3 atan is 3 transcendentals.
        let c = own(&cost("", "return atan(scene.minv * scene.p1).y;"));
        assert_eq!((c.arithmetic, c.transcendental), (15, 3));
    }

    #[test]
    fn a_literal_bounded_loop_counts_its_body_per_trip() {
        let c = body(
            "var s = 0.0;\nlet x = scene.p1.x;\nfor (var i = 0u; i < 10u; i++) {\n    s += atan(x);\n}\nreturn s;",
        );
        assert_eq!(c.loop_trips, Some(10));
        assert_eq!((c.loops, c.transcendental), (1, 10));
        assert_eq!(c.transcendental_fns, named(&[("atan", 10)]));
        // Per trip `i < 10`, `s + atan`, `i + 1`; the failing `i < 10` once more.
        assert_eq!(c.arithmetic, 3 * 10 + 1);
        assert_eq!(c.branches, 10 + 1);
    }

    #[test]
    fn an_override_bounded_loop_takes_the_params() {
        let k = kernel(
            "override N: u32 = 4;",
            "var s = 0.0;\nfor (var i = 0u; i < N; i++) {\n    s += sqrt(scene.p1.x + f32(i));\n}\nreturn s;",
            "N=4",
        );
        let c = method_cost(&k, &[32.0]).unwrap();
        assert_eq!((c.loop_trips, c.transcendental), (Some(32), 32));
        let c = method_cost(&k, &[]).unwrap();
        assert_eq!((c.loop_trips, c.transcendental), (Some(4), 4));
        // Derived bounds fold too: max(N / 4, 1).
        let k = kernel(
            "override N: u32 = 64;",
            "var s = 0.0;\nlet n = max(N / 4u, 1u);\nfor (var i = 0u; i < n; i++) {\n    s += exp(scene.p1.x);\n}\nreturn s;",
            "N=64",
        );
        assert_eq!(method_cost(&k, &[]).unwrap().loop_trips, Some(16));
        assert_eq!(method_cost(&k, &[2.0]).unwrap().loop_trips, Some(1));
        assert!(method_cost(&k, &[1.0, 2.0]).is_err());
    }

    #[test]
    fn other_loop_shapes() {
        // `loop` with a `break` on the condition and a step of 2: i = 0, 2, 4.
        let c = body("var s = 0.0;\nvar i = 0;\nloop {\n    if (i >= 5) { break; }\n    s += cos(s);\n    continuing { i += 2; }\n}\nreturn s;");
        assert_eq!((c.loop_trips, c.transcendental), (Some(3), 3));
        // Counting down, the counter set before the loop (i = 9, 6, 3).
        let c = body("var s = 0.0;\nvar i: i32;\ni = 9;\nfor (; i > 0; i -= 3) {\n    s += sin(s);\n}\nreturn s;");
        assert_eq!((c.loop_trips, c.transcendental), (Some(3), 3));
        // ... but not inside a preceding `if`.
        let c = body("var s = 0.0;\nvar i = 9;\nif (s > 0.0) { i = 90; }\nfor (; i > 0; i -= 3) {\n    s += sin(s);\n}\nreturn s;");
        assert_eq!(c.loop_trips, None);
        // Nested: 3 outer trips, each entering a 4-trip loop.
        let c = body("var s = 0.0;\nfor (var i = 0u; i < 3u; i++) {\n    for (var j = 0u; j < 4u; j++) {\n        s += log(s);\n    }\n}\nreturn s;");
        assert_eq!((c.loops, c.loop_trips, c.transcendental), (4, Some(3 + 12), 12));
    }

    #[test]
    fn loops_without_a_static_count_count_once() {
        // A bound from the scene.
        let c = body("var s = 0.0;\nfor (var i = 0u; i < scene.flags; i++) {\n    s += atan(s);\n}\nreturn s;");
        assert_eq!((c.loop_trips, c.loops, c.transcendental), (None, 1, 1));
        // The counter changed in the body.
        let c = body("var s = 0.0;\nfor (var i = 0u; i < 10u; i++) {\n    s += atan(s);\n    if (s > 1.0) { i += 1u; }\n}\nreturn s;");
        assert_eq!((c.loop_trips, c.transcendental), (None, 1));
        // An unsigned counter that wraps instead of ending.
        let c = body("var s = 0.0;\nfor (var i = 3u; i >= 0u; i--) {\n    s += atan(s);\n    if (s > 1.0) { break; }\n}\nreturn s;");
        assert_eq!(c.loop_trips, None);
    }

    #[test]
    fn branches_count_the_costlier_path() {
        // The early return is cheaper than going on: 1 transcendental.
        let c = body("if (scene.p1.x > 0.0) {\n    return 1.0;\n}\nreturn atan(scene.p1.y);");
        assert_eq!((c.transcendental, c.branches, c.arithmetic), (1, 1, 1));
        // The early return is the costlier path.
        let c = body("if (scene.p1.x > 0.0) {\n    return atan(scene.p1.y) + acos(scene.p1.z);\n}\nreturn scene.p1.y;");
        assert_eq!((c.transcendental, c.branches, c.arithmetic), (2, 1, 2));
        // Only one arm of an if/else.
        let c = body("var r = 0.0;\nif (scene.p1.x > 0.0) {\n    r = sqrt(scene.p1.y);\n} else {\n    r = exp(scene.p1.y) * exp(scene.p1.z);\n}\nreturn r;");
        assert_eq!(c.transcendental, 2);
        assert_eq!(c.transcendental_fns, named(&[("exp", 2)]));
    }

    #[test]
    fn calls_inline_the_callee_at_each_site() {
        let c = own(&cost(
            "fn f(x: f32) -> f32 { return atan(x) * 2.0; }",
            "return f(scene.p1.x) + f(scene.p1.y);",
        ));
        assert_eq!((c.calls, c.transcendental, c.arithmetic), (2, 2, 3));
    }

    #[test]
    fn bitcasts_are_free_and_the_built_ins_the_walker_leaves_count_by_the_table() {
        let c = body(
            "let m = mat4x4<f32>(vec4(scene.p1, 1.0), vec4(scene.p2, 1.0), vec4(scene.p1, 0.0), vec4(scene.p2, 0.0));\n\
             return f32(bitcast<u32>(scene.p1.x) >> 1u) + smoothstep(0.0, 1.0, scene.p1.y) + determinant(m);",
        );
        // The shift, the conversion, two adds and the 4×4 determinant's 63; smoothstep is one.
        assert_eq!((c.arithmetic, c.other_math, c.transcendental), (1 + 1 + 2 + 63, 1, 0));
    }

    /// `entry_check` is what compose.rs's entry point does around the call: one counted
    /// expression (a comparison), one `if` whose accept arm returns, one call, no loop.
    #[test]
    fn the_entry_point_is_what_entry_check_counts() {
        let k = kernel("", "return 0.0;", "");
        let c = crate::kernel::compose_with(&k, None, naga::valid::Capabilities::all()).unwrap();
        let ep = c.module.entry_points.iter().find(|e| e.name == ENTRY_NAME).unwrap();
        let f = &ep.function;
        #[derive(Default, Debug, PartialEq)]
        struct Seen {
            counted: Vec<String>,
            ifs: usize,
            returns_in_if: usize,
            calls: usize,
            loops: usize,
        }
        fn walk(f: &Function, b: &Block, in_if: bool, seen: &mut Seen) {
            for st in b.iter() {
                match st {
                    Statement::Emit(r) => {
                        for h in r.clone() {
                            let e = &f.expressions[h];
                            let counted = matches!(
                                e,
                                Expression::Binary { .. }
                                    | Expression::Unary { .. }
                                    | Expression::Select { .. }
                                    | Expression::Relational { .. }
                                    | Expression::Math { .. }
                                    | Expression::As { convert: Some(_), .. }
                            );
                            if counted {
                                seen.counted.push(format!("{e:?}"));
                            }
                        }
                    }
                    Statement::If { accept, reject, .. } => {
                        seen.ifs += 1;
                        walk(f, accept, true, seen);
                        walk(f, reject, true, seen);
                    }
                    Statement::Return { .. } if in_if => seen.returns_in_if += 1,
                    Statement::Call { .. } => seen.calls += 1,
                    Statement::Loop { .. } => seen.loops += 1,
                    other => each_block(other, &mut |b| walk(f, b, in_if, seen)),
                }
            }
        }
        let mut seen = Seen::default();
        walk(f, &f.body, false, &mut seen);
        assert_eq!(seen.counted.len(), 1, "{seen:?}");
        assert!(seen.counted[0].contains("GreaterEqual"), "{seen:?}");
        assert_eq!((seen.ifs, seen.returns_in_if, seen.calls, seen.loops), (1, 1, 1, 0));
        assert_eq!((entry_check().arithmetic, entry_check().branches), (1, 1));
    }

    fn builtin(id: &str) -> KernelFile {
        builtin_kernels().into_iter().find(|k| k.id == id).unwrap()
    }

    #[test]
    fn ltc2023_trades_two_atan_for_one_acos() {
        let c2017 = method_cost(&builtin("line.ltc2017"), &[]).unwrap();
        let c2023 = method_cost(&builtin("line.ltc2023"), &[]).unwrap();
        let fns = |c: &OpCount, name: &str| c.transcendental_fns.get(name).copied().unwrap_or(0);
        // 2017: Fpo twice (one atan each), normalize twice, length twice.
        assert_eq!(
            c2017.transcendental_fns,
            named(&[("atan", 2), ("inverseSqrt", 2), ("sqrt", 2)])
        );
        // 2023: one acos, four rsqrt in the listing, and the normalize and length that
        // derive its centre/axis/half length from the end points.
        assert_eq!(
            c2023.transcendental_fns,
            named(&[("acos", 1), ("inverseSqrt", 5), ("sqrt", 1)])
        );
        let inverse_trig = |c: &OpCount| fns(c, "atan") + fns(c, "acos") + fns(c, "atan2");
        assert!(inverse_trig(&c2023) < inverse_trig(&c2017));
        // No loops: the trip count is static (zero).
        assert_eq!((c2017.loops, c2017.loop_trips), (0, Some(0)));
    }

    #[test]
    fn numeric_cost_grows_linearly_with_samples() {
        let k = builtin("line.numeric");
        let at = |n: u32| method_cost(&k, &[f64::from(n)]).unwrap();
        let (c16, c32, c64) = (at(16), at(32), at(64));
        // SAMPLES / 4 panels of 4 points.
        assert_eq!(
            (c16.loop_trips, c32.loop_trips, c64.loop_trips),
            (Some(4), Some(8), Some(16))
        );
        assert_eq!(c64.loops, 1);
        // Each panel: 4 integrands, each with cos, sin, cos and D's length (a sqrt).
        let per_panel = (c32.transcendental - c16.transcendental) / 4;
        assert!(per_panel > 0);
        assert_eq!(c64.transcendental - c32.transcendental, 8 * per_panel);
        assert_eq!(c16.transcendental - 4 * per_panel, c64.transcendental - 16 * per_panel);
        assert_eq!(c64.total - c32.total, 2 * (c32.total - c16.total));
        assert_eq!(method_cost(&k, &[]).unwrap(), c64, "the header's default is SAMPLES=64");

        let paper = method_cost(&builtin("line.numeric_paper"), &[]).unwrap();
        assert_eq!(paper.loop_trips, Some(100));
    }

    #[test]
    fn composites_count_their_inner_method() {
        // A composite calling I_line twice, with a numeric inner method at two sample counts.
        let text = "//! id: test.composite\n//! target: cylinder\n//! uses: line\n\
                    fn method(scene: Scene) -> f32 {\n    return I_line(scene.p1, scene.p2) + I_line(scene.p2, scene.p1);\n}\n";
        let composite = KernelFile::parse("composite.wgsl", text).unwrap();
        let kernels = [builtin_kernels(), vec![composite]].concat();
        let method = |spec: &str| crate::kernel::methods::resolve(spec, &kernels).unwrap();
        let c16 = method_cost_of(&method("test.composite[line.numeric@16]")).unwrap();
        let c64 = method_cost_of(&method("test.composite[line.numeric@64]")).unwrap();
        assert_eq!((c16.loop_trips, c64.loop_trips), (Some(2 * 4), Some(2 * 16)));
        let inner = method_cost(&builtin("line.numeric"), &[16.0]).unwrap();
        assert_eq!(c16.transcendental, 2 * inner.transcendental);
        // Without an inner method: the default one, as the GPU runs it.
        let default = method_cost(&kernels.last().unwrap().clone(), &[]).unwrap();
        assert_eq!(default, method_cost_of(&method("test.composite")).unwrap());
    }

    /// Every built-in kernel at its header's defaults and, with params, at 16, 64 and 256;
    /// each composite with two inner line methods (an analytic one and a loop).
    fn pinned_methods() -> Vec<(String, OpCount)> {
        let kernels = builtin_kernels();
        let mut rows = Vec::new();
        for k in &kernels {
            rows.push((k.id.clone(), method_cost(k, &[]).unwrap()));
            if !k.params.is_empty() {
                for n in [16u32, 64, 256] {
                    let label = format!("{}@{n}", k.id);
                    rows.push((label, method_cost(k, &vec![f64::from(n); k.params.len()]).unwrap()));
                }
            }
            if k.uses_line {
                // The first analytic inner method of its target and the first with a loop.
                let of_target = || kernels.iter().filter(|i| i.target == k.uses_target && !i.uses_line);
                let analytic = of_target().find(|i| i.params.is_empty()).map(|i| i.id.clone());
                let looped = of_target()
                    .find(|i| !i.params.is_empty())
                    .map(|i| format!("{}@16", i.id));
                for inner in analytic.into_iter().chain(looped) {
                    let spec = format!("{}[{inner}]", k.id);
                    let m = crate::kernel::methods::resolve(&spec, &kernels).unwrap();
                    rows.push((spec, method_cost_of(&m).unwrap()));
                }
            }
        }
        rows
    }

    /// The counts of every built-in method, pinned: a change of the counter that moves one
    /// shows here, with the new table to compare.
    #[test]
    fn op_counts_are_the_pinned_ones() {
        let pinned = include_str!("../../tests/data/op_counts.jsonl");
        let now: String = pinned_methods()
            .into_iter()
            .map(|(method, count)| serde_json::json!({ "method": method, "count": count }).to_string() + "\n")
            .collect();
        if now != pinned {
            let first = now.lines().zip(pinned.lines()).find(|(a, b)| a != b);
            panic!("the op counts moved; first difference (now, pinned): {first:?}\nthe table now:\n{now}");
        }
    }

    /// `cargo test --release --lib cost::tests::builtin_table -- --nocapture`
    #[test]
    fn builtin_table() {
        let mut rows = Vec::new();
        for k in builtin_kernels() {
            let variants: Vec<(String, Vec<f64>)> = if k.params.is_empty() {
                vec![(k.id.clone(), Vec::new())]
            } else {
                [16u32, 64, 256]
                    .iter()
                    .map(|n| (format!("{}@{n}", k.id), vec![f64::from(*n); k.params.len()]))
                    .collect()
            };
            for (label, params) in variants {
                let c = method_cost(&k, &params).unwrap();
                assert!(c.total > 0, "{label}");
                rows.push((label, c));
            }
        }
        println!(
            "{:<22} {:>7} {:>6} {:>6} {:>6} {:>5} {:>6} {:>5} {:>7}  transcendentals",
            "method", "arith", "trans", "other", "branch", "loops", "trips", "calls", "total"
        );
        for (label, c) in rows {
            let trips = c.loop_trips.map_or("-".to_string(), |t| t.to_string());
            let fns: Vec<String> = c.transcendental_fns.iter().map(|(k, v)| format!("{k}×{v}")).collect();
            println!(
                "{label:<22} {:>7} {:>6} {:>6} {:>6} {:>5} {:>6} {:>5} {:>7}  {}",
                c.arithmetic,
                c.transcendental,
                c.other_math,
                c.branches,
                c.loops,
                trips,
                c.calls,
                c.total,
                fns.join(" ")
            );
        }
    }
}
