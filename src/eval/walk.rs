//! The one walker of naga IR: a [`Program`]'s functions evaluated over a value [`Domain`].
//!
//! The walker owns the IR's meaning, once: which expressions run on entry to a function and
//! which where an `Emit` puts them, what every expression reads, how the composite built-ins
//! decompose into scalar operations (`dot` left to right, `length = sqrt(dot(x, x))`,
//! `normalize = x · inverseSqrt(dot(x, x))`, `cross`, `determinant` by cofactors, `mix`,
//! the matrix products), and which component a scalar argument stands for. A domain gives
//! the values and each scalar operation on them:
//!
//! - the interpreter's lanes (`interp/exec.rs`): one component over a chunk of
//!   configurations in f32 or f64, execution masks for divergent control flow;
//! - the envelope's intervals (`interp/envelope.rs`): f32 intervals widened by the WGSL
//!   accuracy rules, both ways taken where a condition straddles;
//! - the compiled code (`interp/compiled/lower.rs`): Cranelift values;
//! - the op count (`cost.rs`): values with no number, each operation counted, both arms
//!   walked and the costlier kept, each loop body once and scaled by its trip count.
//!
//! Control flow is a domain capability ([`Domain::if_`], [`Domain::switch`],
//! [`Domain::loop_`], `break`, `continue`, `return`): masks and forked states are what
//! differ between the domains; each calls back into [`Walker::block`] for the blocks.
//!
//! # Adding a WGSL built-in
//! One arm in [`Walker::expr`] (for `Expression::ImageSample` / `ImageLoad`: read the image
//! and coordinate values as the other arms read theirs) that calls one new `Domain`
//! method (`fn sample(&mut self, texels: &Self::P, uv: &[Self::V]) -> R<Vec<Self::V>>`),
//! and that method in each domain. A built-in that decomposes into existing operations
//! (as `mix` does) needs the walker arm only.
//!
//! # Adding a value domain
//! One `impl Domain` (binary16 lanes: `V` a component of `half::f16` lanes, each float
//! operation rounded to f16): the values, each scalar operation, memory and the control
//! flow it runs (execution masks, as the f32 lanes). The walker, the decompositions and
//! their order come with it.

use crate::eval::program::{Const, Program};
use naga::{
    BinaryOperator as B, Block, Expression as E, Handle, Literal, MathFunction as M, RelationalFunction, ScalarKind,
    Statement as S, SwitchCase, TypeInner, UnaryOperator as U,
};

/// A value (its scalar components in declaration order, matrices column by column) or a
/// pointer.
#[derive(Clone, Debug)]
pub enum Slot<V, P> {
    Val(Vec<V>),
    Ptr(P),
}

/// A domain's slot.
pub type DSlot<D> = Slot<<D as Domain>::V, <D as Domain>::P>;

/// A domain's result.
pub type R<T, D> = Result<T, <D as Domain>::Err>;

/// A function's constant expressions' slots (None for the others).
pub type Consts<D> = Vec<Option<DSlot<D>>>;

/// An `if` statement's arms.
pub struct Arms<'a> {
    pub accept: &'a Block,
    pub reject: &'a Block,
}

/// A `loop` statement's parts.
pub struct Looping<'a> {
    pub body: &'a Block,
    pub continuing: &'a Block,
    pub break_if: Option<Handle<naga::Expression>>,
}

/// One call of a function: each expression's slot, and the return value so far.
pub struct Frame<D: Domain> {
    pub fun: Handle<naga::Function>,
    pub vals: Vec<Option<DSlot<D>>>,
    pub ret: D::Ret,
}

/// The values a kernel is evaluated on and the operations on them (module doc). Every
/// operation takes and gives one scalar component; the walker maps vectors and matrices
/// onto them in its own order.
pub trait Domain: Sized {
    /// One scalar component.
    type V: Clone;
    /// A pointer into the domain's storage.
    type P: Clone;
    /// A function's return value as it accumulates (over lanes, over forked paths).
    type Ret;
    /// Why the walk stopped.
    type Err;
    /// The caller's state across a call (its storage mark, its control state).
    type Saved;

    // ---- where the walk is

    /// Before an expression: its source line (an index into `Program::lines`) and whether
    /// an `Emit` evaluates it (else on entry to its function).
    fn at(&mut self, line: u32, emitted: bool);
    /// An error at the current expression.
    fn fail(&self, msg: String) -> Self::Err;
    /// An error in a statement.
    fn fail_statement(&self, msg: String) -> Self::Err;
    /// Whether any lane or path still runs the statements that follow.
    fn live(&self) -> bool;
    /// Before the expressions of an `Emit`.
    fn emit(&mut self) {}

    // ---- values

    /// A literal; `written`: an f32 literal's written digits (or why they cannot be read).
    fn literal(&mut self, lit: Literal, written: &Result<f64, String>) -> R<Self::V, Self>;
    /// A module constant of type `ty`.
    fn constant(&mut self, c: &Const, ty: Handle<naga::Type>) -> R<Vec<Self::V>, Self>;
    /// An override's value, of type `ty`.
    fn override_value(&mut self, v: f64, ty: &TypeInner) -> R<Self::V, Self>;
    fn zero(&mut self, ty: Handle<naga::Type>) -> R<Vec<Self::V>, Self>;
    /// A float constant the walker's decompositions use (`mix`'s 1).
    fn float(&mut self, x: f64) -> Self::V;
    /// An expression's value once made (`float`: of float type).
    fn settle(&mut self, _v: &mut [Self::V], _float: bool) {}

    // ---- operations

    fn add(&mut self, a: &Self::V, b: &Self::V) -> R<Self::V, Self>;
    fn sub(&mut self, a: &Self::V, b: &Self::V) -> R<Self::V, Self>;
    fn mul(&mut self, a: &Self::V, b: &Self::V) -> R<Self::V, Self>;
    fn div(&mut self, a: &Self::V, b: &Self::V) -> R<Self::V, Self>;
    /// Float `%`.
    fn rem(&mut self, a: &Self::V, b: &Self::V) -> R<Self::V, Self>;
    /// Integer arithmetic, bitwise operators and shifts (booleans' `& | ^` too), on operands
    /// of kind `kind`.
    fn int(&mut self, op: B, a: &Self::V, b: &Self::V, kind: Option<ScalarKind>) -> R<Self::V, Self>;
    /// `== != < <= > >=` on operands of kind `kind`.
    fn compare(&mut self, op: B, a: &Self::V, b: &Self::V, kind: Option<ScalarKind>) -> R<Self::V, Self>;
    /// `&&`, `||`.
    fn logical(&mut self, op: B, a: &Self::V, b: &Self::V) -> R<Self::V, Self>;
    /// `kind`: the result's.
    fn unary(&mut self, op: U, a: &Self::V, kind: Option<ScalarKind>) -> R<Self::V, Self>;
    fn select(&mut self, c: &Self::V, a: &Self::V, b: &Self::V) -> R<Self::V, Self>;
    fn relational(&mut self, f: RelationalFunction, a: &[Self::V]) -> R<Vec<Self::V>, Self>;
    fn convert(&mut self, to: ScalarKind, from: Option<ScalarKind>, a: &Self::V) -> R<Self::V, Self>;
    /// A component-wise built-in of one argument (`abs`, `sqrt`, `sin`, `floor`, …);
    /// `kind`: its argument's.
    fn math1(&mut self, f: M, a: &Self::V, kind: Option<ScalarKind>) -> R<Self::V, Self>;
    /// Of two (`min`, `max`, `atan2`, `pow`, `step`).
    fn math2(&mut self, f: M, a: &Self::V, b: &Self::V, kind: Option<ScalarKind>) -> R<Self::V, Self>;
    /// Of three (`clamp`, `fma`).
    fn math3(&mut self, f: M, a: &Self::V, b: &Self::V, c: &Self::V, kind: Option<ScalarKind>) -> R<Self::V, Self>;

    /// A built-in the domain evaluates in its own way (not by the walker's decomposition),
    /// or None. `at`: its first argument's type; `ty`: its result's.
    fn math_special(
        &mut self,
        _f: M,
        _at: &TypeInner,
        _ty: &TypeInner,
        _args: [Option<&[Self::V]>; 3],
    ) -> Option<R<Vec<Self::V>, Self>> {
        None
    }
    /// An expression the walker gives no meaning to (a bitcast, a derivative, an image
    /// read, an atomic's result), for a domain that can stand for its value of type `ty`
    /// without one (the cost); None: the walk stops, unsupported.
    fn opaque(&mut self, _e: &E, _ty: &TypeInner) -> Option<R<Vec<Self::V>, Self>> {
        None
    }
    /// A statement the walker does not run (`discard`, barriers, atomics, image stores),
    /// likewise.
    fn opaque_statement(_w: &mut Walker<'_, Self>, _fr: &mut Frame<Self>, _st: &S) -> Option<R<(), Self>> {
        None
    }
    /// `dot(x, x)`.
    fn dot_self(&mut self, a: &[Self::V]) -> R<Self::V, Self> {
        dot(self, a, a)
    }
    /// `length(x)`: `abs` of a scalar, else `sqrt(dot(x, x))`.
    fn length(&mut self, a: &[Self::V]) -> R<Self::V, Self> {
        if a.len() == 1 {
            return self.math1(M::Abs, &a[0], Some(ScalarKind::Float));
        }
        let d = self.dot_self(a)?;
        self.math1(M::Sqrt, &d, Some(ScalarKind::Float))
    }
    /// `normalize(x)`: `x · inverseSqrt(dot(x, x))`, as drivers lower it.
    fn normalize(&mut self, a: &[Self::V]) -> R<Vec<Self::V>, Self> {
        let d = dot(self, a, a)?;
        let r = self.math1(M::InverseSqrt, &d, Some(ScalarKind::Float))?;
        a.iter().map(|x| self.mul(x, &r)).collect()
    }
    /// Whether `x * x` of one float value is a square (each component's own operation)
    /// rather than a product.
    fn squares(&self) -> bool {
        false
    }
    fn square(&mut self, a: &Self::V) -> R<Self::V, Self> {
        self.mul(a, a)
    }

    // ---- memory

    /// A new local variable of type `ty`, zeroed.
    fn local(&mut self, ty: Handle<naga::Type>) -> R<Self::P, Self>;
    /// Storage for global `g` holding `v`.
    fn bind(&mut self, g: Handle<naga::GlobalVariable>, v: Vec<Self::V>);
    /// A pointer to global `g` (of `len` components).
    fn global(&mut self, g: Handle<naga::GlobalVariable>, len: usize) -> R<Self::P, Self>;
    /// `len` components at offset `off` of what `p` points at.
    fn child(&mut self, p: &Self::P, off: usize, len: usize) -> Self::P;
    /// The components the storage `p` points into holds.
    fn held(&self, p: &Self::P) -> usize;
    /// Element `idx` (clamped to `count`) of `stride` components each.
    fn index(&mut self, p: &Self::P, idx: &Self::V, count: usize, stride: usize, signed: bool) -> R<Self::P, Self>;
    /// Element `idx` of a value.
    fn index_value(
        &mut self,
        v: &[Self::V],
        idx: &Self::V,
        count: usize,
        stride: usize,
        signed: bool,
    ) -> R<Vec<Self::V>, Self>;
    fn load(&mut self, p: &Self::P) -> R<Vec<Self::V>, Self>;
    /// A `Store` (where the current lanes or paths run).
    fn store(&mut self, p: &Self::P, v: &[Self::V]) -> R<(), Self>;
    /// A local variable's initialiser, on entry.
    fn init(&mut self, p: &Self::P, v: Vec<Self::V>);

    // ---- calls and control flow

    /// On entry to a function: the caller's state, and the callee's return slot.
    fn enter(&mut self, result: Option<Handle<naga::Type>>) -> R<(Self::Saved, Self::Ret), Self>;
    /// On leaving it: the caller's state again, and the return value.
    fn leave(&mut self, saved: Self::Saved, ret: Self::Ret) -> Option<Vec<Self::V>>;
    /// On leaving it by an error: the caller's control state again (a domain that goes on
    /// after an error, on another path, needs its `break` and `continue` targets).
    fn unwind(&mut self, _saved: Self::Saved) {}
    /// The values of `fun`'s constant expressions, kept from an earlier call.
    fn cached(&mut self, _fun: Handle<naga::Function>) -> Option<Consts<Self>> {
        None
    }
    /// After `fun`'s entry: its constant expressions' values, to keep for its next call.
    fn keep(&mut self, _fun: Handle<naga::Function>, _consts: impl FnOnce() -> Consts<Self>) {}
    fn if_(w: &mut Walker<'_, Self>, fr: &mut Frame<Self>, cond: &Self::V, arms: Arms) -> R<(), Self>;
    fn switch(w: &mut Walker<'_, Self>, fr: &mut Frame<Self>, selector: &Self::V, cases: &[SwitchCase]) -> R<(), Self>;
    fn loop_(w: &mut Walker<'_, Self>, fr: &mut Frame<Self>, l: Looping) -> R<(), Self>;
    fn break_(&mut self) -> R<(), Self>;
    fn continue_(&mut self) -> R<(), Self>;
    fn return_(&mut self, ret: &mut Self::Ret, v: Option<&[Self::V]>) -> R<(), Self>;
}

/// `a · b`, left to right.
pub fn dot<D: Domain>(d: &mut D, a: &[D::V], b: &[D::V]) -> R<D::V, D> {
    let mut acc = d.mul(&a[0], &b[0])?;
    for k in 1..a.len() {
        let t = d.mul(&a[k], &b[k])?;
        acc = d.add(&acc, &t)?;
    }
    Ok(acc)
}

/// The component-wise built-ins of one argument the walker evaluates through
/// [`Domain::math1`].
pub const MATH1: &[M] = &[
    M::Abs,
    M::Sqrt,
    M::InverseSqrt,
    M::Sin,
    M::Cos,
    M::Tan,
    M::Asin,
    M::Acos,
    M::Atan,
    M::Exp,
    M::Exp2,
    M::Log,
    M::Log2,
    M::Floor,
    M::Ceil,
    M::Trunc,
    M::Round,
    M::Fract,
    M::Saturate,
    M::Sign,
];
/// Of two, through [`Domain::math2`].
pub const MATH2: &[M] = &[M::Min, M::Max, M::Atan2, M::Pow, M::Step];
/// Of three, through [`Domain::math3`].
pub const MATH3: &[M] = &[M::Clamp, M::Fma];

/// Whether the walker evaluates built-in `f` (first argument of type `at`): component-wise
/// ([`MATH1`], [`MATH2`], [`MATH3`]) or by its decomposition into them and the operators
/// (`mix`, `dot`, `cross`, `length`, `distance`, `normalize`, `determinant` of 2×2 and 3×3,
/// `transpose`). The others reach [`Domain::math_special`] only.
pub fn evaluates(f: M, at: &TypeInner) -> bool {
    let small = matches!(at, TypeInner::Matrix { columns, .. } if (*columns as u8) <= 3);
    MATH1.contains(&f)
        || MATH2.contains(&f)
        || MATH3.contains(&f)
        || matches!(
            f,
            M::Mix | M::Dot | M::Cross | M::Length | M::Distance | M::Normalize | M::Transpose
        )
        || (f == M::Determinant && small)
}

/// Component `i` of an argument, a scalar standing for every component.
fn pick<V>(v: &[V], i: usize) -> &V {
    &v[if v.len() == 1 { 0 } else { i }]
}

/// The walker: a program and a domain.
pub struct Walker<'p, D> {
    pub p: &'p Program,
    pub d: D,
}

impl<'p, D: Domain> Walker<'p, D> {
    pub fn new(p: &'p Program, d: D) -> Walker<'p, D> {
        Walker { p, d }
    }

    /// Runs `method` on `scene` after binding the globals as the entry point does
    /// (compose.rs): `ll_texels` the texels, `ll_ltc` the LTC tables where a function reads
    /// them, each private global its initialiser, `ll_scene` the scene and `Minv` its part.
    pub fn run(
        &mut self,
        scene: Vec<D::V>,
        texels: Vec<D::V>,
        ltc: impl FnOnce(&mut D) -> Vec<D::V>,
    ) -> R<Option<Vec<D::V>>, D> {
        let p = self.p;
        let mut texels = Some(texels);
        let mut ltc = Some(ltc);
        for (h, g) in p.module.global_variables.iter() {
            if g.name.as_deref() == Some("ll_texels") {
                let t = texels.take().unwrap_or_default();
                self.d.bind(h, t);
                continue;
            }
            if g.name.as_deref() == Some("ll_ltc") {
                if let Some(f) = ltc.take().filter(|_| p.reads_ltc) {
                    let t = f(&mut self.d);
                    self.d.bind(h, t);
                }
                continue;
            }
            if g.space != naga::AddressSpace::Private {
                continue;
            }
            let v = match g.name.as_deref() {
                Some("ll_scene") => scene.clone(),
                Some("Minv") => {
                    let (off, len) = p.scene_minv;
                    scene[off..off + len].to_vec()
                }
                _ => match g.init {
                    Some(init) => self.d.constant(&p.global_consts[init.index()], g.ty)?,
                    None => self.d.zero(g.ty)?,
                },
            };
            self.d.bind(h, v);
        }
        self.call(p.method, vec![Slot::Val(scene)])
    }

    fn inner(&self, fun: Handle<naga::Function>, h: Handle<naga::Expression>) -> &'p TypeInner {
        self.p.info[fun][h].ty.inner_with(&self.p.module.types)
    }

    /// The value of expression `h`.
    pub fn val<'f>(&self, fr: &'f Frame<D>, h: Handle<naga::Expression>) -> R<&'f [D::V], D> {
        match fr.vals[h.index()].as_ref() {
            Some(Slot::Val(v)) => Ok(v),
            Some(Slot::Ptr(_)) => Err(self.d.fail(format!("internal: expression {h:?} is a pointer"))),
            None => Err(self.d.fail("value used before it is computed".into())),
        }
    }

    fn ptr<'f>(&self, fr: &'f Frame<D>, h: Handle<naga::Expression>) -> R<&'f D::P, D> {
        match fr.vals[h.index()].as_ref() {
            Some(Slot::Ptr(p)) => Ok(p),
            _ => Err(self.d.fail("not a pointer".into())),
        }
    }

    /// A call: the expressions no `Emit` covers (arguments, variables, constants) first,
    /// then the locals' initialisers, then the body.
    pub fn call(&mut self, fun: Handle<naga::Function>, args: Vec<DSlot<D>>) -> R<Option<Vec<D::V>>, D> {
        let f = &self.p.module.functions[fun];
        let (saved, ret) = self.d.enter(f.result.as_ref().map(|r| r.ty))?;
        let mut fr = Frame {
            fun,
            vals: vec![None; f.expressions.len()],
            ret,
        };
        match self.enter_and_run(&mut fr, args) {
            Ok(()) => Ok(self.d.leave(saved, fr.ret)),
            Err(e) => {
                self.d.unwind(saved);
                Err(e)
            }
        }
    }

    fn enter_and_run(&mut self, fr: &mut Frame<D>, args: Vec<DSlot<D>>) -> R<(), D> {
        let p = self.p;
        let fun = fr.fun;
        let f = &p.module.functions[fun];
        let mut locals = Vec::with_capacity(f.local_variables.len());
        for (_, lv) in f.local_variables.iter() {
            locals.push(self.d.local(lv.ty)?);
        }
        let fp = &p.funs[fun.index()];
        let cached = self.d.cached(fun);
        for (h, e) in f.expressions.iter() {
            if fp.emitted[h.index()] || matches!(e, E::CallResult(_)) {
                continue;
            }
            if let (Some(c), true) = (&cached, fp.constant[h.index()]) {
                fr.vals[h.index()] = c[h.index()].clone();
                continue;
            }
            let v = match e {
                E::FunctionArgument(i) => args[*i as usize].clone(),
                E::LocalVariable(lv) => Slot::Ptr(locals[lv.index()].clone()),
                _ => {
                    self.d.at(fp.line[h.index()], false);
                    self.expr(fr, h)?;
                    continue;
                }
            };
            fr.vals[h.index()] = Some(v);
        }
        self.d.keep(fun, || {
            cached.unwrap_or_else(|| {
                let constant = |i: usize| fp.constant[i].then(|| fr.vals[i].clone()).flatten();
                (0..fr.vals.len()).map(constant).collect()
            })
        });
        for (lv, v) in f.local_variables.iter() {
            if let Some(init) = v.init {
                // naga may leave a constant initializer (`var c = vec3<f32>(0.0);`, GLSL's
                // `mat3 m = mat3(…)` with its columns) inside an `Emit` of the body: it is
                // needed now, before the body runs.
                self.expr_with_operands(fr, init)?;
                let val = self.val(fr, init)?.to_vec();
                self.d.init(&locals[lv.index()], val);
            }
        }
        self.block(fr, &f.body)
    }

    /// Evaluates `h`, after the operands it reads that are not computed yet (in handle
    /// order, which naga keeps operands-first), without recursion.
    fn expr_with_operands(&mut self, fr: &mut Frame<D>, h: Handle<naga::Expression>) -> R<(), D> {
        let p = self.p;
        let f = &p.module.functions[fr.fun];
        let mut needed = vec![false; h.index() + 1];
        needed[h.index()] = true;
        let upto: Vec<_> = f.expressions.iter().take(h.index() + 1).collect();
        for &(i, e) in upto.iter().rev() {
            if !needed[i.index()] || fr.vals[i.index()].is_some() {
                continue;
            }
            let mut read = |o: Handle<naga::Expression>| {
                if o.index() < i.index() {
                    needed[o.index()] = true;
                }
            };
            match e {
                E::Compose { components, .. } => components.iter().for_each(|c| read(*c)),
                E::Splat { value: x, .. }
                | E::Swizzle { vector: x, .. }
                | E::AccessIndex { base: x, .. }
                | E::Unary { expr: x, .. }
                | E::As { expr: x, .. }
                | E::Load { pointer: x } => read(*x),
                E::Access { base: a, index: b } | E::Binary { left: a, right: b, .. } => {
                    read(*a);
                    read(*b);
                }
                E::Select {
                    condition,
                    accept,
                    reject,
                } => [condition, accept, reject].into_iter().for_each(|x| read(*x)),
                E::Math {
                    arg, arg1, arg2, arg3, ..
                } => [Some(arg), arg1.as_ref(), arg2.as_ref(), arg3.as_ref()]
                    .into_iter()
                    .flatten()
                    .for_each(|x| read(*x)),
                _ => {}
            }
        }
        let lines = &p.funs[fr.fun.index()].line;
        for &(i, _) in &upto {
            if needed[i.index()] && fr.vals[i.index()].is_none() {
                self.d.at(lines[i.index()], false);
                self.expr(fr, i)?;
            }
        }
        Ok(())
    }

    /// Runs `block` while some lane or path is live.
    pub fn block(&mut self, fr: &mut Frame<D>, block: &Block) -> R<(), D> {
        for st in block.iter() {
            if !self.d.live() {
                return Ok(());
            }
            match st {
                S::Emit(range) => {
                    self.d.emit();
                    let lines = &self.p.funs[fr.fun.index()].line;
                    for h in range.clone() {
                        self.d.at(lines[h.index()], true);
                        self.expr(fr, h)?;
                    }
                }
                S::Block(b) => self.block(fr, b)?,
                S::If {
                    condition,
                    accept,
                    reject,
                } => {
                    let c = self.val(fr, *condition)?[0].clone();
                    D::if_(self, fr, &c, Arms { accept, reject })?;
                }
                S::Switch { selector, cases } => {
                    let s = self.val(fr, *selector)?[0].clone();
                    D::switch(self, fr, &s, cases)?;
                }
                S::Loop {
                    body,
                    continuing,
                    break_if,
                } => {
                    let l = Looping {
                        body,
                        continuing,
                        break_if: *break_if,
                    };
                    D::loop_(self, fr, l)?
                }
                S::Break => self.d.break_()?,
                S::Continue => self.d.continue_()?,
                S::Return { value } => {
                    let v = match value {
                        Some(v) => Some(self.val(fr, *v)?.to_vec()),
                        None => None,
                    };
                    self.d.return_(&mut fr.ret, v.as_deref())?;
                }
                S::Store { pointer, value } => {
                    let ptr = self.ptr(fr, *pointer)?.clone();
                    let v = self.val(fr, *value)?;
                    self.d.store(&ptr, v)?;
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
                                .ok_or_else(|| self.d.fail_statement("argument not computed".into()))
                        })
                        .collect::<Result<Vec<_>, _>>()?;
                    let r = self.call(*function, args)?;
                    if let (Some(h), Some(r)) = (result, r) {
                        fr.vals[h.index()] = Some(Slot::Val(r));
                    }
                }
                other => match D::opaque_statement(self, fr, other) {
                    Some(r) => r?,
                    None => return Err(self.d.fail_statement(format!("unsupported statement {other:?}"))),
                },
            }
        }
        Ok(())
    }

    /// Evaluates expression `h` into its slot.
    fn expr(&mut self, fr: &mut Frame<D>, h: Handle<naga::Expression>) -> R<(), D> {
        let p = self.p;
        let fun = fr.fun;
        let f = &p.module.functions[fun];
        let ty = self.inner(fun, h);
        let kind = ty.scalar_kind();
        let float = kind == Some(ScalarKind::Float);
        let vals = match &f.expressions[h] {
            E::Literal(l) => vec![self.d.literal(*l, &p.funs[fun.index()].lit64[h.index()])?],
            E::Constant(c) => {
                let k = &p.module.constants[*c];
                self.d.constant(&p.global_consts[k.init.index()], k.ty)?
            }
            E::Override(o) => vec![self.d.override_value(p.overrides[o.index()], ty)?],
            E::ZeroValue(t) => self.d.zero(*t)?,
            E::Compose { components, .. } => {
                let mut out = Vec::new();
                for c in components {
                    out.extend(self.val(fr, *c)?.iter().cloned());
                }
                out
            }
            E::Splat { size, value } => vec![self.val(fr, *value)?[0].clone(); *size as usize],
            E::Swizzle { size, vector, pattern } => {
                let v = self.val(fr, *vector)?;
                pattern[..*size as usize]
                    .iter()
                    .map(|c| v[*c as usize].clone())
                    .collect()
            }
            E::AccessIndex { base, index } => {
                let bty = self.inner(fun, *base);
                match fr.vals[base.index()].as_ref() {
                    Some(Slot::Ptr(ptr)) => {
                        let (off, len) = p.child(&p.pointee(bty), *index as usize);
                        let child = self.d.child(ptr, off, len);
                        fr.vals[h.index()] = Some(Slot::Ptr(child));
                        return Ok(());
                    }
                    Some(Slot::Val(v)) => {
                        let (off, len) = p.child(bty, *index as usize);
                        v[off..off + len].to_vec()
                    }
                    None => return Err(self.d.fail("base not computed".into())),
                }
            }
            E::Access { base, index } => {
                let bty = self.inner(fun, *base);
                let signed = self.inner(fun, *index).scalar_kind() == Some(ScalarKind::Sint);
                let idx = self.val(fr, *index)?[0].clone();
                match fr.vals[base.index()].as_ref() {
                    Some(Slot::Ptr(ptr)) => {
                        let (count, stride) = p.elements(&p.pointee(bty));
                        // A runtime-sized array's length is what its storage holds.
                        let count = match count {
                            0 => (self.d.held(ptr) / stride.max(1)).max(1),
                            n => n,
                        };
                        let elem = self.d.index(ptr, &idx, count, stride, signed)?;
                        fr.vals[h.index()] = Some(Slot::Ptr(elem));
                        return Ok(());
                    }
                    Some(Slot::Val(v)) => {
                        let (count, stride) = p.elements(bty);
                        self.d.index_value(v, &idx, count, stride, signed)?
                    }
                    None => return Err(self.d.fail("base not computed".into())),
                }
            }
            E::GlobalVariable(g) => {
                let len = p.flat[p.module.global_variables[*g].ty.index()];
                let ptr = self.d.global(*g, len)?;
                fr.vals[h.index()] = Some(Slot::Ptr(ptr));
                return Ok(());
            }
            E::Load { pointer } => {
                let ptr = self.ptr(fr, *pointer)?;
                self.d.load(ptr)?
            }
            E::Unary { op, expr } => {
                let a = self.val(fr, *expr)?;
                a.iter().map(|x| self.d.unary(*op, x, kind)).collect::<Result<_, _>>()?
            }
            E::Binary { op, left, right } => {
                let lt = self.inner(fun, *left);
                let rt = self.inner(fun, *right);
                let (a, b) = (self.val(fr, *left)?, self.val(fr, *right)?);
                if left == right && *op == B::Multiply && float && a.len() == b.len() && self.d.squares() {
                    // One value times itself: a square per component.
                    a.iter().map(|x| self.d.square(x)).collect::<Result<_, _>>()?
                } else {
                    self.binary(*op, lt, rt, a, b)?
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
                (0..a.len())
                    .map(|k| self.d.select(&c[k.min(c.len() - 1)], &a[k], &r[k]))
                    .collect::<Result<_, _>>()?
            }
            E::Relational { fun: rf, argument } => {
                let a = self.val(fr, *argument)?;
                self.d.relational(*rf, a)?
            }
            E::Math {
                fun: mf,
                arg,
                arg1,
                arg2,
                ..
            } => {
                let a = self.val(fr, *arg)?;
                let b = arg1.map(|x| self.val(fr, x)).transpose()?;
                let c = arg2.map(|x| self.val(fr, x)).transpose()?;
                let at = self.inner(fun, *arg);
                if *mf == M::Dot && *arg1 == Some(*arg) {
                    vec![self.d.dot_self(a)?]
                } else {
                    self.math(*mf, at, ty, a, b, c)?
                }
            }
            E::As {
                expr,
                kind: to,
                convert,
            } => {
                if convert.is_none() {
                    match self.d.opaque(&f.expressions[h], ty) {
                        Some(v) => v?,
                        None => return Err(self.d.fail("bitcast is not supported".into())),
                    }
                } else {
                    let from = self.inner(fun, *expr).scalar_kind();
                    let a = self.val(fr, *expr)?;
                    a.iter()
                        .map(|x| self.d.convert(*to, from, x))
                        .collect::<Result<_, _>>()?
                }
            }
            E::CallResult(_) => return Err(self.d.fail("call result read before the call".into())),
            other => match self.d.opaque(other, ty) {
                Some(v) => v?,
                None => return Err(self.d.fail(format!("unsupported expression {other:?}"))),
            },
        };
        let mut vals = vals;
        self.d.settle(&mut vals, float);
        fr.vals[h.index()] = Some(Slot::Val(vals));
        Ok(())
    }

    fn binary(&mut self, op: B, lt: &TypeInner, rt: &TypeInner, a: &[D::V], b: &[D::V]) -> R<Vec<D::V>, D> {
        use TypeInner as T;
        let d = &mut self.d;
        let k = lt.scalar_kind();
        let float = k == Some(ScalarKind::Float);
        match (op, lt, rt) {
            (B::Multiply, T::Matrix { columns, rows, .. }, T::Vector { .. }) => {
                let r = *rows as usize;
                let mut out = Vec::new();
                for i in 0..r {
                    let mut acc = d.mul(&a[i], &b[0])?;
                    for j in 1..*columns as usize {
                        let t = d.mul(&a[j * r + i], &b[j])?;
                        acc = d.add(&acc, &t)?;
                    }
                    out.push(acc);
                }
                return Ok(out);
            }
            (B::Multiply, T::Vector { .. }, T::Matrix { columns, rows, .. }) => {
                let r = *rows as usize;
                return (0..*columns as usize)
                    .map(|j| dot(d, a, &b[j * r..(j + 1) * r]))
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
                        let mut acc = d.mul(&a[i], &b[j * ac])?;
                        for kk in 1..ac {
                            let t = d.mul(&a[kk * ar + i], &b[j * ac + kk])?;
                            acc = d.add(&acc, &t)?;
                        }
                        out.push(acc);
                    }
                }
                return Ok(out);
            }
            _ => {}
        }
        let len = a.len().max(b.len());
        let mut out = Vec::with_capacity(len);
        for i in 0..len {
            let (x, y) = (pick(a, i), pick(b, i));
            out.push(match op {
                B::Add if float => d.add(x, y)?,
                B::Subtract if float => d.sub(x, y)?,
                B::Multiply if float => d.mul(x, y)?,
                B::Divide if float => d.div(x, y)?,
                B::Modulo if float => d.rem(x, y)?,
                B::Equal | B::NotEqual | B::Less | B::LessEqual | B::Greater | B::GreaterEqual => {
                    d.compare(op, x, y, k)?
                }
                B::LogicalAnd | B::LogicalOr => d.logical(op, x, y)?,
                _ => d.int(op, x, y, k)?,
            });
        }
        Ok(out)
    }

    fn math(
        &mut self,
        f: M,
        at: &TypeInner,
        ty: &TypeInner,
        a: &[D::V],
        b: Option<&[D::V]>,
        c: Option<&[D::V]>,
    ) -> R<Vec<D::V>, D> {
        let kind = at.scalar_kind();
        let d = &mut self.d;
        if let Some(v) = d.math_special(f, at, ty, [Some(a), b, c]) {
            return v;
        }
        fn need<'v, D: Domain>(d: &D, f: M, v: Option<&'v [D::V]>) -> R<&'v [D::V], D> {
            v.ok_or_else(|| d.fail(format!("{f:?}: missing argument")))
        }
        Ok(match f {
            f if MATH1.contains(&f) => a.iter().map(|x| d.math1(f, x, kind)).collect::<Result<_, _>>()?,
            f if MATH2.contains(&f) => {
                let b = need(d, f, b)?;
                (0..a.len())
                    .map(|i| d.math2(f, pick(a, i), pick(b, i), kind))
                    .collect::<Result<_, _>>()?
            }
            f if MATH3.contains(&f) => {
                let (b, c) = (need(d, f, b)?, need(d, f, c)?);
                (0..a.len())
                    .map(|i| d.math3(f, pick(a, i), pick(b, i), pick(c, i), kind))
                    .collect::<Result<_, _>>()?
            }
            M::Mix => {
                // mix(x, y, t) = x·(1 − t) + y·t
                let (b, c) = (need(d, f, b)?, need(d, f, c)?);
                let one = d.float(1.0);
                (0..a.len())
                    .map(|i| {
                        let (x, y, z) = (pick(a, i), pick(b, i), pick(c, i));
                        let u = d.sub(&one, z)?;
                        let p = d.mul(x, &u)?;
                        let q = d.mul(y, z)?;
                        d.add(&p, &q)
                    })
                    .collect::<Result<_, _>>()?
            }
            M::Dot => {
                let b = need(d, f, b)?;
                vec![dot(d, a, b)?]
            }
            M::Cross => {
                let b = need(d, f, b)?;
                let mut out = Vec::new();
                for (i, j) in [(1, 2), (2, 0), (0, 1)] {
                    let p = d.mul(&a[i], &b[j])?;
                    let q = d.mul(&a[j], &b[i])?;
                    out.push(d.sub(&p, &q)?);
                }
                out
            }
            M::Length => {
                if kind != Some(ScalarKind::Float) {
                    return Err(d.fail("length of a non-float".into()));
                }
                vec![d.length(a)?]
            }
            M::Distance => {
                let b = need(d, f, b)?;
                let diff = (0..a.len())
                    .map(|i| d.sub(&a[i], &b[i]))
                    .collect::<Result<Vec<_>, _>>()?;
                let dd = d.dot_self(&diff)?;
                vec![d.math1(M::Sqrt, &dd, kind)?]
            }
            M::Normalize => d.normalize(a)?,
            M::Determinant => {
                let m = a;
                match m.len() {
                    4 => {
                        let p = d.mul(&m[0], &m[3])?;
                        let q = d.mul(&m[2], &m[1])?;
                        vec![d.sub(&p, &q)?]
                    }
                    9 => {
                        // m[c][r] = m[3c + r]; cofactor expansion along the first column.
                        let e = |c: usize, r: usize| &m[3 * c + r];
                        let minor = |d: &mut D, c1: usize, c2: usize, r1: usize, r2: usize| -> R<D::V, D> {
                            let p = d.mul(e(c1, r1), e(c2, r2))?;
                            let q = d.mul(e(c2, r1), e(c1, r2))?;
                            d.sub(&p, &q)
                        };
                        let m0 = minor(d, 1, 2, 1, 2)?;
                        let m1 = minor(d, 1, 2, 0, 2)?;
                        let m2 = minor(d, 1, 2, 0, 1)?;
                        let t0 = d.mul(e(0, 0), &m0)?;
                        let t1 = d.mul(e(0, 1), &m1)?;
                        let t2 = d.mul(e(0, 2), &m2)?;
                        let s = d.sub(&t0, &t1)?;
                        vec![d.add(&s, &t2)?]
                    }
                    n => return Err(d.fail(format!("determinant of a {n}-component matrix"))),
                }
            }
            M::Transpose => {
                let TypeInner::Matrix { columns, rows, .. } = at else {
                    return Err(d.fail("transpose of a non-matrix".into()));
                };
                let (c, r) = (*columns as usize, *rows as usize);
                // The result has r columns of c rows: out[i][j] = in[j][i].
                (0..r)
                    .flat_map(|i| (0..c).map(move |j| (i, j)))
                    .map(|(i, j)| a[j * r + i].clone())
                    .collect()
            }
            other => return Err(d.fail(format!("math function {other:?} is not supported"))),
        })
    }
}
