//! naga IR → Cranelift IR: one configuration per call ([`Lower::block`], control flow as
//! branches), or several with the interpreter's execution masks ([`Lower::lblock`]): in
//! SIMD vectors (f32 as F32X4, f64 as F64X2; one or more vectors per call), or interleaved
//! scalar lanes.
//!
//! The interpreter (`../exec.rs`) is the specification; this file mirrors it operation by
//! operation, scalar by scalar, in the same order:
//!
//! - every float operation in the mode's type (f32 ops are IEEE single, correctly rounded,
//!   never contracted into an fma: Cranelift does not fuse), transcendentals and `min`/`max`
//!   through the shims the interpreter calls (`shims.rs`);
//! - integers as i32 with WGSL's rules as `exec::int_op` has them (wrapping, `x / 0 = x`,
//!   `x % 0 = 0`, shifts modulo 32), booleans as i8 0/1;
//! - control flow as branches (one configuration takes one path, as one lane of the
//!   interpreter's mask does); loops count their iterations and leave through a status of 1
//!   past the interpreter's 2^24, never with a value;
//! - every call inlined; locals and private globals as SSA variables; dynamic indices
//!   clamped as the interpreter clamps them and resolved by a chain of selects.
//!
//! Anything else is an error naming the construct: the caller falls back to the
//! interpreter for that kernel.

use super::super::{Mode, Program};
use super::shims::{shim, F};
use cranelift_codegen::ir::condcodes::{FloatCC, IntCC};
use cranelift_codegen::ir::{types, AbiParam, Block, InstBuilder, MemFlagsData, SigRef, Signature, Type, Value};
use cranelift_codegen::isa::CallConv;
use cranelift_codegen::settings::{self, Configurable};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext, Variable};
use cranelift_module::Module;
use naga::{
    BinaryOperator as B, Expression as E, Handle, MathFunction as M, ScalarKind, Statement as S, TypeInner,
    UnaryOperator as U,
};
use std::collections::HashMap;

/// The compiled kernel: `scene` points at the Scene's components as f64 (rounded to f32
/// in the f32 mode, as the interpreter's lanes read them), `out` receives the result.
/// Returns 0, or 1 when a loop ran past the limit.
pub(super) type Entry = unsafe extern "C" fn(scene: *const f64, out: *mut f64) -> u32;

/// The interpreter's loop limit (`exec.rs`): more iterations than this are an error.
const LOOP_LIMIT: i64 = 1 << 24;
/// Inlined calls deeper than this are refused (WGSL has no recursion; this bounds size).
const MAX_DEPTH: usize = 16;

/// Native code and the module that owns its memory.
pub(super) struct Native {
    _module: cranelift_jit::JITModule,
    pub entry: Entry,
    /// Configurations per call: `scene` holds this many scenes, `out` this many results.
    pub per_call: usize,
}

// SAFETY: the module's code memory is finalized (read-and-execute) and never changed
// again; `entry` reads only its arguments and calls pure shims, so calls from several
// threads at once are safe. The module is only kept to keep that memory mapped.
unsafe impl Send for Native {}
unsafe impl Sync for Native {}

/// Configurations in one 128-bit vector on the SIMD path: 4 f32 (F32X4) or 2 f64 (F64X2).
pub(super) fn simd_width(mode: Mode) -> usize {
    match mode {
        Mode::F32 => 4,
        Mode::F64 => 2,
    }
}

/// Compiles `method` of `p` in `mode` for `lanes` configurations per call (1: the
/// one-configuration path; more: the lane path, each lane's values side by side), or with
/// `simd` for `lanes` vectors of [`simd_width`] configurations per call in vector registers
/// (the vectors' operations side by side as the lane path's), or says what it cannot compile.
pub(super) fn compile(p: &Program, mode: Mode, lanes: usize, simd: bool) -> Result<Native, String> {
    if lanes == 0 {
        return Err("no lanes".into());
    }
    let mut flags = settings::builder();
    let set = |f: &mut settings::Builder, k: &str, v: &str| f.set(k, v).map_err(|e| format!("cranelift {k}: {e}"));
    set(&mut flags, "opt_level", "speed")?;
    set(&mut flags, "is_pic", "false")?;
    set(&mut flags, "use_colocated_libcalls", "false")?;
    let isa = cranelift_native::builder()
        .map_err(|e| format!("no native code for this machine: {e}"))?
        .finish(settings::Flags::new(flags))
        .map_err(|e| format!("cranelift: {e}"))?;
    let mut module = cranelift_jit::JITModule::new(cranelift_jit::JITBuilder::with_isa(
        isa,
        cranelift_module::default_libcall_names(),
    ));
    let ptr = module.target_config().pointer_type();
    let mut sig = module.make_signature();
    sig.params.push(AbiParam::new(ptr));
    sig.params.push(AbiParam::new(ptr));
    sig.returns.push(AbiParam::new(types::I32));
    let id = module
        .declare_function("method", cranelift_module::Linkage::Local, &sig)
        .map_err(|e| format!("cranelift: {e}"))?;
    let mut ctx = module.make_context();
    ctx.func.signature = sig;
    let mut fctx = FunctionBuilderContext::new();
    let frontend = module.target_config();
    {
        let b = FunctionBuilder::new(&mut ctx.func, &mut fctx);
        let mut l = Lower {
            p,
            mode,
            b,
            stores: Vec::new(),
            globals: vec![None; p.module.global_variables.len()],
            targets: Vec::new(),
            lanes,
            simd,
            lane: 0,
            cur: Vec::new(),
            ltargets: Vec::new(),
            loops: 0,
            open: true,
            fail: None,
            sigs: HashMap::new(),
            depth: 0,
            memo: HashMap::new(),
            ptr,
            cc: frontend.default_call_conv,
        };
        l.entry()?;
        l.b.seal_all_blocks();
        l.b.finalize(frontend);
    }
    module
        .define_function(id, &mut ctx)
        .map_err(|e| format!("cranelift: {e:?}"))?;
    module.clear_context(&mut ctx);
    module.finalize_definitions().map_err(|e| format!("cranelift: {e}"))?;
    let code = module.get_finalized_function(id);
    // SAFETY: the function was declared with exactly this signature (two pointers in, a
    // u32 status out, the platform's C calling convention).
    let entry = unsafe { std::mem::transmute::<*const u8, Entry>(code) };
    Ok(Native {
        _module: module,
        entry,
        per_call: if simd { lanes * simd_width(mode) } else { lanes },
    })
}

/// One compiled value: its scalar components (matrices column by column), or a pointer.
#[derive(Clone)]
enum Slot {
    Val(Vec<Value>),
    Ptr(Ptr),
}

/// A pointer into storage `store`: `len` components from a constant offset, or from
/// `base + idx·stride` with `idx` (i32, already clamped) below `count`.
#[derive(Clone)]
struct Ptr {
    store: usize,
    off: Off,
    len: usize,
}

#[derive(Clone)]
enum Off {
    Const(usize),
    Dyn {
        base: usize,
        idx: Value,
        stride: usize,
        count: usize,
    },
}

/// One inlined call. With several lanes, every value, local and return slot is kept per
/// lane (`[lane][…]`); the lane being lowered is `Lower::lane`.
struct Frame {
    fun: Handle<naga::Function>,
    vals: Vec<Vec<Option<Slot>>>,
    locals: Vec<Vec<usize>>,
    ret: Option<Vec<usize>>,
    exit: Block,
}

/// Where `break` and `continue` send a lane in the lane path: the lanes that left, kept per
/// lane in variables (0/1) until the construct ends.
enum LTarget {
    Loop { brk: Vec<Variable>, cont: Vec<Variable> },
    Switch { brk: Vec<Variable> },
}

struct Lower<'p, 'b> {
    p: &'p Program,
    mode: Mode,
    b: FunctionBuilder<'b>,
    /// Locals and private globals: one variable per scalar component, with its type.
    stores: Vec<Vec<(Variable, Type)>>,
    /// Private globals: their storage per lane.
    globals: Vec<Option<Vec<usize>>>,
    /// Innermost last: where `break` goes, and `continue` (loops only).
    targets: Vec<(Block, Option<Block>)>,
    /// Configurations per call: 1 is the one-configuration path (control flow as branches),
    /// more is the lane path (see [`Lower::lblock`]).
    lanes: usize,
    /// The SIMD path: every value is a vector of [`simd_width`] configurations', masks are
    /// one vector per lane (`lanes` vectors per call), operations without a vector form are
    /// made lane by lane (`per_lane`). f32: F32X4, integers I32X4, booleans I32X4 masks of
    /// all ones or zeros. f64: F64X2, booleans I64X2 masks (what an F64X2 compare gives),
    /// integers I32X4 with configuration `j`'s value in lanes `2j` and `2j + 1` (so every
    /// lane-wise i32 operation keeps the two copies equal and an integer compare's I32X4
    /// mask, read as I64X2, is the boolean mask).
    simd: bool,
    /// The lane whose values are being lowered.
    lane: usize,
    /// The lane path's execution mask: per lane 1 while the lane runs the current statement.
    cur: Vec<Variable>,
    /// The lane path's `break`/`continue` targets, innermost last.
    ltargets: Vec<LTarget>,
    /// Loops the code being lowered is in (shim calls are cached there).
    loops: usize,
    /// Whether the current block still takes instructions (no jump or return yet). In the
    /// lane path: whether any lane can still run the rest of the current naga block.
    open: bool,
    /// The block that returns status 1 (a loop past the limit), made on first use.
    fail: Option<Block>,
    sigs: HashMap<(usize, Type), SigRef>,
    depth: usize,
    /// Shim results in the current block by function and arguments: the shims are pure, so
    /// a repeated call (`cos(phi)` written twice) is the same value (cleared at each block).
    memo: HashMap<(F, Vec<Value>), Value>,
    ptr: Type,
    /// The platform's C calling convention (the shims are `extern "C"`).
    cc: CallConv,
}

type R<T> = Result<T, String>;

/// The flags of a bitcast between vector types of different lane counts (a mask read as
/// another lane width): little-endian, as x86-64 lays out a vector's lanes.
fn lanes_le() -> MemFlagsData {
    MemFlagsData::new().with_endianness(cranelift_codegen::ir::Endianness::Little)
}

impl<'p> Lower<'p, '_> {
    fn fty(&self) -> Type {
        self.vt(self.sty())
    }

    /// The mode's scalar float type.
    fn sty(&self) -> Type {
        match self.mode {
            Mode::F32 => types::F32,
            Mode::F64 => types::F64,
        }
    }

    /// The machine type holding a scalar of type `t` (a vector of it on the SIMD path;
    /// booleans there are I32X4 masks).
    fn vt(&self, t: Type) -> Type {
        if !self.simd {
            return t;
        }
        match (t, self.mode) {
            (types::F32, _) => types::F32X4,
            (types::F64, _) => types::F64X2,
            (types::I8, Mode::F64) => types::I64X2,
            (types::I8 | types::I32, _) => types::I32X4,
            (other, _) => other,
        }
    }

    /// Configurations per vector on the SIMD path (1 elsewhere).
    fn width(&self) -> usize {
        if self.simd {
            simd_width(self.mode)
        } else {
            1
        }
    }

    /// A vector compare's result as the path's boolean mask: on the f64 SIMD path an I32X4
    /// compare of (duplicated) integers read as I64X2.
    fn as_mask(&mut self, c: Value) -> Value {
        let mt = self.vt(types::I8);
        if self.b.func.dfg.value_type(c).is_vector() && self.b.func.dfg.value_type(c) != mt {
            self.b.ins().bitcast(mt, lanes_le(), c)
        } else {
            c
        }
    }

    /// Whether control flow goes through execution masks (the lane and SIMD paths).
    fn masked(&self) -> bool {
        self.lanes > 1 || self.simd
    }

    /// `c ? a : b`, `c` a boolean (a mask on the SIMD path: lane by lane).
    fn sel(&mut self, c: Value, a: Value, b: Value) -> Value {
        if !self.b.func.dfg.value_type(c).is_vector() {
            return self.b.ins().select(c, a, b);
        }
        let t = self.b.func.dfg.value_type(a);
        let c = if t == self.b.func.dfg.value_type(c) {
            c
        } else {
            self.b.ins().bitcast(t, lanes_le(), c)
        };
        self.b.ins().bitselect(c, a, b)
    }

    /// `x cc k` for an integer `x` (a vector compared lane by lane on the SIMD path).
    fn icmp_k(&mut self, cc: IntCC, x: Value, k: i64) -> Value {
        let t = self.b.func.dfg.value_type(x);
        if !t.is_vector() {
            return self.b.ins().icmp_imm_s(cc, x, k);
        }
        let s = self.b.ins().iconst(t.lane_type(), k);
        let v = self.b.ins().splat(t, s);
        let c = self.b.ins().icmp(cc, x, v);
        self.as_mask(c)
    }

    /// A mask of every lane (`on`) or none, in the path's mask type.
    fn mask_const(&mut self, on: bool) -> Value {
        if self.simd {
            let mt = self.vt(types::I8);
            let s = self.b.ins().iconst(mt.lane_type(), -i64::from(on));
            self.b.ins().splat(mt, s)
        } else {
            self.b.ins().iconst(types::I8, i64::from(on))
        }
    }

    /// An i32 constant (splat on the SIMD path).
    fn iconst32(&mut self, v: i64) -> Value {
        let s = self.b.ins().iconst(types::I32, i64::from(v as u32));
        if self.simd {
            self.b.ins().splat(types::I32X4, s)
        } else {
            s
        }
    }

    /// A boolean as the integer 0 or 1.
    fn bool_to_int(&mut self, x: Value) -> Value {
        if self.simd {
            let one = self.iconst32(1);
            let x = if self.b.func.dfg.value_type(x) == types::I32X4 {
                x
            } else {
                self.b.ins().bitcast(types::I32X4, lanes_le(), x)
            };
            self.b.ins().band(x, one)
        } else {
            self.b.ins().uextend(types::I32, x)
        }
    }

    /// `f` on each lane's scalars on the SIMD path (what has no vector instruction, or none
    /// this file trusts: calls, integer division, shifts, conversions, rounding); `f`
    /// itself elsewhere.
    fn per_lane(&mut self, args: &[Value], f: &mut dyn FnMut(&mut Self, &[Value]) -> Value) -> Value {
        if !self.simd {
            return f(self, args);
        }
        let w = self.width();
        self.simd = false;
        // A configuration's element in a vector of type `t`: on the f64 path an integer
        // vector holds configuration `l` in lanes 2l and 2l + 1.
        let at = |t: Type, l: usize| (l * t.lane_count() as usize / w) as u8;
        let mut out: Option<Value> = None;
        for l in 0..w {
            let a: Vec<Value> = args
                .iter()
                .map(|&x| {
                    let t = self.b.func.dfg.value_type(x);
                    self.b.ins().extractlane(x, at(t, l))
                })
                .collect();
            let r = f(self, &a);
            let vt = match self.b.func.dfg.value_type(r) {
                types::F32 => types::F32X4,
                types::F64 => types::F64X2,
                _ => types::I32X4,
            };
            out = Some(match out {
                None => self.b.ins().splat(vt, r),
                Some(mut v) => {
                    let k = vt.lane_count() as usize / w;
                    for i in 0..k {
                        v = self.b.ins().insertlane(v, r, (l * k + i) as u8);
                    }
                    v
                }
            });
        }
        self.simd = true;
        out.expect("at least one lane")
    }

    /// Each scalar component's machine type and kind.
    fn comps(&self, inner: &TypeInner) -> R<Vec<(Type, ScalarKind)>> {
        let scalar = |s: naga::Scalar| -> R<(Type, ScalarKind)> {
            match (s.kind, s.width) {
                (ScalarKind::Float, 4) => Ok((self.sty(), s.kind)),
                (ScalarKind::Sint | ScalarKind::Uint, 4) => Ok((types::I32, s.kind)),
                (ScalarKind::Bool, _) => Ok((types::I8, s.kind)),
                _ => Err(format!("scalar {s:?} is not compiled")),
            }
        };
        Ok(match inner {
            TypeInner::Scalar(s) => vec![scalar(*s)?],
            TypeInner::Vector { size, scalar: s } => vec![scalar(*s)?; *size as usize],
            TypeInner::Matrix {
                columns,
                rows,
                scalar: s,
            } => vec![scalar(*s)?; *columns as usize * *rows as usize],
            TypeInner::Array {
                base,
                size: naga::ArraySize::Constant(n),
                ..
            } => {
                let one = self.comps(&self.p.module.types[*base].inner)?;
                (0..n.get()).flat_map(|_| one.iter().copied()).collect()
            }
            TypeInner::Struct { members, .. } => {
                let mut out = Vec::new();
                for m in members {
                    out.extend(self.comps(&self.p.module.types[m.ty].inner)?);
                }
                out
            }
            other => return Err(format!("type {other:?} is not compiled")),
        })
    }

    fn ty_comps(&self, ty: Handle<naga::Type>) -> R<Vec<(Type, ScalarKind)>> {
        self.comps(&self.p.module.types[ty].inner)
    }

    fn inner(&self, fun: Handle<naga::Function>, h: Handle<naga::Expression>) -> &'p TypeInner {
        self.p.info[fun][h].ty.inner_with(&self.p.module.types)
    }

    fn at(&self, fun: Handle<naga::Function>, h: Handle<naga::Expression>, msg: &str) -> String {
        let line = self.p.funs[fun.index()].line[h.index()];
        match self.p.lines.get(line as usize) {
            Some(l) => format!("{}:{}: {msg} (`{}`)", l.path, l.line, l.text.trim()),
            None => msg.to_string(),
        }
    }

    /// A constant `v` (a value as the interpreter holds it, in f64) of machine type `t`.
    fn konst(&mut self, t: Type, v: f64) -> Value {
        if self.simd {
            return match t {
                types::I8 => self.mask_const(v != 0.0),
                types::I32 => self.iconst32(v as i64),
                _ => {
                    self.simd = false;
                    let s = self.konst(t, v);
                    self.simd = true;
                    let vt = self.vt(t);
                    self.b.ins().splat(vt, s)
                }
            };
        }
        match t {
            types::F32 => self.b.ins().f32const(v as f32),
            types::F64 => self.b.ins().f64const(v),
            types::I8 => self.b.ins().iconst(types::I8, (v != 0.0) as i64),
            _ => self.b.ins().iconst(types::I32, i64::from(v as i64 as u32)),
        }
    }

    fn fconst(&mut self, v: f64) -> Value {
        let t = self.sty();
        self.konst(t, v)
    }

    /// New storage of the given component types, holding `init` (or zeros).
    fn storage(&mut self, comps: &[(Type, ScalarKind)], init: Option<&[Value]>) -> usize {
        let mut vars = Vec::with_capacity(comps.len());
        for (i, &(t, _)) in comps.iter().enumerate() {
            let vt = self.vt(t);
            let v = self.b.declare_var(vt);
            let x = match init {
                Some(init) => init[i],
                None => self.konst(t, 0.0),
            };
            self.b.def_var(v, x);
            vars.push((v, t));
        }
        self.stores.push(vars);
        self.stores.len() - 1
    }

    fn sig(&mut self, args: usize, t: Type) -> SigRef {
        if let Some(s) = self.sigs.get(&(args, t)) {
            return *s;
        }
        let mut sig = Signature::new(self.cc);
        for _ in 0..args {
            sig.params.push(AbiParam::new(t));
        }
        sig.returns.push(AbiParam::new(t));
        let s = self.b.import_signature(sig);
        self.sigs.insert((args, t), s);
        s
    }

    /// Continues in block `b` (which no shim result of another block dominates).
    fn switch(&mut self, b: Block) {
        self.b.switch_to_block(b);
        self.memo.clear();
    }

    /// A call of the shim of `f` in the mode's precision (once per block and arguments).
    fn call_shim(&mut self, f: F, args: &[Value]) -> Value {
        if let Some(&v) = self.memo.get(&(f, args.to_vec())) {
            return v;
        }
        let v = if self.loops > 0 {
            self.cached_call(f, args)
        } else {
            self.raw_call(f, args)
        };
        self.memo.insert((f, args.to_vec()), v);
        v
    }

    /// Inside a loop: a one-entry cache per call site, keyed by the arguments' bits. A pure
    /// function of the same bits returns the same bits, so a call whose arguments did not
    /// change since the site's last call (`cos(phi)` in an inner loop over `r`) is not made
    /// again. The cache's variables are never defined before the loop: cranelift-frontend
    /// reads them as zero there, so the first call always misses.
    fn cached_call(&mut self, f: F, args: &[Value]) -> Value {
        let t = self.fty();
        let it = match t {
            types::F32 => types::I32,
            types::F32X4 => types::I32X4,
            types::F64X2 => types::I64X2,
            _ => types::I64,
        };
        let valid = self.b.declare_var(types::I8);
        let last: Vec<Variable> = args.iter().map(|_| self.b.declare_var(it)).collect();
        let (res, out) = (self.b.declare_var(t), self.b.declare_var(t));
        let bits: Vec<Value> = args
            .iter()
            .map(|&a| self.b.ins().bitcast(it, MemFlagsData::new(), a))
            .collect();
        let mut same = self.b.use_var(valid);
        for (k, &b) in bits.iter().enumerate() {
            let l = self.b.use_var(last[k]);
            let mut eq = self.b.ins().icmp(IntCC::Equal, b, l);
            if self.simd {
                // A hit only when every lane's argument is unchanged.
                eq = self.b.ins().vall_true(eq);
            }
            same = self.b.ins().band(same, eq);
        }
        let (hit, miss, join) = (self.b.create_block(), self.b.create_block(), self.b.create_block());
        self.b.ins().brif(same, hit, &[], miss, &[]);
        self.switch(hit);
        let r = self.b.use_var(res);
        self.b.def_var(out, r);
        self.b.ins().jump(join, &[]);
        self.switch(miss);
        let r = self.raw_call(f, args);
        self.b.def_var(res, r);
        for (k, &b) in bits.iter().enumerate() {
            self.b.def_var(last[k], b);
        }
        let one = self.b.ins().iconst(types::I8, 1);
        self.b.def_var(valid, one);
        self.b.def_var(out, r);
        self.b.ins().jump(join, &[]);
        self.switch(join);
        self.b.use_var(out)
    }

    fn raw_call(&mut self, f: F, args: &[Value]) -> Value {
        if self.simd {
            return self.per_lane(args, &mut |s, a| s.raw_call(f, a));
        }
        let wide = self.mode == Mode::F64;
        let s = shim(f, wide);
        debug_assert_eq!(s.args, args.len());
        let t = self.fty();
        let sig = self.sig(args.len(), t);
        let callee = self.b.ins().iconst(self.ptr, s.addr as i64);
        let call = self.b.ins().call_indirect(sig, callee, args);
        self.b.inst_results(call)[0]
    }

    fn add(&mut self, a: Value, b: Value) -> Value {
        self.b.ins().fadd(a, b)
    }
    fn sub(&mut self, a: Value, b: Value) -> Value {
        self.b.ins().fsub(a, b)
    }
    fn mul(&mut self, a: Value, b: Value) -> Value {
        self.b.ins().fmul(a, b)
    }
    fn dot(&mut self, a: &[Value], b: &[Value]) -> Value {
        let mut acc = self.mul(a[0], b[0]);
        for k in 1..a.len() {
            let t = self.mul(a[k], b[k]);
            acc = self.add(acc, t);
        }
        acc
    }
    /// `inverseSqrt`: in f32, `1/√x` in f64 rounded once (as the interpreter has it).
    fn rsqrt(&mut self, x: Value) -> Value {
        if self.simd && self.mode == Mode::F32 {
            // Lanes 0 and 1 promoted together, 2 and 3 by hand; each pair in f64 as below,
            // rounded to f32 once.
            let lo = self.b.ins().fvpromote_low(x);
            let (x2, x3) = (self.b.ins().extractlane(x, 2), self.b.ins().extractlane(x, 3));
            let (w2, w3) = (
                self.b.ins().fpromote(types::F64, x2),
                self.b.ins().fpromote(types::F64, x3),
            );
            let hi = self.b.ins().splat(types::F64X2, w2);
            let hi = self.b.ins().insertlane(hi, w3, 1);
            let one = self.b.ins().f64const(1.0);
            let one = self.b.ins().splat(types::F64X2, one);
            let (sl, sh) = (self.b.ins().sqrt(lo), self.b.ins().sqrt(hi));
            let (rl, rh) = (self.b.ins().fdiv(one, sl), self.b.ins().fdiv(one, sh));
            let r = self.b.ins().fvdemote(rl);
            let (h0, h1) = (self.b.ins().extractlane(rh, 0), self.b.ins().extractlane(rh, 1));
            let (h0, h1) = (
                self.b.ins().fdemote(types::F32, h0),
                self.b.ins().fdemote(types::F32, h1),
            );
            let r = self.b.ins().insertlane(r, h0, 2);
            return self.b.ins().insertlane(r, h1, 3);
        }
        match self.mode {
            Mode::F32 => {
                let w = self.b.ins().fpromote(types::F64, x);
                let s = self.b.ins().sqrt(w);
                let one = self.b.ins().f64const(1.0);
                let q = self.b.ins().fdiv(one, s);
                self.b.ins().fdemote(types::F32, q)
            }
            Mode::F64 => {
                let s = self.b.ins().sqrt(x);
                let one = self.fconst(1.0);
                self.b.ins().fdiv(one, s)
            }
        }
    }

    /// Rust's `f32::max`/`f64::max` (or `min`), which the interpreter calls, inline: a NaN
    /// `x` gives `y`; else `y` where it is strictly greater (less), else `x`. So a NaN `y`
    /// gives `x`, and of two equal values (`+0`, `−0`) the first, as the Rust functions
    /// return them on this target (`tests/compiled.rs` checks every pair of ±0, ±1, ±∞ and
    /// NaN against the interpreter). No call: a call in a loop makes every live float spill.
    fn min_max(&mut self, max: bool, x: Value, y: Value) -> Value {
        let cc = if max { FloatCC::GreaterThan } else { FloatCC::LessThan };
        let wins = self.b.ins().fcmp(cc, y, x);
        let r = self.sel(wins, y, x);
        let nan = self.b.ins().fcmp(FloatCC::Unordered, x, x);
        self.sel(nan, y, r)
    }

    fn fail_block(&mut self) -> Block {
        if let Some(b) = self.fail {
            return b;
        }
        let b = self.b.create_block();
        self.b.set_cold_block(b);
        self.fail = Some(b);
        b
    }

    /// The whole function: read the scene, set the private globals as the entry point does
    /// (compose.rs), call `method`, write its result.
    fn entry(&mut self) -> R<()> {
        let p = self.p;
        let start = self.b.create_block();
        self.b.append_block_params_for_function_params(start);
        self.switch(start);
        let (scene_ptr, out_ptr) = (self.b.block_params(start)[0], self.b.block_params(start)[1]);
        let f = &p.module.functions[p.method];
        let scene_ty = f.arguments.first().ok_or("`method` takes no scene")?.ty;
        let comps = self.ty_comps(scene_ty)?;
        let total: usize = p.scene.iter().map(|s| s.2).sum();
        if comps.len() != total {
            return Err("`method`'s argument is not the Scene".into());
        }
        // Lane `l`'s scene is the `l`-th run of `total` components, its result `out[l]`.
        // On the SIMD path lane `l`'s values are vectors of `per` scenes, from the
        // `per·l`-th on.
        let per = self.width();
        let mut scenes = Vec::with_capacity(self.lanes);
        for lane in 0..self.lanes {
            let mut scene = Vec::with_capacity(total);
            for (k, &(t, kind)) in comps.iter().enumerate() {
                let mut vec: Option<Value> = None;
                for v in 0..per {
                    let at = (8 * ((lane * per + v) * total + k)) as i32;
                    let x = self.b.ins().load(types::F64, MemFlagsData::trusted(), scene_ptr, at);
                    let x = match (t, kind) {
                        (types::F32, _) => self.b.ins().fdemote(types::F32, x),
                        (types::F64, _) => x,
                        (_, ScalarKind::Sint) => self.b.ins().fcvt_to_sint_sat(types::I32, x),
                        (_, ScalarKind::Uint) => self.b.ins().fcvt_to_uint_sat(types::I32, x),
                        _ => {
                            let z = self.b.ins().f64const(0.0);
                            let c = self.b.ins().fcmp(FloatCC::NotEqual, x, z);
                            if self.simd {
                                let lt = self.vt(types::I8).lane_type();
                                self.b.ins().bmask(lt, c)
                            } else {
                                c
                            }
                        }
                    };
                    let vt = self.vt(t);
                    let k = vt.lane_count() as usize / per;
                    vec = Some(match vec {
                        _ if !self.simd => x,
                        None => self.b.ins().splat(vt, x),
                        Some(mut w) => {
                            for i in 0..k {
                                w = self.b.ins().insertlane(w, x, (v * k + i) as u8);
                            }
                            w
                        }
                    });
                }
                scene.push(vec.ok_or("no lanes")?);
            }
            scenes.push(scene);
        }
        for (h, g) in p.module.global_variables.iter() {
            if g.space != naga::AddressSpace::Private {
                continue;
            }
            let comps = self.ty_comps(g.ty)?;
            let mut per_lane = Vec::with_capacity(self.lanes);
            for scene in &scenes {
                let init: Vec<Value> = match g.name.as_deref() {
                    Some("ll_scene") => scene.clone(),
                    Some("Minv") => {
                        let (off, len) = p.scene_minv;
                        scene[off..off + len].to_vec()
                    }
                    _ => match g.init {
                        Some(init) => self.global_const(init, &comps)?,
                        None => comps.iter().map(|&(t, _)| self.konst(t, 0.0)).collect(),
                    },
                };
                if init.len() != comps.len() {
                    return Err(format!("private global `{:?}` does not match its type", g.name));
                }
                per_lane.push(self.storage(&comps, Some(&init)));
            }
            self.globals[h.index()] = Some(per_lane);
        }
        if self.masked() {
            // Every lane runs `method`.
            for _ in 0..self.lanes {
                let t = self.vt(types::I8);
                let v = self.b.declare_var(t);
                let one = self.mask_const(true);
                self.b.def_var(v, one);
                self.cur.push(v);
            }
        }
        let args = scenes.into_iter().map(|s| vec![Slot::Val(s)]).collect();
        let ret = self.call(p.method, args)?.ok_or("`method` returned nothing")?;
        for (lane, r) in ret.iter().enumerate() {
            for v in 0..per {
                let x = if self.simd {
                    self.b.ins().extractlane(r[0], v as u8)
                } else {
                    r[0]
                };
                let x = match self.mode {
                    Mode::F32 => self.b.ins().fpromote(types::F64, x),
                    Mode::F64 => x,
                };
                self.b
                    .ins()
                    .store(MemFlagsData::trusted(), x, out_ptr, (8 * (lane * per + v)) as i32);
            }
        }
        let ok = self.b.ins().iconst(types::I32, 0);
        self.b.ins().return_(&[ok]);
        if let Some(fail) = self.fail {
            self.switch(fail);
            let one = self.b.ins().iconst(types::I32, 1);
            self.b.ins().return_(&[one]);
        }
        Ok(())
    }

    /// A module constant as values: its f32 values, or in the f64 mode its written digits.
    fn global_const(&mut self, init: Handle<naga::Expression>, comps: &[(Type, ScalarKind)]) -> R<Vec<Value>> {
        let (v32, v64) = &self.p.global_consts[init.index()];
        let vals = match self.mode {
            Mode::F32 => v32.clone(),
            Mode::F64 => v64.clone()?,
        };
        if vals.len() != comps.len() {
            return Err("a constant does not match its type".into());
        }
        Ok(comps.iter().zip(vals).map(|(&(t, _), v)| self.konst(t, v)).collect())
    }

    /// A call, inlined: arguments, locals, the body, and its return value.
    /// `args` and the result per lane.
    fn call(&mut self, fun: Handle<naga::Function>, args: Vec<Vec<Slot>>) -> R<Option<Vec<Vec<Value>>>> {
        let p = self.p;
        if self.depth >= MAX_DEPTH {
            return Err(format!("calls nested deeper than {MAX_DEPTH}"));
        }
        self.depth += 1;
        let n = self.lanes;
        let f = &p.module.functions[fun];
        let exit = self.b.create_block();
        let ret = match &f.result {
            Some(r) => {
                let c = self.ty_comps(r.ty)?;
                Some((0..n).map(|_| self.storage(&c, None)).collect::<Vec<_>>())
            }
            None => None,
        };
        let mut locals = vec![Vec::new(); n];
        for (_, lv) in f.local_variables.iter() {
            let c = self.ty_comps(lv.ty)?;
            for l in &mut locals {
                l.push(self.storage(&c, None));
            }
        }
        let mut fr = Frame {
            fun,
            vals: vec![vec![None; f.expressions.len()]; n],
            locals,
            ret,
            exit,
        };
        let fp = &p.funs[fun.index()];
        // As the interpreter: expressions no `Emit` covers first, in order.
        for (h, e) in f.expressions.iter() {
            if fp.emitted[h.index()] || matches!(e, E::CallResult(_)) {
                continue;
            }
            for (lane, lane_args) in args.iter().enumerate() {
                self.lane = lane;
                match e {
                    E::FunctionArgument(i) => {
                        let a = lane_args.get(*i as usize).cloned().ok_or("missing argument")?;
                        fr.vals[lane][h.index()] = Some(a);
                    }
                    E::LocalVariable(lv) => {
                        fr.vals[lane][h.index()] = Some(Slot::Ptr(Ptr {
                            store: fr.locals[lane][lv.index()],
                            off: Off::Const(0),
                            len: p.flat[f.local_variables[*lv].ty.index()],
                        }));
                    }
                    _ => self.expr(&mut fr, h)?,
                }
            }
        }
        for (lv, v) in f.local_variables.iter() {
            if let Some(init) = v.init {
                for lane in 0..n {
                    self.lane = lane;
                    if fr.vals[lane][init.index()].is_none() {
                        self.expr(&mut fr, init)?;
                    }
                    let val = self.val(&fr, init)?;
                    let store = fr.locals[lane][lv.index()];
                    self.write(store, 0, &val);
                }
            }
        }
        if self.masked() {
            // The lanes that call leave together at the end (those that returned early
            // hold their result in `ret`).
            let entry = self.mask();
            self.lblock(&mut fr, &f.body)?;
            self.b.ins().jump(exit, &[]);
            self.switch(exit);
            self.set_mask(&entry);
        } else {
            self.block(&mut fr, &f.body)?;
            if self.open {
                self.b.ins().jump(exit, &[]);
            }
            self.switch(exit);
        }
        self.open = true;
        self.depth -= 1;
        Ok(fr
            .ret
            .map(|ids| ids.iter().map(|&s| self.read(s, 0, self.stores[s].len())).collect()))
    }

    fn read(&mut self, store: usize, off: usize, len: usize) -> Vec<Value> {
        (off..off + len)
            .map(|k| {
                let v = self.stores[store][k].0;
                self.b.use_var(v)
            })
            .collect()
    }

    /// Stores `vals` from component `off` of `store`. In the lane path only where the
    /// current lane runs (a select on its mask): a lane that left keeps what it had.
    fn write(&mut self, store: usize, off: usize, vals: &[Value]) {
        let mask = self.masked().then(|| self.b.use_var(self.cur[self.lane]));
        for (k, &x) in vals.iter().enumerate() {
            let v = self.stores[store][off + k].0;
            let x = match mask {
                Some(m) => {
                    let old = self.b.use_var(v);
                    self.sel(m, x, old)
                }
                None => x,
            };
            self.b.def_var(v, x);
        }
    }

    fn val(&self, fr: &Frame, h: Handle<naga::Expression>) -> R<Vec<Value>> {
        match &fr.vals[self.lane][h.index()] {
            Some(Slot::Val(v)) => Ok(v.clone()),
            Some(Slot::Ptr(_)) => Err(self.at(fr.fun, h, "a pointer used as a value")),
            None => Err(self.at(fr.fun, h, "value used before it is computed")),
        }
    }

    fn ptr(&self, fr: &Frame, h: Handle<naga::Expression>) -> R<Ptr> {
        match &fr.vals[self.lane][h.index()] {
            Some(Slot::Ptr(p)) => Ok(p.clone()),
            _ => Err(self.at(fr.fun, h, "not a pointer")),
        }
    }

    fn load(&mut self, ptr: &Ptr) -> Vec<Value> {
        match ptr.off {
            Off::Const(o) => self.read(ptr.store, o, ptr.len),
            Off::Dyn {
                base,
                idx,
                stride,
                count,
            } => (0..ptr.len)
                .map(|c| {
                    let mut v = self.read(ptr.store, base + c, 1)[0];
                    for k in 1..count {
                        let x = self.read(ptr.store, base + k * stride + c, 1)[0];
                        let hit = self.icmp_k(IntCC::Equal, idx, k as i64);
                        v = self.sel(hit, x, v);
                    }
                    v
                })
                .collect(),
        }
    }

    fn store(&mut self, ptr: &Ptr, vals: &[Value]) {
        match ptr.off {
            Off::Const(o) => self.write(ptr.store, o, &vals[..ptr.len]),
            Off::Dyn {
                base,
                idx,
                stride,
                count,
            } => {
                for k in 0..count {
                    let hit = self.icmp_k(IntCC::Equal, idx, k as i64);
                    for (c, &x) in vals[..ptr.len].iter().enumerate() {
                        let at = base + k * stride + c;
                        let old = self.read(ptr.store, at, 1)[0];
                        let new = self.sel(hit, x, old);
                        self.write(ptr.store, at, &[new]);
                    }
                }
            }
        }
    }

    /// An index as the interpreter takes it: `max(idx, 0)` then at most `count − 1`.
    fn clamp_index(&mut self, idx: Value, signed: bool, count: usize) -> Value {
        let idx = if signed {
            let zero = self.iconst32(0);
            self.b.ins().smax(idx, zero)
        } else {
            idx
        };
        let top = self.iconst32(count.saturating_sub(1) as i64);
        self.b.ins().umin(idx, top)
    }

    fn block(&mut self, fr: &mut Frame, block: &naga::Block) -> R<()> {
        for st in block.iter() {
            if !self.open {
                // After a jump: the rest is never reached (the interpreter's mask is empty).
                return Ok(());
            }
            match st {
                S::Emit(range) => {
                    for h in range.clone() {
                        self.expr(fr, h)?;
                    }
                }
                S::Block(b) => self.block(fr, b)?,
                S::If {
                    condition,
                    accept,
                    reject,
                } => {
                    let c = self.val(fr, *condition)?[0];
                    let (yes, no, merge) = (self.b.create_block(), self.b.create_block(), self.b.create_block());
                    self.b.ins().brif(c, yes, &[], no, &[]);
                    for (blk, body) in [(yes, accept), (no, reject)] {
                        self.switch(blk);
                        self.open = true;
                        self.block(fr, body)?;
                        if self.open {
                            self.b.ins().jump(merge, &[]);
                        }
                    }
                    self.switch(merge);
                    self.open = true;
                }
                S::Switch { selector, cases } => {
                    let sel = self.val(fr, *selector)?[0];
                    let merge = self.b.create_block();
                    let bodies: Vec<Block> = cases.iter().map(|_| self.b.create_block()).collect();
                    let mut default = None;
                    for (case, &body) in cases.iter().zip(&bodies) {
                        let v = match case.value {
                            naga::SwitchValue::I32(i) => i64::from(i),
                            naga::SwitchValue::U32(u) => i64::from(u as i32),
                            naga::SwitchValue::Default => {
                                default = Some(body);
                                continue;
                            }
                        };
                        let next = self.b.create_block();
                        let hit = self.icmp_k(IntCC::Equal, sel, v);
                        self.b.ins().brif(hit, body, &[], next, &[]);
                        self.switch(next);
                    }
                    self.b.ins().jump(default.unwrap_or(merge), &[]);
                    self.targets.push((merge, None));
                    for (i, case) in cases.iter().enumerate() {
                        self.switch(bodies[i]);
                        self.open = true;
                        self.block(fr, &case.body)?;
                        if self.open {
                            let to = match (case.fall_through, bodies.get(i + 1)) {
                                (true, Some(&b)) => b,
                                _ => merge,
                            };
                            self.b.ins().jump(to, &[]);
                        }
                    }
                    self.targets.pop();
                    self.switch(merge);
                    self.open = true;
                }
                S::Loop {
                    body,
                    continuing,
                    break_if,
                } => {
                    let count = self.b.declare_var(types::I32);
                    let zero = self.b.ins().iconst(types::I32, 0);
                    self.b.def_var(count, zero);
                    let (head, first, cont, exit) = (
                        self.b.create_block(),
                        self.b.create_block(),
                        self.b.create_block(),
                        self.b.create_block(),
                    );
                    self.b.ins().jump(head, &[]);
                    self.switch(head);
                    let n = self.b.use_var(count);
                    let n = self.b.ins().iadd_imm_s(n, 1);
                    self.b.def_var(count, n);
                    let over = self.icmp_k(IntCC::SignedGreaterThan, n, LOOP_LIMIT);
                    let fail = self.fail_block();
                    self.b.ins().brif(over, fail, &[], first, &[]);
                    self.switch(first);
                    self.open = true;
                    self.targets.push((exit, Some(cont)));
                    self.loops += 1;
                    self.block(fr, body)?;
                    if self.open {
                        self.b.ins().jump(cont, &[]);
                    }
                    self.switch(cont);
                    self.open = true;
                    self.block(fr, continuing)?;
                    if self.open {
                        match break_if {
                            Some(c) => {
                                let c = self.val(fr, *c)?[0];
                                self.b.ins().brif(c, exit, &[], head, &[]);
                            }
                            None => {
                                self.b.ins().jump(head, &[]);
                            }
                        }
                    }
                    self.targets.pop();
                    self.loops -= 1;
                    self.switch(exit);
                    self.open = true;
                }
                S::Break => {
                    let (to, _) = *self.targets.last().ok_or("`break` outside a loop")?;
                    self.b.ins().jump(to, &[]);
                    self.open = false;
                }
                S::Continue => {
                    let to = self
                        .targets
                        .iter()
                        .rev()
                        .find_map(|t| t.1)
                        .ok_or("`continue` outside a loop")?;
                    self.b.ins().jump(to, &[]);
                    self.open = false;
                }
                S::Return { value } => {
                    if let Some(v) = value {
                        let v = self.val(fr, *v)?;
                        let ret = fr.ret.as_ref().ok_or("return value in a void function")?[0];
                        self.write(ret, 0, &v);
                    }
                    self.b.ins().jump(fr.exit, &[]);
                    self.open = false;
                }
                S::Store { pointer, value } => {
                    let ptr = self.ptr(fr, *pointer)?;
                    let v = self.val(fr, *value)?;
                    self.store(&ptr, &v);
                }
                S::Call {
                    function,
                    arguments,
                    result,
                } => self.call_stmt(fr, *function, arguments, *result)?,
                other => return Err(format!("statement {other:?} is not compiled")),
            }
        }
        Ok(())
    }

    /// A call statement: its arguments and result per lane.
    fn call_stmt(
        &mut self,
        fr: &mut Frame,
        function: Handle<naga::Function>,
        arguments: &[Handle<naga::Expression>],
        result: Option<Handle<naga::Expression>>,
    ) -> R<()> {
        let args = (0..self.lanes)
            .map(|lane| {
                arguments
                    .iter()
                    .map(|a| {
                        fr.vals[lane][a.index()]
                            .clone()
                            .ok_or_else(|| "argument not computed".to_string())
                    })
                    .collect::<R<Vec<_>>>()
            })
            .collect::<R<Vec<_>>>()?;
        let r = self.call(function, args)?;
        if let (Some(h), Some(r)) = (result, r) {
            for (lane, r) in r.into_iter().enumerate() {
                fr.vals[lane][h.index()] = Some(Slot::Val(r));
            }
        }
        Ok(())
    }

    /// The lane path's mask as values (per lane 0 or 1).
    fn mask(&mut self) -> Vec<Value> {
        (0..self.lanes).map(|l| self.b.use_var(self.cur[l])).collect()
    }

    fn set_mask(&mut self, m: &[Value]) {
        for (l, &v) in m.iter().enumerate() {
            self.b.def_var(self.cur[l], v);
        }
    }

    /// New per-lane 0/1 variables holding `init`.
    fn lane_vars(&mut self, init: &[Value]) -> Vec<Variable> {
        let t = self.vt(types::I8);
        init.iter()
            .map(|&x| {
                let v = self.b.declare_var(t);
                self.b.def_var(v, x);
                v
            })
            .collect()
    }

    fn zeros(&mut self) -> Vec<Value> {
        (0..self.lanes).map(|_| self.mask_const(false)).collect()
    }

    fn or(&mut self, a: &[Value], b: &[Value]) -> Vec<Value> {
        a.iter().zip(b).map(|(&x, &y)| self.b.ins().bor(x, y)).collect()
    }

    fn and(&mut self, a: &[Value], b: &[Value]) -> Vec<Value> {
        a.iter().zip(b).map(|(&x, &y)| self.b.ins().band(x, y)).collect()
    }

    fn and_not(&mut self, a: &[Value], b: &[Value]) -> Vec<Value> {
        a.iter().zip(b).map(|(&x, &y)| self.b.ins().band_not(x, y)).collect()
    }

    /// Whether any lane of `m` is set.
    fn any(&mut self, m: &[Value]) -> Value {
        let mut acc = m[0];
        for &x in &m[1..] {
            acc = self.b.ins().bor(acc, x);
        }
        if self.simd {
            return self.b.ins().vany_true(acc);
        }
        acc
    }

    /// Adds the current lanes to `to` and stops them (`break`, `continue`, `return`).
    fn leave(&mut self, to: Option<Vec<Variable>>) {
        let m = self.mask();
        if let Some(to) = to {
            for (l, &x) in m.iter().enumerate() {
                let old = self.b.use_var(to[l]);
                let v = self.b.ins().bor(old, x);
                self.b.def_var(to[l], v);
            }
        }
        let z = self.zeros();
        self.set_mask(&z);
        self.open = false;
    }

    /// A boolean expression's value in every lane.
    fn lane_bools(&mut self, fr: &Frame, h: Handle<naga::Expression>) -> R<Vec<Value>> {
        (0..self.lanes)
            .map(|lane| {
                self.lane = lane;
                self.val(fr, h).map(|v| v[0])
            })
            .collect()
    }

    /// `body` on the lanes of `m`, skipped when there are none; the lanes still running at
    /// its end.
    fn arm(&mut self, fr: &mut Frame, body: &naga::Block, m: &[Value]) -> R<Vec<Value>> {
        if body.is_empty() {
            return Ok(m.to_vec());
        }
        self.set_mask(m);
        let any = self.any(m);
        let (run, join) = (self.b.create_block(), self.b.create_block());
        self.b.ins().brif(any, run, &[], join, &[]);
        self.switch(run);
        self.open = true;
        self.lblock(fr, body)?;
        self.b.ins().jump(join, &[]);
        self.switch(join);
        self.open = true;
        Ok(self.mask())
    }

    /// The lane path: `lanes` configurations per call, each naga value computed once per
    /// lane (the lanes' operations side by side, independent chains the processor overlaps),
    /// and control flow as the interpreter has it, with execution masks: a divergent `if`
    /// runs each side on its lanes (a side no lane takes is jumped over), a loop runs while
    /// any lane is in it, `break`/`continue`/`return` take lanes out of the mask, every
    /// store is a select on the lane's mask. Uniform control flow thus still costs a branch
    /// per construct; nothing here changes a value's bits (selects only choose).
    fn lblock(&mut self, fr: &mut Frame, block: &naga::Block) -> R<()> {
        let n = self.lanes;
        for st in block.iter() {
            if !self.open {
                // Every lane that ran this block has left it.
                return Ok(());
            }
            match st {
                S::Emit(range) => {
                    for h in range.clone() {
                        for lane in 0..n {
                            self.lane = lane;
                            self.expr(fr, h)?;
                        }
                    }
                }
                S::Block(b) => self.lblock(fr, b)?,
                S::If {
                    condition,
                    accept,
                    reject,
                } => {
                    let parent = self.mask();
                    let c = self.lane_bools(fr, *condition)?;
                    let yes = self.and(&parent, &c);
                    let no = self.and_not(&parent, &c);
                    let a = self.arm(fr, accept, &yes)?;
                    let r = self.arm(fr, reject, &no)?;
                    let m = self.or(&a, &r);
                    self.set_mask(&m);
                    self.open = true;
                }
                S::Switch { selector, cases } => {
                    let entry = self.mask();
                    let sel: Vec<Value> = (0..n)
                        .map(|lane| {
                            self.lane = lane;
                            self.val(fr, *selector).map(|v| v[0])
                        })
                        .collect::<R<_>>()?;
                    let mut hits = Vec::with_capacity(cases.len());
                    let mut matched = self.zeros();
                    for case in cases {
                        let v = match case.value {
                            naga::SwitchValue::I32(i) => i64::from(i),
                            naga::SwitchValue::U32(u) => i64::from(u as i32),
                            naga::SwitchValue::Default => {
                                hits.push(None);
                                continue;
                            }
                        };
                        let h: Vec<Value> = sel.iter().map(|&s| self.icmp_k(IntCC::Equal, s, v)).collect();
                        matched = self.or(&matched, &h);
                        hits.push(Some(h));
                    }
                    let zeros = self.zeros();
                    let brk = self.lane_vars(&zeros);
                    self.ltargets.push(LTarget::Switch { brk: brk.clone() });
                    let (mut carry, mut done) = (zeros.clone(), zeros);
                    for (case, hit) in cases.iter().zip(hits) {
                        let hit = match hit {
                            Some(h) => self.and(&entry, &h),
                            None => self.and_not(&entry, &matched),
                        };
                        let m = self.or(&hit, &carry);
                        let end = self.arm(fr, &case.body, &m)?;
                        if case.fall_through {
                            carry = end;
                        } else {
                            done = self.or(&done, &end);
                            carry = self.zeros();
                        }
                    }
                    self.ltargets.pop();
                    let b: Vec<Value> = brk.iter().map(|&v| self.b.use_var(v)).collect();
                    let m = self.or(&done, &carry);
                    let m = self.or(&m, &b);
                    self.set_mask(&m);
                    self.open = true;
                }
                S::Loop {
                    body,
                    continuing,
                    break_if,
                } => {
                    let entry = self.mask();
                    // `live`: lanes still looping; `brk`: lanes that left by `break` or
                    // `break if`; `cont`: lanes that took `continue` this pass.
                    let live = self.lane_vars(&entry);
                    let zeros = self.zeros();
                    let brk = self.lane_vars(&zeros);
                    let cont = self.lane_vars(&zeros);
                    let count = self.b.declare_var(types::I32);
                    let zero = self.b.ins().iconst(types::I32, 0);
                    self.b.def_var(count, zero);
                    let (head, first, exit) = (self.b.create_block(), self.b.create_block(), self.b.create_block());
                    let any = self.any(&entry);
                    self.b.ins().brif(any, head, &[], exit, &[]);
                    self.switch(head);
                    let c = self.b.use_var(count);
                    let c = self.b.ins().iadd_imm_s(c, 1);
                    self.b.def_var(count, c);
                    let over = self.icmp_k(IntCC::SignedGreaterThan, c, LOOP_LIMIT);
                    let fail = self.fail_block();
                    self.b.ins().brif(over, fail, &[], first, &[]);
                    self.switch(first);
                    let m: Vec<Value> = live.iter().map(|&v| self.b.use_var(v)).collect();
                    self.set_mask(&m);
                    let z = self.zeros();
                    for (&v, &x) in cont.iter().zip(&z) {
                        self.b.def_var(v, x);
                    }
                    self.ltargets.push(LTarget::Loop {
                        brk: brk.clone(),
                        cont: cont.clone(),
                    });
                    self.loops += 1;
                    self.open = true;
                    self.lblock(fr, body)?;
                    self.open = true;
                    let m = self.mask();
                    let k: Vec<Value> = cont.iter().map(|&v| self.b.use_var(v)).collect();
                    let m = self.or(&m, &k);
                    self.set_mask(&m);
                    self.lblock(fr, continuing)?;
                    self.open = true;
                    let m = self.mask();
                    let stay = match break_if {
                        Some(c) => {
                            let c = self.lane_bools(fr, *c)?;
                            let out = self.and(&m, &c);
                            for (l, &x) in out.iter().enumerate() {
                                let old = self.b.use_var(brk[l]);
                                let v = self.b.ins().bor(old, x);
                                self.b.def_var(brk[l], v);
                            }
                            self.and_not(&m, &c)
                        }
                        None => m,
                    };
                    for (&v, &x) in live.iter().zip(&stay) {
                        self.b.def_var(v, x);
                    }
                    let again = self.any(&stay);
                    self.b.ins().brif(again, head, &[], exit, &[]);
                    self.ltargets.pop();
                    self.loops -= 1;
                    self.switch(exit);
                    let m: Vec<Value> = brk.iter().map(|&v| self.b.use_var(v)).collect();
                    self.set_mask(&m);
                    self.open = true;
                }
                S::Break => {
                    let to = match self.ltargets.last().ok_or("`break` outside a loop")? {
                        LTarget::Loop { brk, .. } | LTarget::Switch { brk } => brk.clone(),
                    };
                    self.leave(Some(to));
                }
                S::Continue => {
                    let to = self
                        .ltargets
                        .iter()
                        .rev()
                        .find_map(|t| match t {
                            LTarget::Loop { cont, .. } => Some(cont.clone()),
                            LTarget::Switch { .. } => None,
                        })
                        .ok_or("`continue` outside a loop")?;
                    self.leave(Some(to));
                }
                S::Return { value } => {
                    if let Some(v) = value {
                        let ids = fr.ret.clone().ok_or("return value in a void function")?;
                        for (lane, &ret) in ids.iter().enumerate() {
                            self.lane = lane;
                            let v = self.val(fr, *v)?;
                            self.write(ret, 0, &v);
                        }
                    }
                    self.leave(None);
                }
                S::Store { pointer, value } => {
                    for lane in 0..n {
                        self.lane = lane;
                        let ptr = self.ptr(fr, *pointer)?;
                        let v = self.val(fr, *value)?;
                        self.store(&ptr, &v);
                    }
                }
                S::Call {
                    function,
                    arguments,
                    result,
                } => self.call_stmt(fr, *function, arguments, *result)?,
                other => return Err(format!("statement {other:?} is not compiled")),
            }
        }
        Ok(())
    }

    fn expr(&mut self, fr: &mut Frame, h: Handle<naga::Expression>) -> R<()> {
        let p = self.p;
        let fun = fr.fun;
        let f = &p.module.functions[fun];
        let ty = self.inner(fun, h);
        let slot = match &f.expressions[h] {
            E::Literal(l) => Slot::Val(vec![match *l {
                naga::Literal::F32(x) => match self.mode {
                    Mode::F32 => self.konst(types::F32, f64::from(x)),
                    Mode::F64 => {
                        let v = p.funs[fun.index()].lit64[h.index()]
                            .clone()
                            .map_err(|m| self.at(fun, h, &m))?;
                        self.konst(types::F64, v)
                    }
                },
                naga::Literal::U32(x) => self.iconst32(i64::from(x)),
                naga::Literal::I32(x) => self.iconst32(i64::from(x)),
                naga::Literal::Bool(x) => self.mask_const(x),
                other => return Err(self.at(fun, h, &format!("literal {other:?} is not compiled"))),
            }]),
            E::Constant(c) => {
                let comps = self.comps(ty)?;
                let init = p.module.constants[*c].init;
                Slot::Val(self.global_const(init, &comps).map_err(|m| self.at(fun, h, &m))?)
            }
            E::Override(o) => {
                let v = p.overrides[o.index()];
                let (t, _) = *self.comps(ty)?.first().ok_or("an override without a value")?;
                // The interpreter keeps an override's value unrounded until an f32 operation
                // reads it; only values exact in f32 behave the same here.
                if t == types::F32 && v as f32 as f64 != v && !v.is_nan() {
                    return Err(self.at(fun, h, "an f32 override whose value is not exact in f32"));
                }
                Slot::Val(vec![self.konst(t, v)])
            }
            E::ZeroValue(t) => {
                let comps = self.ty_comps(*t)?;
                Slot::Val(comps.iter().map(|&(t, _)| self.konst(t, 0.0)).collect())
            }
            E::Compose { components, .. } => {
                let mut out = Vec::new();
                for c in components {
                    out.extend(self.val(fr, *c)?);
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
                match fr.vals[self.lane][base.index()].clone() {
                    Some(Slot::Ptr(ptr)) => {
                        let (off, len) = p.child(&p.pointee(bty), *index as usize);
                        let off = match ptr.off {
                            Off::Const(o) => Off::Const(o + off),
                            Off::Dyn {
                                base,
                                idx,
                                stride,
                                count,
                            } => Off::Dyn {
                                base: base + off,
                                idx,
                                stride,
                                count,
                            },
                        };
                        Slot::Ptr(Ptr {
                            store: ptr.store,
                            off,
                            len,
                        })
                    }
                    Some(Slot::Val(v)) => {
                        let (off, len) = p.child(bty, *index as usize);
                        Slot::Val(v[off..off + len].to_vec())
                    }
                    None => return Err(self.at(fun, h, "base not computed")),
                }
            }
            E::Access { base, index } => {
                let bty = self.inner(fun, *base);
                let signed = self.inner(fun, *index).scalar_kind() == Some(ScalarKind::Sint);
                let raw = self.val(fr, *index)?[0];
                match fr.vals[self.lane][base.index()].clone() {
                    Some(Slot::Ptr(ptr)) => {
                        let (count, stride) = p.elements(&p.pointee(bty));
                        let idx = self.clamp_index(raw, signed, count);
                        let Off::Const(base) = ptr.off else {
                            return Err(self.at(fun, h, "two dynamic indices into one variable are not compiled"));
                        };
                        Slot::Ptr(Ptr {
                            store: ptr.store,
                            off: Off::Dyn {
                                base,
                                idx,
                                stride,
                                count,
                            },
                            len: stride,
                        })
                    }
                    Some(Slot::Val(v)) => {
                        let (count, stride) = p.elements(bty);
                        let idx = self.clamp_index(raw, signed, count);
                        let out = (0..stride)
                            .map(|c| {
                                let mut x = v[c];
                                for k in 1..count {
                                    let hit = self.icmp_k(IntCC::Equal, idx, k as i64);
                                    x = self.sel(hit, v[k * stride + c], x);
                                }
                                x
                            })
                            .collect();
                        Slot::Val(out)
                    }
                    None => return Err(self.at(fun, h, "base not computed")),
                }
            }
            E::GlobalVariable(g) => {
                let store = self.globals[g.index()]
                    .as_ref()
                    .map(|s| s[self.lane])
                    .ok_or_else(|| self.at(fun, h, "a global outside the private space is not compiled"))?;
                Slot::Ptr(Ptr {
                    store,
                    off: Off::Const(0),
                    len: p.flat[p.module.global_variables[*g].ty.index()],
                })
            }
            E::Load { pointer } => {
                let ptr = self.ptr(fr, *pointer)?;
                Slot::Val(self.load(&ptr))
            }
            E::Unary { op, expr } => {
                let a = self.val(fr, *expr)?;
                let kind = ty.scalar_kind();
                let mut out = Vec::new();
                for x in a {
                    out.push(match (op, kind) {
                        (U::Negate, Some(ScalarKind::Float)) => self.b.ins().fneg(x),
                        (U::Negate, Some(ScalarKind::Sint)) => self.b.ins().ineg(x),
                        (U::LogicalNot, _) => self.icmp_k(IntCC::Equal, x, 0),
                        (U::BitwiseNot, Some(ScalarKind::Sint | ScalarKind::Uint)) => self.b.ins().bnot(x),
                        _ => return Err(self.at(fun, h, &format!("{op:?} on {kind:?} is not compiled"))),
                    });
                }
                Slot::Val(out)
            }
            E::Binary { op, left, right } => {
                let lt = self.inner(fun, *left);
                let rt = self.inner(fun, *right);
                let (a, b) = (self.val(fr, *left)?, self.val(fr, *right)?);
                Slot::Val(self.binary(*op, lt, rt, &a, &b).map_err(|m| self.at(fun, h, &m))?)
            }
            E::Select {
                condition,
                accept,
                reject,
            } => {
                let c = self.val(fr, *condition)?;
                let a = self.val(fr, *accept)?;
                let r = self.val(fr, *reject)?;
                let out = (0..a.len())
                    .map(|k| self.sel(c[k.min(c.len() - 1)], a[k], r[k]))
                    .collect();
                Slot::Val(out)
            }
            E::Relational { fun: rf, argument } => {
                let a = self.val(fr, *argument)?;
                let out = match rf {
                    naga::RelationalFunction::All | naga::RelationalFunction::Any => {
                        let all = matches!(rf, naga::RelationalFunction::All);
                        let mut acc = a[0];
                        for &x in &a[1..] {
                            acc = if all {
                                self.b.ins().band(acc, x)
                            } else {
                                self.b.ins().bor(acc, x)
                            };
                        }
                        vec![acc]
                    }
                    naga::RelationalFunction::IsNan => {
                        a.iter().map(|&x| self.b.ins().fcmp(FloatCC::Unordered, x, x)).collect()
                    }
                    naga::RelationalFunction::IsInf => a
                        .iter()
                        .map(|&x| {
                            let m = self.b.ins().fabs(x);
                            let inf = self.fconst(f64::INFINITY);
                            self.b.ins().fcmp(FloatCC::Equal, m, inf)
                        })
                        .collect(),
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
                let a = self.val(fr, *arg)?;
                let b = arg1.map(|x| self.val(fr, x)).transpose()?;
                let c = arg2.map(|x| self.val(fr, x)).transpose()?;
                let at = self.inner(fun, *arg);
                Slot::Val(
                    self.math(*mf, at, &a, b.as_deref(), c.as_deref())
                        .map_err(|m| self.at(fun, h, &m))?,
                )
            }
            E::As {
                expr,
                kind: to,
                convert,
            } => {
                if convert.is_none() {
                    return Err(self.at(fun, h, "bitcast is not compiled"));
                }
                let from = self.inner(fun, *expr).scalar_kind();
                let a = self.val(fr, *expr)?;
                let ft = self.fty();
                // The f64 SIMD path's integers are duplicated in I32X4: converted lane by lane.
                let wide = self.simd && self.mode == Mode::F64;
                let mut out = Vec::new();
                for x in a {
                    out.push(match (to, from) {
                        (ScalarKind::Float, Some(ScalarKind::Float)) => x,
                        (ScalarKind::Float, Some(ScalarKind::Sint | ScalarKind::Bool)) if wide => {
                            let w = match from {
                                Some(ScalarKind::Bool) => self.bool_to_int(x),
                                _ => x,
                            };
                            self.per_lane(&[w], &mut |s, a| {
                                let ft = s.fty();
                                s.b.ins().fcvt_from_sint(ft, a[0])
                            })
                        }
                        (ScalarKind::Float, Some(ScalarKind::Sint)) => self.b.ins().fcvt_from_sint(ft, x),
                        (ScalarKind::Float, Some(ScalarKind::Uint)) => self.per_lane(&[x], &mut |s, a| {
                            let ft = s.fty();
                            s.b.ins().fcvt_from_uint(ft, a[0])
                        }),
                        (ScalarKind::Float, Some(ScalarKind::Bool)) => {
                            let w = self.bool_to_int(x);
                            self.b.ins().fcvt_from_sint(ft, w)
                        }
                        (ScalarKind::Uint, Some(ScalarKind::Float)) => {
                            self.per_lane(&[x], &mut |s, a| s.b.ins().fcvt_to_uint_sat(types::I32, a[0]))
                        }
                        (ScalarKind::Sint, Some(ScalarKind::Float)) => {
                            self.per_lane(&[x], &mut |s, a| s.b.ins().fcvt_to_sint_sat(types::I32, a[0]))
                        }
                        (ScalarKind::Uint | ScalarKind::Sint, Some(ScalarKind::Uint | ScalarKind::Sint)) => x,
                        (ScalarKind::Uint | ScalarKind::Sint, Some(ScalarKind::Bool)) => self.bool_to_int(x),
                        (ScalarKind::Bool, Some(ScalarKind::Float)) => {
                            let z = self.fconst(0.0);
                            self.b.ins().fcmp(FloatCC::NotEqual, x, z)
                        }
                        (ScalarKind::Bool, Some(ScalarKind::Uint | ScalarKind::Sint)) => {
                            self.icmp_k(IntCC::NotEqual, x, 0)
                        }
                        (ScalarKind::Bool, Some(ScalarKind::Bool)) => x,
                        other => return Err(self.at(fun, h, &format!("conversion {other:?} is not compiled"))),
                    });
                }
                Slot::Val(out)
            }
            E::CallResult(_) => return Err(self.at(fun, h, "call result read before the call")),
            other => return Err(self.at(fun, h, &format!("expression {other:?} is not compiled"))),
        };
        fr.vals[self.lane][h.index()] = Some(slot);
        Ok(())
    }

    fn binary(&mut self, op: B, lt: &TypeInner, rt: &TypeInner, a: &[Value], b: &[Value]) -> R<Vec<Value>> {
        use TypeInner as T;
        let k = lt.scalar_kind();
        let float = k == Some(ScalarKind::Float);
        match (op, lt, rt) {
            (B::Multiply, T::Matrix { columns, rows, .. }, T::Vector { .. }) => {
                let r = *rows as usize;
                let mut out = Vec::new();
                for i in 0..r {
                    let mut acc = self.mul(a[i], b[0]);
                    for j in 1..*columns as usize {
                        let t = self.mul(a[j * r + i], b[j]);
                        acc = self.add(acc, t);
                    }
                    out.push(acc);
                }
                return Ok(out);
            }
            (B::Multiply, T::Vector { .. }, T::Matrix { columns, rows, .. }) => {
                let r = *rows as usize;
                return Ok((0..*columns as usize)
                    .map(|j| self.dot(a, &b[j * r..(j + 1) * r]))
                    .collect());
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
                        let mut acc = self.mul(a[i], b[j * ac]);
                        for kk in 1..ac {
                            let t = self.mul(a[kk * ar + i], b[j * ac + kk]);
                            acc = self.add(acc, t);
                        }
                        out.push(acc);
                    }
                }
                return Ok(out);
            }
            _ => {}
        }
        let len = a.len().max(b.len());
        let pick = |v: &[Value], i: usize| if v.len() == 1 { v[0] } else { v[i] };
        let signed = k == Some(ScalarKind::Sint);
        let mut out = Vec::with_capacity(len);
        for i in 0..len {
            let (x, y) = (pick(a, i), pick(b, i));
            let ins = self.b.ins();
            let fcmp = |cc| if float { Some(cc) } else { None };
            let icmp = |s: IntCC, u: IntCC| if signed { s } else { u };
            let v = match op {
                B::Add if float => ins.fadd(x, y),
                B::Subtract if float => ins.fsub(x, y),
                B::Multiply if float => ins.fmul(x, y),
                B::Divide if float => ins.fdiv(x, y),
                B::Modulo if float => self.call_shim(F::Rem, &[x, y]),
                B::Add => ins.iadd(x, y),
                B::Subtract => ins.isub(x, y),
                B::Multiply => ins.imul(x, y),
                B::Divide | B::Modulo if k == Some(ScalarKind::Bool) => return Err(format!("{op:?} on bool")),
                B::Divide | B::Modulo => self.per_lane(&[x, y], &mut |s, a| s.int_div(op, a[0], a[1], signed)),
                B::ShiftLeft | B::ShiftRight if self.simd => self.per_lane(&[x, y], &mut |s, a| match op {
                    B::ShiftLeft => s.b.ins().ishl(a[0], a[1]),
                    _ if signed => s.b.ins().sshr(a[0], a[1]),
                    _ => s.b.ins().ushr(a[0], a[1]),
                }),
                B::And => ins.band(x, y),
                B::InclusiveOr => ins.bor(x, y),
                B::ExclusiveOr => ins.bxor(x, y),
                B::ShiftLeft => ins.ishl(x, y),
                B::ShiftRight if signed => ins.sshr(x, y),
                B::ShiftRight => ins.ushr(x, y),
                B::Equal => match fcmp(FloatCC::Equal) {
                    Some(cc) => ins.fcmp(cc, x, y),
                    None => ins.icmp(IntCC::Equal, x, y),
                },
                B::NotEqual => match fcmp(FloatCC::NotEqual) {
                    Some(cc) => ins.fcmp(cc, x, y),
                    None => ins.icmp(IntCC::NotEqual, x, y),
                },
                B::Less => match fcmp(FloatCC::LessThan) {
                    Some(cc) => ins.fcmp(cc, x, y),
                    None => ins.icmp(icmp(IntCC::SignedLessThan, IntCC::UnsignedLessThan), x, y),
                },
                B::LessEqual => match fcmp(FloatCC::LessThanOrEqual) {
                    Some(cc) => ins.fcmp(cc, x, y),
                    None => ins.icmp(icmp(IntCC::SignedLessThanOrEqual, IntCC::UnsignedLessThanOrEqual), x, y),
                },
                B::Greater => match fcmp(FloatCC::GreaterThan) {
                    Some(cc) => ins.fcmp(cc, x, y),
                    None => ins.icmp(icmp(IntCC::SignedGreaterThan, IntCC::UnsignedGreaterThan), x, y),
                },
                B::GreaterEqual => match fcmp(FloatCC::GreaterThanOrEqual) {
                    Some(cc) => ins.fcmp(cc, x, y),
                    None => ins.icmp(
                        icmp(IntCC::SignedGreaterThanOrEqual, IntCC::UnsignedGreaterThanOrEqual),
                        x,
                        y,
                    ),
                },
                B::LogicalAnd => ins.band(x, y),
                B::LogicalOr => ins.bor(x, y),
            };
            let compare = matches!(
                op,
                B::Equal | B::NotEqual | B::Less | B::LessEqual | B::Greater | B::GreaterEqual
            );
            let v = if compare { self.as_mask(v) } else { v };
            out.push(v);
        }
        Ok(out)
    }

    /// WGSL integer `/` and `%` as `exec::int_op`: `x / 0 = x`, `x % 0 = 0`, and the one
    /// signed overflow `MIN / −1 = MIN` (wrapping), `MIN % −1 = 0`; never a trap.
    fn int_div(&mut self, op: B, x: Value, y: Value, signed: bool) -> Value {
        let one = self.b.ins().iconst(types::I32, 1);
        let zero = self.b.ins().iconst(types::I32, 0);
        let is_zero = self.icmp_k(IntCC::Equal, y, 0);
        let safe = if signed {
            let minus = self.icmp_k(IntCC::Equal, y, -1);
            let bad = self.b.ins().bor(is_zero, minus);
            let safe = self.sel(bad, one, y);
            let q = match op {
                B::Divide => self.b.ins().sdiv(x, safe),
                _ => self.b.ins().srem(x, safe),
            };
            // y = −1: x / −1 = −x (wrapping), x % −1 = 0.
            let neg = match op {
                B::Divide => self.b.ins().ineg(x),
                _ => zero,
            };
            self.sel(minus, neg, q)
        } else {
            let safe = self.sel(is_zero, one, y);
            match op {
                B::Divide => self.b.ins().udiv(x, safe),
                _ => self.b.ins().urem(x, safe),
            }
        };
        let by_zero = match op {
            B::Divide => x,
            _ => zero,
        };
        self.sel(is_zero, by_zero, safe)
    }

    fn math(&mut self, f: M, at: &TypeInner, a: &[Value], b: Option<&[Value]>, c: Option<&[Value]>) -> R<Vec<Value>> {
        let kind = at.scalar_kind();
        let float = kind == Some(ScalarKind::Float);
        let need = |v: Option<&[Value]>| {
            v.map(<[Value]>::to_vec)
                .ok_or_else(|| format!("{f:?}: missing argument"))
        };
        let pick = |v: &[Value], i: usize| v[if v.len() == 1 { 0 } else { i }];
        if !float {
            return self.int_math(f, kind, a, b, c);
        }
        let unary =
            |s: &mut Self, g: &dyn Fn(&mut Self, Value) -> Value| a.iter().map(|&x| g(s, x)).collect::<Vec<_>>();
        let shim1 = |s: &mut Self, which: F| a.iter().map(|&x| s.call_shim(which, &[x])).collect::<Vec<_>>();
        Ok(match f {
            M::Abs => unary(self, &|s, x| s.b.ins().fabs(x)),
            M::Sqrt => unary(self, &|s, x| s.b.ins().sqrt(x)),
            M::InverseSqrt => unary(self, &|s, x| s.rsqrt(x)),
            M::Sin => shim1(self, F::Sin),
            M::Cos => shim1(self, F::Cos),
            M::Tan => shim1(self, F::Tan),
            M::Asin => shim1(self, F::Asin),
            M::Acos => shim1(self, F::Acos),
            M::Atan => shim1(self, F::Atan),
            M::Exp => shim1(self, F::Exp),
            M::Exp2 => shim1(self, F::Exp2),
            M::Log => shim1(self, F::Log),
            M::Log2 => shim1(self, F::Log2),
            M::Floor => unary(self, &|s, x| s.per_lane(&[x], &mut |s, a| s.b.ins().floor(a[0]))),
            M::Ceil => unary(self, &|s, x| s.per_lane(&[x], &mut |s, a| s.b.ins().ceil(a[0]))),
            M::Trunc => unary(self, &|s, x| s.per_lane(&[x], &mut |s, a| s.b.ins().trunc(a[0]))),
            M::Round => unary(self, &|s, x| s.per_lane(&[x], &mut |s, a| s.b.ins().nearest(a[0]))),
            M::Fract => unary(self, &|s, x| {
                let fl = s.per_lane(&[x], &mut |s, a| s.b.ins().floor(a[0]));
                s.b.ins().fsub(x, fl)
            }),
            M::Saturate => unary(self, &|s, x| {
                // Rust's clamp: below 0 → 0, above 1 → 1, NaN and −0 kept.
                let (zero, one) = (s.fconst(0.0), s.fconst(1.0));
                let lo = s.b.ins().fcmp(FloatCC::LessThan, x, zero);
                let x = s.sel(lo, zero, x);
                let hi = s.b.ins().fcmp(FloatCC::GreaterThan, x, one);
                s.sel(hi, one, x)
            }),
            M::Sign => unary(self, &|s, x| {
                let (zero, one, minus) = (s.fconst(0.0), s.fconst(1.0), s.fconst(-1.0));
                let lt = s.b.ins().fcmp(FloatCC::LessThan, x, zero);
                let neg = s.sel(lt, minus, zero);
                let gt = s.b.ins().fcmp(FloatCC::GreaterThan, x, zero);
                s.sel(gt, one, neg)
            }),
            M::Min | M::Max | M::Atan2 | M::Pow | M::Step => {
                let b = need(b)?;
                (0..a.len())
                    .map(|i| {
                        let (x, y) = (pick(a, i), pick(&b, i));
                        match f {
                            M::Min => self.min_max(false, x, y),
                            M::Max => self.min_max(true, x, y),
                            M::Atan2 => self.call_shim(F::Atan2, &[x, y]),
                            M::Pow => self.call_shim(F::Pow, &[x, y]),
                            _ => {
                                // step(edge, v) = v >= edge
                                let ge = self.b.ins().fcmp(FloatCC::GreaterThanOrEqual, y, x);
                                let (one, zero) = (self.fconst(1.0), self.fconst(0.0));
                                self.sel(ge, one, zero)
                            }
                        }
                    })
                    .collect()
            }
            M::Clamp | M::Fma | M::Mix => {
                let (b, c) = (need(b)?, need(c)?);
                (0..a.len())
                    .map(|i| {
                        let (x, y, z) = (pick(a, i), pick(&b, i), pick(&c, i));
                        match f {
                            M::Clamp => {
                                let m = self.min_max(true, x, y);
                                self.min_max(false, m, z)
                            }
                            M::Fma => self.call_shim(F::Fma, &[x, y, z]),
                            _ => {
                                let one = self.fconst(1.0);
                                let u = self.sub(one, z);
                                let p = self.mul(x, u);
                                let q = self.mul(y, z);
                                self.add(p, q)
                            }
                        }
                    })
                    .collect()
            }
            M::Dot => {
                let b = need(b)?;
                vec![self.dot(a, &b)]
            }
            M::Cross => {
                let y = need(b)?;
                let mut out = Vec::new();
                for (i, j) in [(1, 2), (2, 0), (0, 1)] {
                    let p = self.mul(a[i], y[j]);
                    let q = self.mul(a[j], y[i]);
                    out.push(self.sub(p, q));
                }
                out
            }
            M::Length => {
                if a.len() == 1 {
                    vec![self.b.ins().fabs(a[0])]
                } else {
                    let d = self.dot(a, a);
                    vec![self.b.ins().sqrt(d)]
                }
            }
            M::Distance => {
                let b = need(b)?;
                let diff: Vec<Value> = (0..a.len()).map(|i| self.sub(a[i], b[i])).collect();
                let d = self.dot(&diff, &diff);
                vec![self.b.ins().sqrt(d)]
            }
            M::Normalize => {
                let d = self.dot(a, a);
                let r = self.rsqrt(d);
                a.iter().map(|&x| self.mul(x, r)).collect()
            }
            M::Determinant => match a.len() {
                4 => {
                    let p = self.mul(a[0], a[3]);
                    let q = self.mul(a[2], a[1]);
                    vec![self.sub(p, q)]
                }
                9 => {
                    let e = |c: usize, r: usize| a[3 * c + r];
                    let minor = |s: &mut Self, c1: usize, c2: usize, r1: usize, r2: usize| {
                        let p = s.mul(e(c1, r1), e(c2, r2));
                        let q = s.mul(e(c2, r1), e(c1, r2));
                        s.sub(p, q)
                    };
                    let m0 = minor(self, 1, 2, 1, 2);
                    let m1 = minor(self, 1, 2, 0, 2);
                    let m2 = minor(self, 1, 2, 0, 1);
                    let t0 = self.mul(e(0, 0), m0);
                    let t1 = self.mul(e(0, 1), m1);
                    let t2 = self.mul(e(0, 2), m2);
                    let s = self.sub(t0, t1);
                    vec![self.add(s, t2)]
                }
                n => return Err(format!("determinant of a {n}-component matrix")),
            },
            M::Transpose => {
                let TypeInner::Matrix { columns, rows, .. } = at else {
                    return Err("transpose of a non-matrix".into());
                };
                let (c, r) = (*columns as usize, *rows as usize);
                (0..r)
                    .flat_map(|i| (0..c).map(move |j| (i, j)))
                    .map(|(i, j)| a[j * r + i])
                    .collect()
            }
            other => return Err(format!("math function {other:?} is not compiled")),
        })
    }

    /// The integer built-ins the interpreter evaluates on exact integer values.
    fn int_math(
        &mut self,
        f: M,
        kind: Option<ScalarKind>,
        a: &[Value],
        b: Option<&[Value]>,
        c: Option<&[Value]>,
    ) -> R<Vec<Value>> {
        let signed = match kind {
            Some(ScalarKind::Sint) => true,
            Some(ScalarKind::Uint) => false,
            other => return Err(format!("{f:?} of {other:?} is not compiled")),
        };
        let pick = |v: &[Value], i: usize| v[if v.len() == 1 { 0 } else { i }];
        let min = |s: &mut Self, x, y| {
            if signed {
                s.b.ins().smin(x, y)
            } else {
                s.b.ins().umin(x, y)
            }
        };
        let max = |s: &mut Self, x, y| {
            if signed {
                s.b.ins().smax(x, y)
            } else {
                s.b.ins().umax(x, y)
            }
        };
        Ok(match (f, b, c) {
            (M::Min, Some(b), _) => (0..a.len()).map(|i| min(self, pick(a, i), pick(b, i))).collect(),
            (M::Max, Some(b), _) => (0..a.len()).map(|i| max(self, pick(a, i), pick(b, i))).collect(),
            (M::Clamp, Some(b), Some(c)) => (0..a.len())
                .map(|i| {
                    let m = max(self, pick(a, i), pick(b, i));
                    min(self, m, pick(c, i))
                })
                .collect(),
            (M::Abs, _, _) if !signed => a.to_vec(),
            _ => return Err(format!("integer {f:?} is not compiled")),
        })
    }
}
