//! A method's kernel prepared for the CPU evaluator: composed once, its types flattened to
//! scalar components, its constants read in f32 and from their written digits in f64
//! (`digits.rs`), each expression's source line located. Every mode of the evaluator walks
//! this (`walk.rs`): the interpreter's lanes, the envelope's intervals and the compiled code.

use crate::eval::digits;
use crate::input::scene::Config;
use crate::kernel::methods::Method;
use crate::kernel::KernelFile;
use crate::kernel::{compose_with, Composed};
use anyhow::{anyhow, Context, Result};
use naga::{Expression as E, Handle, TypeInner};
use std::collections::HashMap;

/// No source line (an expression naga made without a span).
pub const NO_LINE: u32 = u32::MAX;

/// The precision a kernel is evaluated in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    F32,
    F64,
}

/// A flattened constant: its f32 values and its written digits in f64.
pub type Const = (Vec<f64>, Result<Vec<f64>, String>);

/// A kernel source line that operations were attributed to.
#[derive(Clone, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub struct Line {
    pub path: String,
    pub line: usize,
    pub text: String,
}

pub struct FunMeta {
    /// Expressions some `Emit` evaluates (the others are evaluated on entry).
    pub(crate) emitted: Vec<bool>,
    /// Expressions whose value is the same on every call (literals, constants, globals).
    pub(crate) constant: Vec<bool>,
    /// An f32 literal's written digits (or why they cannot be read).
    pub(crate) lit64: Vec<Result<f64, String>>,
    /// Index into [`Program::lines`] of each expression, or `NO_LINE`.
    pub(crate) line: Vec<u32>,
}

/// A method's kernel, composed and prepared for evaluation.
pub struct Program {
    pub(crate) module: naga::Module,
    pub(crate) info: naga::valid::ModuleInfo,
    pub(crate) method: Handle<naga::Function>,
    /// Scalar components of each type.
    pub(crate) flat: Vec<usize>,
    pub(crate) global_consts: Vec<Const>,
    pub(crate) funs: Vec<FunMeta>,
    pub(crate) overrides: Vec<f64>,
    pub lines: Vec<Line>,
    /// `Scene` members: name, component offset, length.
    pub(crate) scene: Vec<(String, usize, usize)>,
    pub(crate) scene_minv: (usize, usize),
    /// Whether a function reads `ll_ltc` (the harness's LTC tables, binding 4): only then is
    /// the table given to the run.
    pub(crate) reads_ltc: bool,
    /// Constants of a translated kernel (GLSL, HLSL) whose written digits are lost: the f64
    /// evaluation is refused (src/kernel/written.rs).
    pub(crate) lost_digits: Vec<String>,
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
    pub fn new(method: &Method) -> Result<Program> {
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
        // A constant that lost its digits refuses the f64 column only where the method
        // reaches it: one in a function it never calls does not (one at module scope, or in a
        // function the composition does not name as the translation did, does).
        let reached = reached_functions(&program.module, program.method);
        let named = |n: &str| {
            program
                .module
                .functions
                .iter()
                .any(|(_, f)| f.name.as_deref() == Some(n))
        };
        let mut lost = Vec::new();
        let kernels = [(&method.kernel, false)].into_iter();
        for (k, is_inner) in kernels.chain(inner.map(|m| (&m.kernel, true))) {
            for l in k.origin.iter().flat_map(|o| &o.lost_digits) {
                let name = match l.function.as_deref() {
                    Some("method") if is_inner => Some(crate::kernel::INNER_METHOD),
                    other => other,
                };
                let unreached = name.is_some_and(|n| named(n) && !reached.contains(n));
                if !unreached {
                    lost.push(l.message.clone());
                }
            }
        }
        program.lost_digits = lost;
        Ok(program)
    }

    /// The program as the pipeline compiles it, for the operation count: composed with
    /// every capability (the count refuses no kernel a device accepts), its overrides set
    /// to `params` (header order, the header's defaults for the rest) and folded by naga's
    /// `process_overrides`, which makes what depends only on them a constant, as the
    /// driver does. `inner`: a composite's line method and its params (else the default).
    pub fn folded(kernel: &KernelFile, params: &[f64], inner: Option<(&KernelFile, &[f64])>) -> Result<Program> {
        let composed = compose_with(kernel, inner.map(|(k, _)| k), naga::valid::Capabilities::all())?;
        let default = composed.inner.clone();
        let inner = inner.or(default.as_ref().map(|k| (k, &[][..])));
        for (k, given) in std::iter::once((kernel, params)).chain(inner) {
            if given.len() > k.params.len() {
                anyhow::bail!("{} takes {} param(s), {} given", k.id, k.params.len(), given.len());
            }
        }
        let mut values = param_values(kernel, params);
        if let Some((k, given)) = inner {
            let named = param_values(k, given).into_iter();
            values.extend(named.map(|(n, v)| (crate::kernel::inner_name(&n), v)));
        }
        let constants: naga::back::PipelineConstants = values.iter().cloned().collect();
        let entry = Some((naga::ShaderStage::Compute, crate::kernel::ENTRY_NAME));
        let (module, info) =
            naga::back::pipeline_constants::process_overrides(&composed.module, &composed.info, entry, &constants)
                .with_context(|| format!("{}: cannot resolve the overrides", kernel.path))?;
        let (module, info) = (module.into_owned(), info.into_owned());
        Program::prepare(composed.with_module(module, info), &values)
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
        })
    }

    pub(crate) fn pointee(&self, inner: &TypeInner) -> TypeInner {
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
    pub(crate) fn child(&self, inner: &TypeInner, idx: usize) -> (usize, usize) {
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
    pub(crate) fn elements(&self, inner: &TypeInner) -> (usize, usize) {
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

/// Calls `f` on every statement of `block` and of the blocks nested in it.
fn each_statement<'b>(block: &'b naga::Block, f: &mut impl FnMut(&'b naga::Statement)) {
    use naga::Statement as S;
    for st in block.iter() {
        f(st);
        match st {
            S::Block(b) => each_statement(b, f),
            S::If { accept, reject, .. } => {
                each_statement(accept, f);
                each_statement(reject, f);
            }
            S::Switch { cases, .. } => cases.iter().for_each(|c| each_statement(&c.body, f)),
            S::Loop { body, continuing, .. } => {
                each_statement(body, f);
                each_statement(continuing, f);
            }
            _ => {}
        }
    }
}

fn mark_emitted(block: &naga::Block, out: &mut [bool]) {
    each_statement(block, &mut |st| {
        if let naga::Statement::Emit(r) = st {
            for h in r.clone() {
                out[h.index()] = true;
            }
        }
    });
}

/// The names of the functions `from` calls, directly or through others, and its own.
fn reached_functions(m: &naga::Module, from: Handle<naga::Function>) -> std::collections::HashSet<String> {
    let mut seen = vec![false; m.functions.len()];
    let mut todo = vec![from];
    seen[from.index()] = true;
    while let Some(f) = todo.pop() {
        each_statement(&m.functions[f].body, &mut |st| {
            if let naga::Statement::Call { function, .. } = st {
                if !std::mem::replace(&mut seen[function.index()], true) {
                    todo.push(*function);
                }
            }
        });
    }
    m.functions
        .iter()
        .filter(|(h, _)| seen[h.index()])
        .filter_map(|(_, f)| f.name.clone())
        .collect()
}
