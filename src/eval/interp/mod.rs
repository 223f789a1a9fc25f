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
//! - [`Evaluator::attribute`]: f32 with an f64 shadow of every value (same control flow),
//!   and each float operation's local error (Herbie): the op in f32 on the shadow's
//!   arguments rounded to f32, against the exact (f64) op on the shadow's arguments, in
//!   bits (`log2(1 + ulps)`), summed per kernel source line.
//!
//! Configurations run in chunks, one IR operation over a whole chunk at a time
//! (`exec.rs`), chunks in parallel with rayon.

mod compiled;
mod envelope;
mod exec;

use crate::input::scene::Config;
use crate::kernel::methods::Method;
use anyhow::{anyhow, Context, Result};
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

pub use crate::eval::program::{Line, Mode, Program};
pub use compiled::{Path, LANES};
pub use envelope::{Outcome as EnvelopeOutcome, Stop as EnvelopeStop};
pub use exec::ulp_bits;

/// Configurations per chunk: enough lanes to amortise the per-operation dispatch.
const CHUNK: usize = 1024;

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
    crate::tuning::tuning().interpreter_forced
}

/// A method's prepared kernel and its compiled forms: what the evaluator runs.
pub struct Evaluator {
    program: Program,
    /// The compiled kernel per mode (f32, f64), made on first use, or why it cannot be.
    compiled: [OnceLock<Result<compiled::Compiled, String>>; 2],
}

impl std::ops::Deref for Evaluator {
    type Target = Program;
    fn deref(&self) -> &Program {
        &self.program
    }
}

/// The evaluator's program for `method` (composed once, then cached for the process).
pub fn program(method: &Method) -> Result<Arc<Evaluator>> {
    static CACHE: OnceLock<Mutex<HashMap<String, Arc<Evaluator>>>> = OnceLock::new();
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
    let program = Program::new(method).with_context(|| format!("CPU evaluator for {}", method.describe()))?;
    let p = Arc::new(Evaluator {
        program,
        compiled: Default::default(),
    });
    cache.lock().expect("cache lock").insert(key, p.clone());
    Ok(p)
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
                crate::warnings::raise(crate::warnings::Warning::NoCpuValues {
                    method: self.label.clone(),
                    reason: format!("{e:#}"),
                });
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

impl Evaluator {
    fn chunk(&self, configs: &[&Config], mode: Mode) -> Result<Vec<f64>> {
        let n = configs.len();
        let split = if mode == Mode::F32 { n } else { 0 };
        let ex = exec::Exec::new(self, n, split, false);
        let scene = exec::scene_lanes(self, configs, n, split, false);
        ex.run(scene, exec::texel_lanes(configs, n, split, false)).0
    }

    /// The compiled kernel in `mode` (compiled on first use), or why there is none.
    fn compiled(&self, mode: Mode) -> Result<&compiled::Compiled, &str> {
        let slot = &self.compiled[usize::from(mode == Mode::F64)];
        slot.get_or_init(|| compiled::Compiled::new(&self.program, mode))
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

    /// The evaluator [`Evaluator::eval`] uses in `mode`: the compiled one where the kernel
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

    /// `method` on every configuration, in `mode`, on [`Evaluator::engine`]. The kernel reads
    /// each configuration as the GPU does (`SceneInput`: a `ggx` one fed and rotated); an LTC
    /// method's fed magnitude is the caller's to apply (`Method::cpu_column`).
    pub fn eval(&self, configs: &[&Config], mode: Mode) -> Result<Vec<f64>> {
        self.eval_on(configs, mode, self.engine(mode))
    }

    /// [`Evaluator::eval`] on the given evaluator (`Compiled` where the kernel does not
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
        envelope::Intervals::run(self, scene, texels, strict)
    }

    /// The f32 values with each source line's local error (module doc).
    pub fn attribute(&self, configs: &[&Config]) -> Result<Attribution> {
        self.attribute_with(configs, false, true)
    }

    /// [`Evaluator::attribute`]; `reference`: each operation's local error recorded one lane at
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
                let scene = exec::scene_lanes(self, c, 2 * k, k, true);
                let (v, ex) = ex.run(scene, exec::texel_lanes(c, 2 * k, k, true));
                let mut v = v?;
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

#[cfg(test)]
mod tests;
