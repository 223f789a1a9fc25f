//! The CPU evaluator of naga IR: a method's composed kernel (the same WGSL the GPU runs)
//! evaluated on the CPU, so the kernel file is the only place its formula is written.
//!
//! - [`Mode::F32`]: IEEE single precision. `+ − × ÷ √ fma` are Rust's `f32` operations
//!   (correctly rounded), `inverseSqrt` is rounded once from f64; `sin cos tan asin acos
//!   atan atan2 exp log pow` come from the `libm` crate (a port of musl's libm), whose
//!   accuracy `tests::libm_f32_accuracy` measures and prints. Composite built-ins are
//!   spelled out in f32 steps: `dot` left to right, `length = sqrt(dot)`, `normalize =
//!   v·inverseSqrt(dot)` (as drivers lower them), `cross`, `determinant` by cofactors.
//! - [`Mode::F64`]: the kernel promoted to double. Every float constant is read from its
//!   written digits in the source (`digits.rs`), never through the f32 naga stores.
//! - [`Program::attribute`]: f32 with an f64 shadow of every value (same control flow),
//!   and each float operation's local error (Herbie): the op in f32 on the shadow's
//!   arguments rounded to f32, against the exact (f64) op on the shadow's arguments, in
//!   bits (`log2(1 + ulps)`), summed per kernel source line.
//!
//! Configurations run in chunks, one IR operation over a whole chunk at a time
//! (`exec.rs`), chunks in parallel with rayon.

mod compiled;
mod digits;
mod envelope;
mod exec;

use crate::input::scene::Config;
use crate::kernel::methods::Method;
use crate::kernel::{compose_with, Composed};
use anyhow::{anyhow, Context, Result};
use naga::{Expression as E, Handle, TypeInner};
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

pub use compiled::{Path, LANES};
pub use envelope::{Outcome as EnvelopeOutcome, Stop as EnvelopeStop};
pub use exec::ulp_bits;

/// Configurations per chunk: enough lanes to amortise the per-operation dispatch.
const CHUNK: usize = 1024;
const NO_LINE: u32 = u32::MAX;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    F32,
    F64,
}

/// Which evaluator runs a kernel's values: this interpreter (the specification) or the
/// same kernel compiled to native code (`compiled/`, bit-identical, much faster).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Engine {
    Interpreter,
    Compiled,
}

impl Engine {
    pub fn name(self) -> &'static str {
        match self {
            Engine::Interpreter => "interpreter",
            Engine::Compiled => "compiled",
        }
    }
}

/// `LINELIGHT_EVALUATOR=interpreter` runs every value on the interpreter (to compare
/// timings, or to rule the compiler out); otherwise the compiled evaluator runs every
/// kernel it compiles.
fn interpreter_forced() -> bool {
    static FORCED: OnceLock<bool> = OnceLock::new();
    *FORCED.get_or_init(|| std::env::var("LINELIGHT_EVALUATOR").is_ok_and(|v| v == "interpreter"))
}

/// A flattened constant: its f32 values and its written digits in f64.
type Const = (Vec<f64>, Result<Vec<f64>, String>);

/// A kernel source line that operations were attributed to.
#[derive(Clone, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub struct Line {
    pub path: String,
    pub line: usize,
    pub text: String,
}

struct FunMeta {
    /// Expressions some `Emit` evaluates (the others are evaluated on entry).
    emitted: Vec<bool>,
    /// Expressions whose value is the same on every call (literals, constants, globals).
    constant: Vec<bool>,
    /// An f32 literal's written digits (or why they cannot be read).
    lit64: Vec<Result<f64, String>>,
    /// Index into [`Program::lines`] of each expression, or `NO_LINE`.
    line: Vec<u32>,
}

/// A method's kernel, composed and prepared for evaluation.
pub struct Program {
    module: naga::Module,
    info: naga::valid::ModuleInfo,
    method: Handle<naga::Function>,
    /// Scalar components of each type.
    flat: Vec<usize>,
    global_consts: Vec<Const>,
    funs: Vec<FunMeta>,
    overrides: Vec<f64>,
    pub lines: Vec<Line>,
    /// `Scene` members: name, component offset, length.
    scene: Vec<(String, usize, usize)>,
    scene_minv: (usize, usize),
    /// Whether a function reads `ll_ltc` (the harness's LTC tables, binding 4): only then is
    /// the table given to the run ([`ltc_tables`]).
    reads_ltc: bool,
    /// Constants of a translated kernel (GLSL, HLSL) whose written digits are lost: the f64
    /// evaluation is refused (src/kernel/written.rs).
    lost_digits: Vec<String>,
    /// The compiled kernel per mode (f32, f64), made on first use, or why it cannot be.
    compiled: [OnceLock<Result<compiled::Compiled, String>>; 2],
}

/// The evaluator's program for `method` (composed once, then cached for the process).
pub fn program(method: &Method) -> Result<Arc<Program>> {
    static CACHE: OnceLock<Mutex<HashMap<String, Arc<Program>>>> = OnceLock::new();
    let inner = method.inner.as_deref();
    let key = format!(
        "{:?}\0{:?}\0{:?}\0{:?}",
        method.kernel.parts(),
        method.params,
        inner.map(|m| m.kernel.parts()),
        inner.map(|m| &m.params)
    );
    let cache = CACHE.get_or_init(Default::default);
    if let Some(p) = cache.lock().expect("cache lock").get(&key) {
        return Ok(p.clone());
    }
    let p = Arc::new(Program::new(method).with_context(|| format!("CPU evaluator for {}", method.describe()))?);
    cache.lock().expect("cache lock").insert(key, p.clone());
    Ok(p)
}

/// [`Program::ltc_lanes`]'s value, made once per thread (its components are `Rc`s): one
/// one-lane component per float.
fn ltc_tables() -> exec::Val {
    thread_local! {
        static T: exec::Val = exec::Val(
            crate::input::ltc::device::ours()
                .iter()
                .map(|&x| exec::lanes(vec![f64::from(x)]))
                .collect(),
        );
    }
    T.with(Clone::clone)
}

/// A method's `f64` and `cpu_f32` columns from its own kernel on the CPU evaluator. A trait
/// of this module, so that the method (src/methods) does not depend on the evaluator.
pub trait CpuColumns {
    /// [`CpuColumns::cpu_column`] on the given evaluator (an error where `Compiled` is asked
    /// for and the kernel is not compiled).
    fn cpu_column_on(&self, configs: &[Config], mode: Mode, engine: Engine) -> Result<Vec<Option<f64>>>;
    /// The kernel's `f64` (or `cpu_f32`) column on `configs`: None where the method does not
    /// apply to a configuration. For a `ggx` configuration the kernel sees the fed (rotated)
    /// configuration, and an LTC method's result is multiplied by the fed magnitude in the
    /// mode's precision, as a shader multiplies; a `minv: ggx` kernel evaluates the lobe itself
    /// and is not scaled ([`Method::magnitude`]).
    fn cpu_column(&self, configs: &[Config], mode: Mode) -> Result<Vec<Option<f64>>>;
    /// [`CpuColumns::cpu_column`], or where the evaluator cannot run this kernel (an `f16`
    /// kernel, an IR construct it lacks) no values, with a note on stderr once per method:
    /// the GPU column still stands.
    fn cpu_column_or_none(&self, configs: &[Config], mode: Mode) -> Vec<Option<f64>>;
    /// The kernel's own formula in double precision for one configuration; None when the
    /// evaluator cannot run this kernel (the reason is in [`CpuColumns::cpu_column`]'s error).
    fn eval_f64(&self, config: &Config) -> Option<f64>;
    /// The kernel in IEEE single precision on the CPU (beside the GPU's f32).
    fn eval_f32_cpu(&self, config: &Config) -> Option<f32>;
}

impl CpuColumns for Method {
    fn cpu_column(&self, configs: &[Config], mode: Mode) -> Result<Vec<Option<f64>>> {
        let engine = program(self)?.engine(mode);
        self.cpu_column_on(configs, mode, engine)
    }

    fn cpu_column_on(&self, configs: &[Config], mode: Mode, engine: Engine) -> Result<Vec<Option<f64>>> {
        let program = program(self)?;
        let inputs: Vec<&Config> = configs.iter().filter(|c| self.applies(c)).collect();
        let magnitudes = inputs.iter().map(|c| self.magnitude(c));
        let mut values = program.eval_on(&inputs, mode, engine)?.into_iter().zip(magnitudes);
        let scaled = |(v, magnitude): (f64, f64)| match mode {
            Mode::F32 => f64::from(v as f32 * magnitude as f32),
            _ => v * magnitude,
        };
        Ok(configs
            .iter()
            .map(|c| {
                if self.applies(c) {
                    values.next().map(scaled)
                } else {
                    None
                }
            })
            .collect())
    }

    fn cpu_column_or_none(&self, configs: &[Config], mode: Mode) -> Vec<Option<f64>> {
        match self.cpu_column(configs, mode) {
            Ok(v) => v,
            Err(e) => {
                static NOTED: std::sync::Mutex<Vec<String>> = std::sync::Mutex::new(Vec::new());
                let mut noted = NOTED.lock().unwrap_or_else(|p| p.into_inner());
                if !noted.contains(&self.label) {
                    noted.push(self.label.clone());
                    eprintln!("note: `{}` has no f64/cpu_f32 values: {e:#}", self.label);
                }
                vec![None; configs.len()]
            }
        }
    }

    fn eval_f64(&self, config: &Config) -> Option<f64> {
        cpu_one(self, config, Mode::F64)
    }

    fn eval_f32_cpu(&self, config: &Config) -> Option<f32> {
        cpu_one(self, config, Mode::F32).map(|v| v as f32)
    }
}

/// A method's envelope on one configuration (docs/envelope.md): every f32 result a WGSL
/// implementation within the spec's accuracy rules may return when it evaluates the kernel
/// in its written order; None where the method does not apply. An LTC method's result is
/// multiplied by a `ggx` configuration's fed magnitude, as the shader multiplies.
pub fn envelope(method: &Method, config: &Config) -> Result<Option<EnvelopeOutcome>> {
    if !method.applies(config) {
        return Ok(None);
    }
    let program = program(method)?;
    let mut out = program.envelope(config, None);
    let magnitude = method.magnitude(config);
    if magnitude != 1.0 {
        let m = crate::eval::envelope::interval::Iv::point(magnitude as f32 as f64);
        out.value = out.value.map(|v| crate::eval::envelope::interval::mul(v, m));
    }
    Ok(Some(out))
}

/// "Where the freedom goes" on one configuration: for each line whose operations used an
/// allowance beyond correct rounding, log2 of the envelope's width over its width with that
/// line's operations held to correct rounding (bits of width the line's freedom adds).
/// Empty where the envelope is not a finite interval.
pub fn freedom(method: &Method, config: &Config) -> Result<Vec<(Line, f64)>> {
    if !method.applies(config) {
        return Ok(Vec::new());
    }
    let program = program(method)?;
    let full = program.envelope(config, None);
    let Ok(v) = full.value else { return Ok(Vec::new()) };
    let floor = crate::eval::envelope::interval::ulp32(v.lo.abs().max(v.hi.abs()));
    let width = (v.hi - v.lo).max(floor);
    let mut out = Vec::new();
    for &l in &full.loose {
        if let Ok(s) = program.envelope(config, Some(l)).value {
            let bits = (width / (s.hi - s.lo).max(floor)).log2();
            out.push((program.lines[l].clone(), bits));
        }
    }
    out.sort_by(|a, b| b.1.total_cmp(&a.1));
    Ok(out)
}

/// One configuration's value in `mode`.
fn cpu_one(method: &Method, config: &Config, mode: Mode) -> Option<f64> {
    method
        .cpu_column(std::slice::from_ref(config), mode)
        .ok()?
        .into_iter()
        .next()
        .flatten()
}

fn param_values(kernel: &crate::kernel::KernelFile, values: &[f64]) -> Vec<(String, f64)> {
    kernel
        .params
        .iter()
        .enumerate()
        .map(|(i, p)| (p.name.clone(), values.get(i).copied().unwrap_or(p.default)))
        .collect()
}

impl Program {
    fn new(method: &Method) -> Result<Program> {
        let inner = method.inner.as_deref();
        let composed = compose_with(&method.kernel, inner.map(|m| &m.kernel), Default::default())?;
        let mut params = param_values(&method.kernel, &method.params);
        match (inner, &composed.inner) {
            (Some(m), _) => params.extend(
                param_values(&m.kernel, &m.params)
                    .into_iter()
                    .map(|(n, v)| (crate::kernel::inner_name(&n), v)),
            ),
            (None, Some(k)) => params.extend(
                param_values(k, &[])
                    .into_iter()
                    .map(|(n, v)| (crate::kernel::inner_name(&n), v)),
            ),
            (None, None) => {}
        }
        let mut program = Program::prepare(composed, &params)?;
        for k in std::iter::once(&method.kernel).chain(inner.map(|m| &m.kernel)) {
            if let Some(o) = &k.origin {
                program.lost_digits.extend(o.lost_digits.iter().cloned());
            }
        }
        Ok(program)
    }

    fn prepare(c: Composed, params: &[(String, f64)]) -> Result<Program> {
        let m = &c.module;
        let text = |span: naga::Span| span.to_range().map(|r| c.source[r].to_string());

        let mut flat = Vec::new();
        for (_, t) in m.types.iter() {
            let n = match &t.inner {
                TypeInner::Scalar(_) => 1,
                TypeInner::Vector { size, .. } => *size as usize,
                TypeInner::Matrix { columns, rows, .. } => *columns as usize * *rows as usize,
                TypeInner::Array {
                    base,
                    size: naga::ArraySize::Constant(n),
                    ..
                } => flat[base.index()] * n.get() as usize,
                TypeInner::Struct { members, .. } => members.iter().map(|mb| flat[mb.ty.index()]).sum(),
                _ => 0,
            };
            flat.push(n);
        }

        let mut overrides = Vec::new();
        let mut global_consts: Vec<Const> = Vec::new();
        // Global expressions only refer to earlier ones, and overrides to earlier
        // expressions, so one pass in order fills both.
        let mut override_of = HashMap::new();
        for (h, o) in m.overrides.iter() {
            override_of.insert(h, o);
        }
        for (h, e) in m.global_expressions.iter() {
            let span = m.global_expressions.get_span(h);
            let v: Const = match e {
                E::Literal(l) => match *l {
                    naga::Literal::F32(x) => {
                        let v64 = lit64(&c, m, &global_consts, text(span), x);
                        (vec![x as f64], v64.map(|v| vec![v]))
                    }
                    naga::Literal::U32(x) => (vec![x as f64], Ok(vec![x as f64])),
                    naga::Literal::I32(x) => (vec![x as f64], Ok(vec![x as f64])),
                    naga::Literal::Bool(x) => (vec![x as u8 as f64], Ok(vec![x as u8 as f64])),
                    naga::Literal::F64(x) => (vec![x], Ok(vec![x])),
                    naga::Literal::AbstractFloat(x) => (vec![x], Ok(vec![x])),
                    naga::Literal::AbstractInt(x) => (vec![x as f64], Ok(vec![x as f64])),
                    other => anyhow::bail!("unsupported constant literal {other:?}"),
                },
                E::Constant(k) => global_consts[m.constants[*k].init.index()].clone(),
                E::ZeroValue(t) => (vec![0.0; flat[t.index()]], Ok(vec![0.0; flat[t.index()]])),
                E::Compose { components, .. } => {
                    let mut a = Vec::new();
                    let mut b = Ok(Vec::new());
                    for k in components {
                        let (x, y) = &global_consts[k.index()];
                        a.extend(x);
                        b = b.and_then(|mut v: Vec<f64>| {
                            v.extend(y.as_ref().map_err(Clone::clone)?);
                            Ok(v)
                        });
                    }
                    (a, b)
                }
                E::Splat { size, value } => {
                    let (x, y) = &global_consts[value.index()];
                    (
                        vec![x[0]; *size as usize],
                        y.as_ref().map(|y| vec![y[0]; *size as usize]).map_err(Clone::clone),
                    )
                }
                E::Override(o) => {
                    let v = overrides
                        .get(o.index())
                        .copied()
                        .ok_or_else(|| anyhow!("override used before its value is known"))?;
                    (vec![v], Ok(vec![v]))
                }
                other => {
                    let msg = format!("unsupported constant expression {other:?}");
                    (vec![f64::NAN], Err(msg))
                }
            };
            global_consts.push(v);
            // Any override whose default is this expression can now be valued.
            while let Some((oh, o)) = m.overrides.iter().nth(overrides.len()) {
                let name = o.name.clone().unwrap_or_default();
                let given = params.iter().find(|(n, _)| *n == name).map(|(_, v)| *v);
                let value = match (given, o.init) {
                    (Some(v), _) => v,
                    (None, Some(init)) if init.index() < global_consts.len() => global_consts[init.index()].0[0],
                    (None, Some(_)) => break,
                    (None, None) => anyhow::bail!("override `{name}` has no value"),
                };
                let _ = oh;
                overrides.push(value);
            }
        }
        while overrides.len() < m.overrides.len() {
            let (_, o) = m.overrides.iter().nth(overrides.len()).expect("counted");
            let name = o.name.clone().unwrap_or_default();
            let v = params
                .iter()
                .find(|(n, _)| *n == name)
                .map(|(_, v)| *v)
                .ok_or_else(|| anyhow!("override `{name}` has no value"))?;
            overrides.push(v);
        }

        let mut lines: Vec<Line> = Vec::new();
        let mut line_ids: HashMap<(String, usize), u32> = HashMap::new();
        let mut funs = Vec::new();
        for (_, f) in m.functions.iter() {
            let mut emitted = vec![false; f.expressions.len()];
            mark_emitted(&f.body, &mut emitted);
            let mut lit = Vec::new();
            let mut line = Vec::new();
            let mut constant = vec![false; f.expressions.len()];
            for (h, e) in f.expressions.iter() {
                constant[h.index()] = !emitted[h.index()]
                    && match e {
                        E::Literal(_) | E::Constant(_) | E::Override(_) | E::ZeroValue(_) | E::GlobalVariable(_) => {
                            true
                        }
                        E::Compose { components, .. } => components.iter().all(|c| constant[c.index()]),
                        E::Splat { value, .. } => constant[value.index()],
                        _ => false,
                    };
                let span = f.expressions.get_span(h);
                lit.push(match e {
                    E::Literal(naga::Literal::F32(x)) => lit64(&c, m, &global_consts, text(span), *x),
                    _ => Err(String::new()),
                });
                line.push(match span.to_range() {
                    Some(r) => {
                        let (path, no, t) = c.locate(r.start);
                        *line_ids.entry((path.clone(), no)).or_insert_with(|| {
                            lines.push(Line {
                                path,
                                line: no,
                                text: t,
                            });
                            lines.len() as u32 - 1
                        })
                    }
                    None => NO_LINE,
                });
            }
            funs.push(FunMeta {
                emitted,
                constant,
                lit64: lit,
                line,
            });
        }

        let (method, _) = m
            .functions
            .iter()
            .find(|(_, f)| f.name.as_deref() == Some("method"))
            .ok_or_else(|| anyhow!("no `method`"))?;
        let scene_ty = m
            .types
            .iter()
            .find(|(_, t)| t.name.as_deref() == Some("Scene"))
            .ok_or_else(|| anyhow!("no `Scene` struct"))?;
        let TypeInner::Struct { members, .. } = &scene_ty.1.inner else {
            anyhow::bail!("`Scene` is not a struct");
        };
        let mut scene = Vec::new();
        let mut off = 0;
        for mb in members {
            let len = flat[mb.ty.index()];
            scene.push((mb.name.clone().unwrap_or_default(), off, len));
            off += len;
        }
        let scene_minv = scene
            .iter()
            .find(|(n, _, _)| n == "minv")
            .map(|(_, o, l)| (*o, *l))
            .ok_or_else(|| anyhow!("`Scene` has no `minv`"))?;
        let dummy = crate::input::scene::SceneInput::new(&Config {
            id: String::new(),
            p1: [0.0; 3],
            p2: [0.0; 3],
            radius: None,
            rect: None,
            material: crate::input::scene::Material::Diffuse,
            texture: None,
        });
        for (name, _, len) in &scene {
            if dummy.member(name).map(|v| v.len()) != Some(*len) {
                anyhow::bail!("`Scene` member `{name}` has no CPU input (src/input/scene.rs `SceneInput::member`)");
            }
        }
        let reads_ltc = m.global_variables.iter().any(|(g, v)| {
            v.name.as_deref() == Some("ll_ltc")
                && m.functions.iter().any(|(_, f)| {
                    f.expressions
                        .iter()
                        .any(|(_, e)| matches!(e, E::GlobalVariable(h) if *h == g))
                })
        });
        Ok(Program {
            reads_ltc,
            module: c.module,
            info: c.info,
            method,
            flat,
            global_consts,
            funs,
            overrides,
            lines,
            scene,
            scene_minv,
            lost_digits: Vec::new(),
            compiled: Default::default(),
        })
    }

    fn pointee(&self, inner: &TypeInner) -> TypeInner {
        match inner {
            TypeInner::Pointer { base, .. } => self.module.types[*base].inner.clone(),
            TypeInner::ValuePointer {
                size: Some(size),
                scalar,
                ..
            } => TypeInner::Vector {
                size: *size,
                scalar: *scalar,
            },
            TypeInner::ValuePointer { scalar, .. } => TypeInner::Scalar(*scalar),
            other => other.clone(),
        }
    }

    /// Component offset and length of member / element `idx` of a value of type `inner`.
    fn child(&self, inner: &TypeInner, idx: usize) -> (usize, usize) {
        match inner {
            TypeInner::Struct { members, .. } => {
                let off = members[..idx].iter().map(|mb| self.flat[mb.ty.index()]).sum();
                (off, self.flat[members[idx].ty.index()])
            }
            other => {
                let (_, stride) = self.elements(other);
                (idx * stride, stride)
            }
        }
    }

    /// Element count and components per element of a vector, matrix or array.
    fn elements(&self, inner: &TypeInner) -> (usize, usize) {
        match inner {
            TypeInner::Vector { size, .. } => (*size as usize, 1),
            TypeInner::Matrix { columns, rows, .. } => (*columns as usize, *rows as usize),
            TypeInner::Array {
                base,
                size: naga::ArraySize::Constant(n),
                ..
            } => (n.get() as usize, self.flat[base.index()]),
            // A runtime-sized array (the harness's `ll_texels`): its length is the value's own;
            // 0 tells the caller to read it there.
            TypeInner::Array {
                base,
                size: naga::ArraySize::Dynamic,
                ..
            } => (0, self.flat[base.index()]),
            TypeInner::Pointer { .. } | TypeInner::ValuePointer { .. } => self.elements(&self.pointee(inner)),
            _ => (1, 1),
        }
    }

    /// The texels of each lane's texture (issue 25): component k of lane i is texel k of lane
    /// i's configuration (f32 lanes read them rounded), padded with 0 to the longest; each
    /// lane's texels start at 0, so its scene's `tex_offset` is 0 (`SceneInput::new`).
    fn texel_lanes(&self, configs: &[&Config], n: usize, split: usize, shadow_f32: bool) -> exec::Val {
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
        exec::Val(comps.into_iter().map(exec::lanes).collect())
    }

    /// The harness's LTC tables as the kernel reads them through `ll_ltc` (binding 4,
    /// `input::ltc::device`): the same f32 texels on every lane, f32 and f64 lanes alike (the
    /// table is data a shader reads as f32), held once as one-lane components that a load
    /// gives every lane (`exec.rs`); None when no function reads it.
    fn ltc_lanes(&self) -> Option<exec::Val> {
        self.reads_ltc.then(ltc_tables)
    }

    fn scene_lanes(&self, configs: &[&Config], n: usize, split: usize, shadow_f32: bool) -> exec::Val {
        let total: usize = self.scene.iter().map(|s| s.2).sum();
        let mut comps = vec![vec![0.0; n]; total];
        let half = if shadow_f32 { split } else { n };
        for (i, c) in configs.iter().enumerate() {
            let input = crate::input::scene::SceneInput::new(c);
            for (name, off, _) in &self.scene {
                let v = input.member(name).expect("checked in prepare");
                for (k, x) in v.into_iter().enumerate() {
                    let r = x as f32 as f64;
                    for lane in [i, i + half] {
                        if lane < n {
                            // f32 lanes (and an attribution's shadow) read the scene in f32.
                            comps[off + k][lane] = if lane < split || shadow_f32 { r } else { x };
                        }
                    }
                }
            }
        }
        exec::Val(comps.into_iter().map(exec::lanes).collect())
    }

    fn chunk(&self, configs: &[&Config], mode: Mode) -> Result<Vec<f64>> {
        let n = configs.len();
        let split = if mode == Mode::F32 { n } else { 0 };
        let mut ex = exec::Exec::new(self, n, split, false);
        ex.run(
            self.scene_lanes(configs, n, split, false),
            self.texel_lanes(configs, n, split, false),
        )
    }

    /// The compiled kernel in `mode` (compiled on first use), or why there is none.
    fn compiled(&self, mode: Mode) -> Result<&compiled::Compiled, &str> {
        let slot = &self.compiled[usize::from(mode == Mode::F64)];
        slot.get_or_init(|| compiled::Compiled::new(self, mode))
            .as_ref()
            .map_err(String::as_str)
    }

    /// Why this kernel is not compiled in `mode` (it is then interpreted), or None.
    pub fn not_compiled(&self, mode: Mode) -> Option<String> {
        self.compiled(mode).err().map(str::to_string)
    }

    /// How the compiled kernel in `mode` runs (SIMD, interleaved lanes, one configuration
    /// per call, with the reasons), or None where it is not compiled.
    pub fn path(&self, mode: Mode) -> Option<Path> {
        self.compiled(mode).ok().map(|c| c.path.clone())
    }

    /// The evaluator [`Program::eval`] uses in `mode`: the compiled one where the kernel
    /// compiles (and `LINELIGHT_EVALUATOR=interpreter` is not set), else the interpreter.
    pub fn engine(&self, mode: Mode) -> Engine {
        if interpreter_forced() || self.compiled(mode).is_err() {
            Engine::Interpreter
        } else {
            Engine::Compiled
        }
    }

    /// Which evaluator runs the f32 and f64 values, and why not the compiled one where it
    /// does not (the sweep's timing and `bench` print it).
    pub fn engines(&self) -> String {
        let one = |mode| match (self.engine(mode), self.not_compiled(mode)) {
            (Engine::Compiled, _) => match self.path(mode) {
                Some(p @ Path::One(_)) => format!("compiled, {}", p.describe()),
                _ => Engine::Compiled.name().to_string(),
            },
            (Engine::Interpreter, Some(why)) => format!("interpreter ({why})"),
            (Engine::Interpreter, None) => "interpreter (LINELIGHT_EVALUATOR=interpreter)".to_string(),
        };
        let (a, b) = (one(Mode::F32), one(Mode::F64));
        if a == b {
            a
        } else {
            format!("f32 {a}; f64 {b}")
        }
    }

    /// `method` on every configuration, in `mode`, on [`Program::engine`]. The kernel reads
    /// each configuration as the GPU does (`SceneInput`: a `ggx` one fed and rotated); an LTC
    /// method's fed magnitude is the caller's to apply (`Method::cpu_column`).
    pub fn eval(&self, configs: &[&Config], mode: Mode) -> Result<Vec<f64>> {
        self.eval_on(configs, mode, self.engine(mode))
    }

    /// [`Program::eval`] on the given evaluator (`Compiled` where the kernel does not
    /// compile is an error naming why).
    pub fn eval_on(&self, configs: &[&Config], mode: Mode, engine: Engine) -> Result<Vec<f64>> {
        if mode == Mode::F64 && !self.lost_digits.is_empty() {
            anyhow::bail!(
                "no f64 evaluation: constants of the kernel went through f32 and their written digits \
                 cannot be recovered: {}",
                self.lost_digits.join("; ")
            );
        }
        if engine == Engine::Compiled {
            let c = self
                .compiled(mode)
                .map_err(|e| anyhow!("the kernel is not compiled: {e}"))?;
            return c.eval(configs);
        }
        let parts = configs
            .par_chunks(CHUNK)
            .map(|c| self.chunk(c, mode))
            .collect::<Result<Vec<_>>>()?;
        Ok(parts.concat())
    }

    /// The envelope of one configuration (the kernel's own result, before any magnitude);
    /// `strict`: a line (index into `lines`) whose operations are held to correct rounding.
    pub fn envelope(&self, config: &Config, strict: Option<usize>) -> EnvelopeOutcome {
        let total: usize = self.scene.iter().map(|s| s.2).sum();
        let mut scene = vec![crate::eval::envelope::interval::Iv::point(0.0); total];
        let input = crate::input::scene::SceneInput::new(config);
        for (name, off, _) in &self.scene {
            let v = input.member(name).expect("checked in prepare");
            for (k, x) in v.into_iter().enumerate() {
                // The kernel reads its scene in f32.
                scene[off + k] = crate::eval::envelope::interval::Iv::point(x as f32 as f64);
            }
        }
        let texels = config.texture.as_ref().map_or(vec![0.0], |t| t.texels.clone());
        let texels = texels
            .into_iter()
            .map(|x| crate::eval::envelope::interval::Iv::point(x as f32 as f64))
            .collect();
        envelope::Walk::run(self, scene, texels, strict)
    }

    /// The f32 values with each source line's local error (module doc).
    pub fn attribute(&self, configs: &[&Config]) -> Result<Attribution> {
        self.attribute_with(configs, false, true)
    }

    /// [`Program::attribute`]; `reference`: each operation's local error recorded one lane at
    /// a time through [`ulp_bits`] (the straightforward path the tests compare with); `wide`:
    /// the lane loops in their AVX2 build where the CPU has it (else the baseline build).
    fn attribute_with(&self, configs: &[&Config], reference: bool, wide: bool) -> Result<Attribution> {
        let parts = configs
            .par_chunks(CHUNK / 2)
            .map(|c| {
                let k = c.len();
                let mut ex = exec::Exec::new(self, 2 * k, k, true);
                ex.reference_record(reference);
                ex.wide(wide);
                let mut v = ex.run(self.scene_lanes(c, 2 * k, k, true), self.texel_lanes(c, 2 * k, k, true))?;
                v.truncate(k);
                let mut per = vec![Vec::new(); k];
                for (line, e) in ex.errors.iter().enumerate() {
                    if let Some(e) = e {
                        for (cfg, (&sum, &max)) in e.sum.iter().zip(&e.max).enumerate() {
                            let count = e.count(cfg);
                            if count > 0 {
                                per[cfg].push(LineBits {
                                    line,
                                    mean: sum / count as f64,
                                    max,
                                });
                            }
                        }
                    }
                }
                Ok((v, per))
            })
            .collect::<Result<Vec<_>>>()?;
        let mut out = Attribution {
            lines: self.lines.clone(),
            f32: Vec::new(),
            per_config: Vec::new(),
        };
        for (v, per) in parts {
            out.f32.extend(v);
            out.per_config.extend(per);
        }
        for p in &mut out.per_config {
            p.sort_by(|a, b| b.max.total_cmp(&a.max).then(b.mean.total_cmp(&a.mean)));
        }
        Ok(out)
    }
}

/// One source line's local error on one configuration, in bits: the mean and the max
/// over the line's operations (every execution of each).
#[derive(Clone, Debug)]
pub struct LineBits {
    pub line: usize,
    pub mean: f64,
    pub max: f64,
}

/// Per-line local error of one method over a set of configurations.
#[derive(Clone, Debug)]
pub struct Attribution {
    pub lines: Vec<Line>,
    /// The f32 result on each configuration.
    pub f32: Vec<f64>,
    /// Lines with any operation on each configuration, most bits first.
    pub per_config: Vec<Vec<LineBits>>,
}

/// A line's local error over configurations: mean of the per-configuration means, and
/// the nearest-rank p99 and max of the per-configuration maxima.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct LineSummary {
    pub line: Line,
    pub mean: f64,
    pub p99: f64,
    pub max: f64,
    pub configs: usize,
}

impl Attribution {
    /// Every line, most bits (mean) first.
    pub fn summary(&self) -> Vec<LineSummary> {
        let mut by_line: HashMap<usize, (Vec<f64>, Vec<f64>)> = HashMap::new();
        for per in &self.per_config {
            for b in per {
                let e = by_line.entry(b.line).or_default();
                e.0.push(b.mean);
                e.1.push(b.max);
            }
        }
        let mut out: Vec<LineSummary> = by_line
            .into_iter()
            .map(|(line, (means, mut maxes))| {
                maxes.sort_by(f64::total_cmp);
                let rank = ((0.99 * maxes.len() as f64).ceil() as usize).clamp(1, maxes.len());
                LineSummary {
                    line: self.lines[line].clone(),
                    mean: means.iter().sum::<f64>() / means.len() as f64,
                    p99: maxes[rank - 1],
                    max: maxes[maxes.len() - 1],
                    configs: means.len(),
                }
            })
            .collect();
        out.sort_by(|a, b| {
            b.mean
                .total_cmp(&a.mean)
                .then(b.p99.total_cmp(&a.p99))
                .then(a.line.line.cmp(&b.line.line))
        });
        out
    }
}

/// The written digits of an f32 literal whose source text is `text`.
fn lit64(c: &Composed, m: &naga::Module, consts: &[Const], text: Option<String>, x: f32) -> Result<f64, String> {
    let text = text.ok_or("a float constant without source text")?;
    let v = written(c, m, consts, &text, 0)?;
    let close = (v as f32 == x) || ((v - x as f64).abs() <= 4.0 * f64::from(f32::EPSILON) * (x as f64).abs());
    if !close {
        return Err(format!("`{text}` reads as {v:e} in f64 but as {x:e} in f32"));
    }
    Ok(v)
}

/// `text` in f64. A name is a module constant, or else a function-scope `const` (naga
/// inlines those, so their declaration is found in the source; it must be unique).
fn written(c: &Composed, m: &naga::Module, consts: &[Const], text: &str, depth: usize) -> Result<f64, String> {
    let constant = |name: &str| {
        if let Some((_, k)) = m.constants.iter().find(|(_, k)| k.name.as_deref() == Some(name)) {
            let v = consts.get(k.init.index())?.1.as_ref().ok()?;
            return (v.len() == 1).then(|| v[0]);
        }
        if depth > 8 {
            return None;
        }
        let decls = local_consts(&c.source, name);
        match decls.as_slice() {
            [one] => written(c, m, consts, one, depth + 1).ok(),
            _ => None,
        }
    };
    digits::eval(text, &constant).map_err(|e| format!("cannot read `{text}` in f64: {e}"))
}

/// The distinct initialisers of `const NAME = …;` / `const NAME: T = …;` in `source`.
fn local_consts(source: &str, name: &str) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    let mut rest = source;
    while let Some(i) = rest.find("const ") {
        let after = &rest[i + 6..];
        rest = after;
        let after = after.trim_start();
        let Some(tail) = after.strip_prefix(name) else { continue };
        if tail.starts_with(|ch: char| ch.is_alphanumeric() || ch == '_') {
            continue;
        }
        let Some(eq) = tail.find('=') else { continue };
        let Some(end) = tail[eq..].find(';') else { continue };
        let init = tail[eq + 1..eq + end].trim().to_string();
        if !out.contains(&init) {
            out.push(init);
        }
    }
    out
}

fn mark_emitted(block: &naga::Block, out: &mut [bool]) {
    for st in block.iter() {
        match st {
            naga::Statement::Emit(r) => {
                for h in r.clone() {
                    out[h.index()] = true;
                }
            }
            naga::Statement::Block(b) => mark_emitted(b, out),
            naga::Statement::If { accept, reject, .. } => {
                mark_emitted(accept, out);
                mark_emitted(reject, out);
            }
            naga::Statement::Switch { cases, .. } => {
                for c in cases {
                    mark_emitted(&c.body, out);
                }
            }
            naga::Statement::Loop { body, continuing, .. } => {
                mark_emitted(body, out);
                mark_emitted(continuing, out);
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests;
