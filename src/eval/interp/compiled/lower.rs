//! naga IR → Cranelift IR: a value domain of the walker (`eval/walk.rs`) whose values are
//! Cranelift values, one per lane. One configuration per call (control flow as branches),
//! or several with the interpreter's execution masks ([`Lower::masked_loop`] and the arms of
//! `if_` and `switch`): in SIMD vectors (f32 as F32X4, f64 as F64X2; one or more vectors per
//! call), or interleaved scalar lanes.
//!
//! The interpreter (`../exec.rs`) is the specification; the walker gives both the same
//! operations, scalar by scalar, in the same order, and this file makes each one:
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

use super::shims::{shim, F};
use crate::eval::program::{Const, Mode, Program};
use crate::eval::walk::{Arms, Domain, Frame, Looping, Slot, Walker};
use cranelift_codegen::ir::condcodes::{FloatCC, IntCC};
use cranelift_codegen::ir::{types, AbiParam, Block, InstBuilder, MemFlagsData, SigRef, Signature, Type, Value};
use cranelift_codegen::isa::CallConv;
use cranelift_codegen::settings::{self, Configurable};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext, Variable};
use cranelift_module::Module;
use naga::{BinaryOperator as B, Handle, MathFunction as M, ScalarKind, TypeInner, UnaryOperator as U};
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
            loc: crate::eval::program::NO_LINE,
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
        let (scene, out) = l.prologue()?;
        let mut w = Walker::new(p, l);
        let ret = w
            .call(p.method, vec![Slot::Val(scene)])?
            .ok_or("`method` returned nothing")?;
        let mut l = w.d;
        l.epilogue(&ret[0], out);
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
    /// more is the lane path (module doc).
    lanes: usize,
    /// The SIMD path: every value is a vector of [`simd_width`] configurations', masks are
    /// one vector per lane (`lanes` vectors per call), operations without a vector form are
    /// made lane by lane (`per_lane`). f32: F32X4, integers I32X4, booleans I32X4 masks of
    /// all ones or zeros. f64: F64X2, booleans I64X2 masks (what an F64X2 compare gives),
    /// integers I32X4 with configuration `j`'s value in lanes `2j` and `2j + 1` (so every
    /// lane-wise i32 operation keeps the two copies equal and an integer compare's I32X4
    /// mask, read as I64X2, is the boolean mask).
    simd: bool,
    /// The lane whose values are being written.
    lane: usize,
    /// The current expression's source line (errors name it).
    loc: u32,
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

    /// The function's start: read the scene (returned, one value per component, and the
    /// result pointer), set the private globals as the entry point does (compose.rs).
    fn prologue(&mut self) -> R<(Vec<Lv>, Value)> {
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
                        Some(init) => self.global_const(&p.global_consts[init.index()], &comps)?,
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
        Ok((by_component(scenes), out_ptr))
    }

    /// The function's end: `method`'s result `r` (per lane) written, the status returned.
    fn epilogue(&mut self, r: &Lv, out_ptr: Value) {
        let per = self.width();
        for (lane, &r) in r.iter().enumerate() {
            for v in 0..per {
                let x = if self.simd {
                    self.b.ins().extractlane(r, v as u8)
                } else {
                    r
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
    }

    /// A module constant as values: its f32 values, or in the f64 mode its written digits.
    fn global_const(&mut self, (v32, v64): &Const, comps: &[(Type, ScalarKind)]) -> R<Vec<Value>> {
        let vals = match self.mode {
            Mode::F32 => v32.clone(),
            Mode::F64 => v64.clone()?,
        };
        if vals.len() != comps.len() {
            return Err("a constant does not match its type".into());
        }
        Ok(comps.iter().zip(vals).map(|(&(t, _), v)| self.konst(t, v)).collect())
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

    fn load_one(&mut self, ptr: &Ptr) -> Vec<Value> {
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

    fn store_one(&mut self, ptr: &Ptr, vals: &[Value]) {
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
    fn leave_lanes(&mut self, to: Option<Vec<Variable>>) {
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
}

/// One component of a value, one machine value per lane.
type Lv = Vec<Value>;

/// Lane `l` of a value's components.
fn lane_of(v: &[Lv], l: usize) -> Vec<Value> {
    v.iter().map(|c| c[l]).collect()
}

/// Per-lane components as components of per-lane values.
fn by_component(per_lane: Vec<Vec<Value>>) -> Vec<Lv> {
    let len = per_lane.first().map_or(0, Vec::len);
    (0..len).map(|k| per_lane.iter().map(|v| v[k]).collect()).collect()
}

/// A call's return slot: its storage per lane (None for a void function), and the block
/// every `return` jumps to.
pub(super) struct Ret {
    ids: Option<Vec<usize>>,
    exit: Block,
}

impl<'p> Lower<'p, '_> {
    /// `f` on each lane's value.
    fn each(&mut self, a: &Lv, mut f: impl FnMut(&mut Self, Value) -> Value) -> Lv {
        a.iter().map(|&x| f(self, x)).collect()
    }

    /// `f` on each lane's two values.
    fn each2(&mut self, a: &Lv, b: &Lv, mut f: impl FnMut(&mut Self, Value, Value) -> Value) -> Lv {
        a.iter().zip(b).map(|(&x, &y)| f(self, x, y)).collect()
    }

    /// A constant in every lane.
    fn konsts(&mut self, t: Type, v: f64) -> Lv {
        (0..self.lanes).map(|_| self.konst(t, v)).collect()
    }

    /// An error at the current expression's line.
    fn located(&self, msg: &str) -> String {
        match self.p.lines.get(self.loc as usize) {
            Some(l) => format!("{}:{}: {msg} (`{}`)", l.path, l.line, l.text.trim()),
            None => msg.to_string(),
        }
    }

    /// `body` on the lanes of `m`, skipped when there are none; the lanes still running at
    /// its end.
    fn arm(w: &mut Walker<'_, Self>, fr: &mut Frame<Self>, body: &naga::Block, m: &[Value]) -> R<Vec<Value>> {
        let l = &mut w.d;
        if body.is_empty() {
            return Ok(m.to_vec());
        }
        l.set_mask(m);
        let any = l.any(m);
        let (run, join) = (l.b.create_block(), l.b.create_block());
        l.b.ins().brif(any, run, &[], join, &[]);
        l.switch(run);
        l.open = true;
        w.block(fr, body)?;
        let l = &mut w.d;
        l.b.ins().jump(join, &[]);
        l.switch(join);
        l.open = true;
        Ok(l.mask())
    }

    /// The integer built-ins the interpreter evaluates on exact integer values.
    fn int_math(&mut self, f: M, kind: Option<ScalarKind>, args: [Option<&[Lv]>; 3]) -> R<Vec<Lv>> {
        let signed = match kind {
            Some(ScalarKind::Sint) => true,
            Some(ScalarKind::Uint) => false,
            other => return Err(self.located(&format!("{f:?} of {other:?} is not compiled"))),
        };
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
        let [Some(a), b, c] = args else {
            return Err(self.located(&format!("{f:?}: missing argument")));
        };
        let pick = |v: &[Lv], i: usize| v[if v.len() == 1 { 0 } else { i }].clone();
        Ok(match (f, b, c) {
            (M::Min, Some(b), _) => (0..a.len()).map(|i| self.each2(&a[i], &pick(b, i), min)).collect(),
            (M::Max, Some(b), _) => (0..a.len()).map(|i| self.each2(&a[i], &pick(b, i), max)).collect(),
            (M::Clamp, Some(b), Some(c)) => (0..a.len())
                .map(|i| {
                    let m = self.each2(&a[i], &pick(b, i), max);
                    self.each2(&m, &pick(c, i), min)
                })
                .collect(),
            (M::Abs, _, _) if !signed => a.to_vec(),
            _ => return Err(self.located(&format!("integer {f:?} is not compiled"))),
        })
    }
}

impl<'p, 'b> Domain for Lower<'p, 'b> {
    type V = Lv;
    type P = Vec<Ptr>;
    type Ret = Ret;
    type Err = String;
    /// The caller's mask on the lane path.
    type Saved = Option<Vec<Value>>;

    fn at(&mut self, line: u32, _emitted: bool) {
        self.loc = line;
    }

    fn fail(&self, msg: String) -> String {
        self.located(&msg)
    }

    fn fail_statement(&self, msg: String) -> String {
        msg
    }

    /// Whether the current block still takes instructions (no jump or return yet). In the
    /// lane path: whether any lane can still run the rest of the current naga block.
    fn live(&self) -> bool {
        self.open
    }

    fn literal(&mut self, lit: naga::Literal, written: &Result<f64, String>) -> R<Lv> {
        let (t, v) = match lit {
            naga::Literal::F32(x) => match self.mode {
                Mode::F32 => (types::F32, f64::from(x)),
                Mode::F64 => (types::F64, written.clone().map_err(|m| self.located(&m))?),
            },
            naga::Literal::U32(x) => (types::I32, f64::from(x)),
            naga::Literal::I32(x) => (types::I32, f64::from(x)),
            naga::Literal::Bool(x) => (types::I8, f64::from(u8::from(x))),
            other => return Err(self.located(&format!("literal {other:?} is not compiled"))),
        };
        Ok(self.konsts(t, v))
    }

    fn constant(&mut self, c: &Const, ty: Handle<naga::Type>) -> R<Vec<Lv>> {
        let comps = self.ty_comps(ty)?;
        let per_lane = (0..self.lanes)
            .map(|_| self.global_const(c, &comps))
            .collect::<R<Vec<_>>>()
            .map_err(|m| self.located(&m))?;
        Ok(by_component(per_lane))
    }

    fn override_value(&mut self, v: f64, ty: &TypeInner) -> R<Lv> {
        let (t, _) = *self.comps(ty)?.first().ok_or("an override without a value")?;
        // The interpreter keeps an override's value unrounded until an f32 operation
        // reads it; only values exact in f32 behave the same here.
        if t == types::F32 && v as f32 as f64 != v && !v.is_nan() {
            return Err(self.located("an f32 override whose value is not exact in f32"));
        }
        Ok(self.konsts(t, v))
    }

    fn zero(&mut self, ty: Handle<naga::Type>) -> R<Vec<Lv>> {
        let comps = self.ty_comps(ty)?;
        Ok(comps.iter().map(|&(t, _)| self.konsts(t, 0.0)).collect())
    }

    fn float(&mut self, x: f64) -> Lv {
        let t = self.sty();
        self.konsts(t, x)
    }

    fn add(&mut self, a: &Lv, b: &Lv) -> R<Lv> {
        Ok(self.each2(a, b, |s, x, y| s.b.ins().fadd(x, y)))
    }
    fn sub(&mut self, a: &Lv, b: &Lv) -> R<Lv> {
        Ok(self.each2(a, b, |s, x, y| s.b.ins().fsub(x, y)))
    }
    fn mul(&mut self, a: &Lv, b: &Lv) -> R<Lv> {
        Ok(self.each2(a, b, |s, x, y| s.b.ins().fmul(x, y)))
    }
    fn div(&mut self, a: &Lv, b: &Lv) -> R<Lv> {
        Ok(self.each2(a, b, |s, x, y| s.b.ins().fdiv(x, y)))
    }
    fn rem(&mut self, a: &Lv, b: &Lv) -> R<Lv> {
        Ok(self.each2(a, b, |s, x, y| s.call_shim(F::Rem, &[x, y])))
    }

    fn int(&mut self, op: B, a: &Lv, b: &Lv, kind: Option<ScalarKind>) -> R<Lv> {
        let signed = kind == Some(ScalarKind::Sint);
        if matches!(op, B::Divide | B::Modulo) && kind == Some(ScalarKind::Bool) {
            return Err(self.located(&format!("{op:?} on bool")));
        }
        Ok(self.each2(a, b, |s, x, y| {
            let ins = s.b.ins();
            match op {
                B::Add => ins.iadd(x, y),
                B::Subtract => ins.isub(x, y),
                B::Multiply => ins.imul(x, y),
                B::Divide | B::Modulo => s.per_lane(&[x, y], &mut |s, a| s.int_div(op, a[0], a[1], signed)),
                B::ShiftLeft | B::ShiftRight if s.simd => s.per_lane(&[x, y], &mut |s, a| match op {
                    B::ShiftLeft => s.b.ins().ishl(a[0], a[1]),
                    _ if signed => s.b.ins().sshr(a[0], a[1]),
                    _ => s.b.ins().ushr(a[0], a[1]),
                }),
                B::And => ins.band(x, y),
                B::InclusiveOr => ins.bor(x, y),
                B::ExclusiveOr => ins.bxor(x, y),
                B::ShiftLeft => ins.ishl(x, y),
                B::ShiftRight if signed => ins.sshr(x, y),
                _ => ins.ushr(x, y),
            }
        }))
    }

    fn compare(&mut self, op: B, a: &Lv, b: &Lv, kind: Option<ScalarKind>) -> R<Lv> {
        let float = kind == Some(ScalarKind::Float);
        let signed = kind == Some(ScalarKind::Sint);
        let icmp = |s: IntCC, u: IntCC| if signed { s } else { u };
        let (f, i) = match op {
            B::Equal => (FloatCC::Equal, IntCC::Equal),
            B::NotEqual => (FloatCC::NotEqual, IntCC::NotEqual),
            B::Less => (FloatCC::LessThan, icmp(IntCC::SignedLessThan, IntCC::UnsignedLessThan)),
            B::LessEqual => (
                FloatCC::LessThanOrEqual,
                icmp(IntCC::SignedLessThanOrEqual, IntCC::UnsignedLessThanOrEqual),
            ),
            B::Greater => (
                FloatCC::GreaterThan,
                icmp(IntCC::SignedGreaterThan, IntCC::UnsignedGreaterThan),
            ),
            _ => (
                FloatCC::GreaterThanOrEqual,
                icmp(IntCC::SignedGreaterThanOrEqual, IntCC::UnsignedGreaterThanOrEqual),
            ),
        };
        Ok(self.each2(a, b, |s, x, y| {
            let v = if float {
                s.b.ins().fcmp(f, x, y)
            } else {
                s.b.ins().icmp(i, x, y)
            };
            s.as_mask(v)
        }))
    }

    fn logical(&mut self, op: B, a: &Lv, b: &Lv) -> R<Lv> {
        Ok(self.each2(a, b, |s, x, y| match op {
            B::LogicalAnd => s.b.ins().band(x, y),
            _ => s.b.ins().bor(x, y),
        }))
    }

    fn unary(&mut self, op: U, a: &Lv, kind: Option<ScalarKind>) -> R<Lv> {
        match (op, kind) {
            (U::Negate, Some(ScalarKind::Float)) => Ok(self.each(a, |s, x| s.b.ins().fneg(x))),
            (U::Negate, Some(ScalarKind::Sint)) => Ok(self.each(a, |s, x| s.b.ins().ineg(x))),
            (U::LogicalNot, _) => Ok(self.each(a, |s, x| s.icmp_k(IntCC::Equal, x, 0))),
            (U::BitwiseNot, Some(ScalarKind::Sint | ScalarKind::Uint)) => Ok(self.each(a, |s, x| s.b.ins().bnot(x))),
            _ => Err(self.located(&format!("{op:?} on {kind:?} is not compiled"))),
        }
    }

    fn select(&mut self, c: &Lv, a: &Lv, r: &Lv) -> R<Lv> {
        Ok((0..c.len()).map(|l| self.sel(c[l], a[l], r[l])).collect())
    }

    fn relational(&mut self, f: naga::RelationalFunction, a: &[Lv]) -> R<Vec<Lv>> {
        use naga::RelationalFunction as RF;
        Ok(match f {
            RF::All | RF::Any => {
                let all = matches!(f, RF::All);
                let mut acc = a[0].clone();
                for x in &a[1..] {
                    acc = self.each2(
                        &acc,
                        x,
                        |s, p, q| {
                            if all {
                                s.b.ins().band(p, q)
                            } else {
                                s.b.ins().bor(p, q)
                            }
                        },
                    );
                }
                vec![acc]
            }
            RF::IsNan => a
                .iter()
                .map(|x| self.each(x, |s, x| s.b.ins().fcmp(FloatCC::Unordered, x, x)))
                .collect(),
            RF::IsInf => a
                .iter()
                .map(|x| {
                    self.each(x, |s, x| {
                        let m = s.b.ins().fabs(x);
                        let inf = s.fconst(f64::INFINITY);
                        s.b.ins().fcmp(FloatCC::Equal, m, inf)
                    })
                })
                .collect(),
        })
    }

    fn convert(&mut self, to: ScalarKind, from: Option<ScalarKind>, a: &Lv) -> R<Lv> {
        let ft = self.fty();
        // The f64 SIMD path's integers are duplicated in I32X4: converted lane by lane.
        let wide = self.simd && self.mode == Mode::F64;
        let mut out = Vec::with_capacity(a.len());
        for &x in a {
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
                (ScalarKind::Bool, Some(ScalarKind::Uint | ScalarKind::Sint)) => self.icmp_k(IntCC::NotEqual, x, 0),
                (ScalarKind::Bool, Some(ScalarKind::Bool)) => x,
                other => return Err(self.located(&format!("conversion {other:?} is not compiled"))),
            });
        }
        Ok(out)
    }

    /// Integer built-ins, from the interpreter's exact integer values.
    fn math_special(&mut self, f: M, at: &TypeInner, _ty: &TypeInner, args: [Option<&[Lv]>; 3]) -> Option<R<Vec<Lv>>> {
        let kind = at.scalar_kind();
        (kind != Some(ScalarKind::Float)).then(|| self.int_math(f, kind, args))
    }

    fn math1(&mut self, f: M, a: &Lv, _kind: Option<ScalarKind>) -> R<Lv> {
        let shim = |which: F| move |s: &mut Self, x: Value| s.call_shim(which, &[x]);
        Ok(match f {
            M::Abs => self.each(a, |s, x| s.b.ins().fabs(x)),
            M::Sqrt => self.each(a, |s, x| s.b.ins().sqrt(x)),
            M::InverseSqrt => self.each(a, |s, x| s.rsqrt(x)),
            M::Sin => self.each(a, shim(F::Sin)),
            M::Cos => self.each(a, shim(F::Cos)),
            M::Tan => self.each(a, shim(F::Tan)),
            M::Asin => self.each(a, shim(F::Asin)),
            M::Acos => self.each(a, shim(F::Acos)),
            M::Atan => self.each(a, shim(F::Atan)),
            M::Exp => self.each(a, shim(F::Exp)),
            M::Exp2 => self.each(a, shim(F::Exp2)),
            M::Log => self.each(a, shim(F::Log)),
            M::Log2 => self.each(a, shim(F::Log2)),
            M::Floor => self.each(a, |s, x| s.per_lane(&[x], &mut |s, a| s.b.ins().floor(a[0]))),
            M::Ceil => self.each(a, |s, x| s.per_lane(&[x], &mut |s, a| s.b.ins().ceil(a[0]))),
            M::Trunc => self.each(a, |s, x| s.per_lane(&[x], &mut |s, a| s.b.ins().trunc(a[0]))),
            M::Round => self.each(a, |s, x| s.per_lane(&[x], &mut |s, a| s.b.ins().nearest(a[0]))),
            M::Fract => self.each(a, |s, x| {
                let fl = s.per_lane(&[x], &mut |s, a| s.b.ins().floor(a[0]));
                s.b.ins().fsub(x, fl)
            }),
            M::Saturate => self.each(a, |s, x| {
                // Rust's clamp: below 0 → 0, above 1 → 1, NaN and −0 kept.
                let (zero, one) = (s.fconst(0.0), s.fconst(1.0));
                let lo = s.b.ins().fcmp(FloatCC::LessThan, x, zero);
                let x = s.sel(lo, zero, x);
                let hi = s.b.ins().fcmp(FloatCC::GreaterThan, x, one);
                s.sel(hi, one, x)
            }),
            M::Sign => self.each(a, |s, x| {
                let (zero, one, minus) = (s.fconst(0.0), s.fconst(1.0), s.fconst(-1.0));
                let lt = s.b.ins().fcmp(FloatCC::LessThan, x, zero);
                let neg = s.sel(lt, minus, zero);
                let gt = s.b.ins().fcmp(FloatCC::GreaterThan, x, zero);
                s.sel(gt, one, neg)
            }),
            other => return Err(self.located(&format!("math function {other:?} is not compiled"))),
        })
    }

    fn math2(&mut self, f: M, a: &Lv, b: &Lv, _kind: Option<ScalarKind>) -> R<Lv> {
        Ok(self.each2(a, b, |s, x, y| match f {
            M::Min => s.min_max(false, x, y),
            M::Max => s.min_max(true, x, y),
            M::Atan2 => s.call_shim(F::Atan2, &[x, y]),
            M::Pow => s.call_shim(F::Pow, &[x, y]),
            _ => {
                // step(edge, v) = v >= edge
                let ge = s.b.ins().fcmp(FloatCC::GreaterThanOrEqual, y, x);
                let (one, zero) = (s.fconst(1.0), s.fconst(0.0));
                s.sel(ge, one, zero)
            }
        }))
    }

    fn math3(&mut self, f: M, a: &Lv, b: &Lv, c: &Lv, _kind: Option<ScalarKind>) -> R<Lv> {
        Ok((0..a.len())
            .map(|l| {
                let (x, y, z) = (a[l], b[l], c[l]);
                match f {
                    M::Clamp => {
                        let m = self.min_max(true, x, y);
                        self.min_max(false, m, z)
                    }
                    _ => self.call_shim(F::Fma, &[x, y, z]),
                }
            })
            .collect())
    }

    fn local(&mut self, ty: Handle<naga::Type>) -> R<Vec<Ptr>> {
        let c = self.ty_comps(ty)?;
        let len = self.p.flat[ty.index()];
        Ok((0..self.lanes)
            .map(|_| Ptr {
                store: self.storage(&c, None),
                off: Off::Const(0),
                len,
            })
            .collect())
    }

    /// Not called: the entry binds the private globals itself ([`Lower::prologue`]), and
    /// no other global is compiled.
    fn bind(&mut self, _g: Handle<naga::GlobalVariable>, _v: Vec<Lv>) {}

    fn global(&mut self, g: Handle<naga::GlobalVariable>, len: usize) -> R<Vec<Ptr>> {
        let stores = self.globals[g.index()]
            .clone()
            .ok_or_else(|| self.located("a global outside the private space is not compiled"))?;
        Ok(stores
            .into_iter()
            .map(|store| Ptr {
                store,
                off: Off::Const(0),
                len,
            })
            .collect())
    }

    fn child(&mut self, p: &Vec<Ptr>, off: usize, len: usize) -> Vec<Ptr> {
        p.iter()
            .map(|ptr| {
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
                Ptr {
                    store: ptr.store,
                    off,
                    len,
                }
            })
            .collect()
    }

    fn held(&self, p: &Vec<Ptr>) -> usize {
        p.first().map_or(0, |ptr| self.stores[ptr.store].len())
    }

    fn index(&mut self, p: &Vec<Ptr>, idx: &Lv, count: usize, stride: usize, signed: bool) -> R<Vec<Ptr>> {
        let mut out = Vec::with_capacity(p.len());
        for (ptr, &raw) in p.iter().zip(idx) {
            let idx = self.clamp_index(raw, signed, count);
            let Off::Const(base) = ptr.off else {
                return Err(self.located("two dynamic indices into one variable are not compiled"));
            };
            out.push(Ptr {
                store: ptr.store,
                off: Off::Dyn {
                    base,
                    idx,
                    stride,
                    count,
                },
                len: stride,
            });
        }
        Ok(out)
    }

    fn index_value(&mut self, v: &[Lv], idx: &Lv, count: usize, stride: usize, signed: bool) -> R<Vec<Lv>> {
        let per_lane = (0..idx.len())
            .map(|l| {
                let idx = self.clamp_index(idx[l], signed, count);
                (0..stride)
                    .map(|c| {
                        let mut x = v[c][l];
                        for k in 1..count {
                            let hit = self.icmp_k(IntCC::Equal, idx, k as i64);
                            x = self.sel(hit, v[k * stride + c][l], x);
                        }
                        x
                    })
                    .collect()
            })
            .collect();
        Ok(by_component(per_lane))
    }

    fn load(&mut self, p: &Vec<Ptr>) -> R<Vec<Lv>> {
        let per_lane = p.iter().map(|ptr| self.load_one(ptr)).collect();
        Ok(by_component(per_lane))
    }

    fn store(&mut self, p: &Vec<Ptr>, v: &[Lv]) -> R<()> {
        for (lane, ptr) in p.iter().enumerate() {
            self.lane = lane;
            let v = lane_of(v, lane);
            self.store_one(ptr, &v);
        }
        Ok(())
    }

    fn init(&mut self, p: &Vec<Ptr>, v: Vec<Lv>) {
        for (lane, ptr) in p.iter().enumerate() {
            self.lane = lane;
            let v = lane_of(&v, lane);
            self.write(ptr.store, 0, &v);
        }
    }

    /// A call, inlined: its return storage per lane and the block it leaves by.
    fn enter(&mut self, result: Option<Handle<naga::Type>>) -> R<(Option<Vec<Value>>, Ret)> {
        if self.depth >= MAX_DEPTH {
            return Err(format!("calls nested deeper than {MAX_DEPTH}"));
        }
        self.depth += 1;
        let exit = self.b.create_block();
        let ids = match result {
            Some(t) => {
                let c = self.ty_comps(t)?;
                Some((0..self.lanes).map(|_| self.storage(&c, None)).collect::<Vec<_>>())
            }
            None => None,
        };
        // The lanes that call leave together at the end (those that returned early hold
        // their result in `ret`).
        let entry = self.masked().then(|| self.mask());
        Ok((entry, Ret { ids, exit }))
    }

    fn leave(&mut self, entry: Option<Vec<Value>>, ret: Ret) -> Option<Vec<Lv>> {
        match entry {
            Some(entry) => {
                self.b.ins().jump(ret.exit, &[]);
                self.switch(ret.exit);
                self.set_mask(&entry);
            }
            None => {
                if self.open {
                    self.b.ins().jump(ret.exit, &[]);
                }
                self.switch(ret.exit);
            }
        }
        self.open = true;
        self.depth -= 1;
        let ids = ret.ids?;
        let per_lane = ids.iter().map(|&s| self.read(s, 0, self.stores[s].len())).collect();
        Some(by_component(per_lane))
    }

    fn if_(w: &mut Walker<'_, Self>, fr: &mut Frame<Self>, c: &Lv, arms: Arms) -> R<()> {
        let Arms { accept, reject } = arms;
        let l = &mut w.d;
        if l.masked() {
            let parent = l.mask();
            let yes = l.and(&parent, c);
            let no = l.and_not(&parent, c);
            let a = Self::arm(w, fr, accept, &yes)?;
            let r = Self::arm(w, fr, reject, &no)?;
            let l = &mut w.d;
            let m = l.or(&a, &r);
            l.set_mask(&m);
            l.open = true;
            return Ok(());
        }
        let (yes, no, merge) = (l.b.create_block(), l.b.create_block(), l.b.create_block());
        l.b.ins().brif(c[0], yes, &[], no, &[]);
        for (blk, body) in [(yes, accept), (no, reject)] {
            w.d.switch(blk);
            w.d.open = true;
            w.block(fr, body)?;
            if w.d.open {
                w.d.b.ins().jump(merge, &[]);
            }
        }
        w.d.switch(merge);
        w.d.open = true;
        Ok(())
    }

    fn switch(w: &mut Walker<'_, Self>, fr: &mut Frame<Self>, sel: &Lv, cases: &[naga::SwitchCase]) -> R<()> {
        let value = |case: &naga::SwitchCase| match case.value {
            naga::SwitchValue::I32(i) => Some(i64::from(i)),
            naga::SwitchValue::U32(u) => Some(i64::from(u as i32)),
            naga::SwitchValue::Default => None,
        };
        if w.d.masked() {
            let l = &mut w.d;
            let entry = l.mask();
            let mut hits = Vec::with_capacity(cases.len());
            let mut matched = l.zeros();
            for case in cases {
                let Some(v) = value(case) else {
                    hits.push(None);
                    continue;
                };
                let h: Vec<Value> = sel.iter().map(|&s| l.icmp_k(IntCC::Equal, s, v)).collect();
                matched = l.or(&matched, &h);
                hits.push(Some(h));
            }
            let zeros = l.zeros();
            let brk = l.lane_vars(&zeros);
            l.ltargets.push(LTarget::Switch { brk: brk.clone() });
            let (mut carry, mut done) = (zeros.clone(), zeros);
            for (case, hit) in cases.iter().zip(hits) {
                let l = &mut w.d;
                let hit = match hit {
                    Some(h) => l.and(&entry, &h),
                    None => l.and_not(&entry, &matched),
                };
                let m = l.or(&hit, &carry);
                let end = Self::arm(w, fr, &case.body, &m)?;
                if case.fall_through {
                    carry = end;
                } else {
                    done = w.d.or(&done, &end);
                    carry = w.d.zeros();
                }
            }
            let l = &mut w.d;
            l.ltargets.pop();
            let b: Vec<Value> = brk.iter().map(|&v| l.b.use_var(v)).collect();
            let m = l.or(&done, &carry);
            let m = l.or(&m, &b);
            l.set_mask(&m);
            l.open = true;
            return Ok(());
        }
        let l = &mut w.d;
        let merge = l.b.create_block();
        let bodies: Vec<Block> = cases.iter().map(|_| l.b.create_block()).collect();
        let mut default = None;
        for (case, &body) in cases.iter().zip(&bodies) {
            let Some(v) = value(case) else {
                default = Some(body);
                continue;
            };
            let next = l.b.create_block();
            let hit = l.icmp_k(IntCC::Equal, sel[0], v);
            l.b.ins().brif(hit, body, &[], next, &[]);
            l.switch(next);
        }
        l.b.ins().jump(default.unwrap_or(merge), &[]);
        l.targets.push((merge, None));
        for (i, case) in cases.iter().enumerate() {
            w.d.switch(bodies[i]);
            w.d.open = true;
            w.block(fr, &case.body)?;
            if w.d.open {
                let to = match (case.fall_through, bodies.get(i + 1)) {
                    (true, Some(&b)) => b,
                    _ => merge,
                };
                w.d.b.ins().jump(to, &[]);
            }
        }
        w.d.targets.pop();
        w.d.switch(merge);
        w.d.open = true;
        Ok(())
    }

    fn loop_(w: &mut Walker<'_, Self>, fr: &mut Frame<Self>, lp: Looping) -> R<()> {
        if w.d.masked() {
            return Self::masked_loop(w, fr, lp);
        }
        let (body, continuing, break_if) = (lp.body, lp.continuing, lp.break_if);
        let l = &mut w.d;
        let count = l.counter();
        let (head, first, cont, exit) = (
            l.b.create_block(),
            l.b.create_block(),
            l.b.create_block(),
            l.b.create_block(),
        );
        l.b.ins().jump(head, &[]);
        l.trip(head, count, first);
        l.open = true;
        l.targets.push((exit, Some(cont)));
        l.loops += 1;
        w.block(fr, body)?;
        if w.d.open {
            w.d.b.ins().jump(cont, &[]);
        }
        w.d.switch(cont);
        w.d.open = true;
        w.block(fr, continuing)?;
        if w.d.open {
            match break_if {
                Some(c) => {
                    let c = w.val(fr, c)?[0][0];
                    w.d.b.ins().brif(c, exit, &[], head, &[]);
                }
                None => {
                    w.d.b.ins().jump(head, &[]);
                }
            }
        }
        let l = &mut w.d;
        l.targets.pop();
        l.loops -= 1;
        l.switch(exit);
        l.open = true;
        Ok(())
    }

    fn break_(&mut self) -> R<()> {
        if self.masked() {
            let to = match self.ltargets.last().ok_or("`break` outside a loop")? {
                LTarget::Loop { brk, .. } | LTarget::Switch { brk } => brk.clone(),
            };
            self.leave_lanes(Some(to));
            return Ok(());
        }
        let (to, _) = *self.targets.last().ok_or("`break` outside a loop")?;
        self.b.ins().jump(to, &[]);
        self.open = false;
        Ok(())
    }

    fn continue_(&mut self) -> R<()> {
        if self.masked() {
            let to = self
                .ltargets
                .iter()
                .rev()
                .find_map(|t| match t {
                    LTarget::Loop { cont, .. } => Some(cont.clone()),
                    LTarget::Switch { .. } => None,
                })
                .ok_or("`continue` outside a loop")?;
            self.leave_lanes(Some(to));
            return Ok(());
        }
        let to = self
            .targets
            .iter()
            .rev()
            .find_map(|t| t.1)
            .ok_or("`continue` outside a loop")?;
        self.b.ins().jump(to, &[]);
        self.open = false;
        Ok(())
    }

    fn return_(&mut self, ret: &mut Ret, v: Option<&[Lv]>) -> R<()> {
        if let Some(v) = v {
            let ids = ret.ids.clone().ok_or("return value in a void function")?;
            let lanes = if self.masked() { ids.len() } else { 1 };
            for (lane, &id) in ids.iter().enumerate().take(lanes) {
                self.lane = lane;
                let v = lane_of(v, lane);
                self.write(id, 0, &v);
            }
        }
        if self.masked() {
            self.leave_lanes(None);
        } else {
            self.b.ins().jump(ret.exit, &[]);
            self.open = false;
        }
        Ok(())
    }
}

impl<'p> Lower<'p, '_> {
    /// A loop's trip counter, 0.
    fn counter(&mut self) -> Variable {
        let count = self.b.declare_var(types::I32);
        let zero = self.b.ins().iconst(types::I32, 0);
        self.b.def_var(count, zero);
        count
    }

    /// A loop's head block: one more trip counted, status 1 past the limit, else on to
    /// `first`.
    fn trip(&mut self, head: Block, count: Variable, first: Block) {
        self.switch(head);
        let n = self.b.use_var(count);
        let n = self.b.ins().iadd_imm_s(n, 1);
        self.b.def_var(count, n);
        let over = self.icmp_k(IntCC::SignedGreaterThan, n, LOOP_LIMIT);
        let fail = self.fail_block();
        self.b.ins().brif(over, fail, &[], first, &[]);
        self.switch(first);
    }

    /// A loop on the lane path: it runs while any lane is in it.
    fn masked_loop(w: &mut Walker<'_, Self>, fr: &mut Frame<Self>, lp: Looping) -> R<()> {
        let (body, continuing, break_if) = (lp.body, lp.continuing, lp.break_if);
        let l = &mut w.d;
        let entry = l.mask();
        // `live`: lanes still looping; `brk`: lanes that left by `break` or
        // `break if`; `cont`: lanes that took `continue` this pass.
        let live = l.lane_vars(&entry);
        let zeros = l.zeros();
        let brk = l.lane_vars(&zeros);
        let cont = l.lane_vars(&zeros);
        let count = l.counter();
        let (head, first, exit) = (l.b.create_block(), l.b.create_block(), l.b.create_block());
        let any = l.any(&entry);
        l.b.ins().brif(any, head, &[], exit, &[]);
        l.trip(head, count, first);
        let m: Vec<Value> = live.iter().map(|&v| l.b.use_var(v)).collect();
        l.set_mask(&m);
        let z = l.zeros();
        for (&v, &x) in cont.iter().zip(&z) {
            l.b.def_var(v, x);
        }
        l.ltargets.push(LTarget::Loop {
            brk: brk.clone(),
            cont: cont.clone(),
        });
        l.loops += 1;
        l.open = true;
        w.block(fr, body)?;
        let l = &mut w.d;
        l.open = true;
        let m = l.mask();
        let k: Vec<Value> = cont.iter().map(|&v| l.b.use_var(v)).collect();
        let m = l.or(&m, &k);
        l.set_mask(&m);
        w.block(fr, continuing)?;
        w.d.open = true;
        let m = w.d.mask();
        let stay = match break_if {
            Some(c) => {
                let c = w.val(fr, c)?[0].clone();
                let l = &mut w.d;
                let out = l.and(&m, &c);
                for (i, &x) in out.iter().enumerate() {
                    let old = l.b.use_var(brk[i]);
                    let v = l.b.ins().bor(old, x);
                    l.b.def_var(brk[i], v);
                }
                l.and_not(&m, &c)
            }
            None => m,
        };
        let l = &mut w.d;
        for (&v, &x) in live.iter().zip(&stay) {
            l.b.def_var(v, x);
        }
        let again = l.any(&stay);
        l.b.ins().brif(again, head, &[], exit, &[]);
        l.ltargets.pop();
        l.loops -= 1;
        l.switch(exit);
        let m: Vec<Value> = brk.iter().map(|&v| l.b.use_var(v)).collect();
        l.set_mask(&m);
        l.open = true;
        Ok(())
    }
}
