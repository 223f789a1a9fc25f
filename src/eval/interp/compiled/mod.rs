//! The compiled CPU evaluator: a [`Program`]'s `method` compiled once per run and mode to
//! native code by Cranelift (`lower.rs`), giving the interpreter's values bit for bit (NaN
//! payloads aside) at a fraction of its cost. The interpreter stays the specification: a
//! kernel this compiler does not handle is interpreted, with the reason kept
//! ([`Program::engine`]); attribution and the envelope are always interpreted.
//! `tests/compiled.rs` checks the bits on every built-in kernel.

mod lower;
mod shims;

use crate::eval::program::{Mode, Program};
use crate::input::scene::{scene_member, Config, SceneInput, SCENE_COMPONENTS};
use anyhow::{bail, Result};
use rayon::prelude::*;

/// Configurations per call on the interleaved lane path (`lower.rs`, [`lower::compile`]),
/// and on the SIMD path in either mode (one F32X4 vector, two F64X2 vectors).
pub const LANES: usize = 4;

/// `LINELIGHT_VECTORS=K` (1 to 4): K vectors per call on the SIMD path, in both modes (to
/// time the choice); unset: one F32X4 in f32, two F64X2 in f64 (4 configurations each).
fn vectors_wanted() -> Option<usize> {
    crate::tuning::tuning().vectors
}

/// `LINELIGHT_F64_PATH=lanes`: f64 on the previous path, 4 interleaved scalar lanes per
/// call, f32 untouched (to time the F64X2 path against it in one build).
fn f64_lanes_wanted() -> bool {
    crate::tuning::tuning().f64_lanes
}

/// `LINELIGHT_LANES=N` (1 to 16): N configurations per call on the interleaved lane path,
/// no SIMD; 1 is the one-configuration path (to time the paths, or to rule one out).
/// `LINELIGHT_LANES=4` is the f64 path before F64X2.
fn lanes_wanted() -> Option<usize> {
    crate::tuning::tuning().lanes
}

/// How a compiled kernel runs its configurations.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Path {
    /// In vector registers (F32X4 or F64X2), this many configurations per call.
    Simd(usize),
    /// N configurations per call, each lane's scalar operations side by side; why not
    /// SIMD where it was tried.
    Lanes(usize, Option<String>),
    /// One configuration per call, and why.
    One(String),
}

impl Path {
    /// Configurations per call.
    pub fn per_call(&self) -> usize {
        match self {
            Path::Simd(n) => *n,
            Path::Lanes(n, _) => *n,
            Path::One(_) => 1,
        }
    }

    pub fn describe(&self) -> String {
        match self {
            Path::Simd(n) => format!("SIMD, {n} configurations per call"),
            Path::Lanes(n, None) => format!("{n} interleaved lanes per call"),
            Path::Lanes(n, Some(why)) => format!("{n} interleaved lanes per call (not SIMD: {why})"),
            Path::One(why) => format!("one configuration per call ({why})"),
        }
    }
}

/// The interleaved lane path with `n` lanes, or the one-configuration path with why not.
fn lanes(p: &Program, mode: Mode, n: usize) -> Result<(lower::Native, Path), String> {
    if n == 1 {
        return Ok((
            lower::compile(p, mode, 1, false)?,
            Path::One("LINELIGHT_LANES=1".into()),
        ));
    }
    match lower::compile(p, mode, n, false) {
        Ok(native) => Ok((native, Path::Lanes(n, None))),
        Err(why) => Ok((lower::compile(p, mode, 1, false)?, Path::One(why))),
    }
}

/// A kernel compiled in one mode.
pub(super) struct Compiled {
    native: lower::Native,
    /// How it runs (SIMD, interleaved lanes, one configuration per call).
    pub path: Path,
    mode: Mode,
    /// Where each component of the kernel's scene comes from in [`SceneInput::flatten`]'s
    /// layout (the kernel's components in its own order).
    from: Vec<usize>,
}

/// Configurations per parallel task (as the interpreter's chunk).
const CHUNK: usize = 1024;

impl Compiled {
    pub(super) fn new(p: &Program, mode: Mode) -> Result<Compiled, String> {
        let mut from = vec![0; p.scene.iter().map(|s| s.2).sum()];
        for (name, off, len) in &p.scene {
            let (src, n) = scene_member(name).ok_or_else(|| format!("no Scene member `{name}`"))?;
            if n != *len {
                return Err(format!("Scene member `{name}` has {len} components, the contract {n}"));
            }
            for k in 0..n {
                from[off + k] = src + k;
            }
        }
        let vectors = vectors_wanted().unwrap_or(LANES / lower::simd_width(mode));
        let wanted = match mode {
            Mode::F64 if f64_lanes_wanted() => lanes_wanted().or(Some(LANES)),
            _ => lanes_wanted(),
        };
        let (native, path) = match wanted {
            Some(n) => lanes(p, mode, n)?,
            None => match lower::compile(p, mode, vectors, true) {
                Ok(native) => {
                    let n = native.per_call;
                    (native, Path::Simd(n))
                }
                Err(why) => {
                    let (native, path) = lanes(p, mode, LANES)?;
                    let path = match path {
                        Path::Lanes(n, _) => Path::Lanes(n, Some(why)),
                        other => other,
                    };
                    (native, path)
                }
            },
        };
        Ok(Compiled {
            native,
            path,
            mode,
            from,
        })
    }

    /// `method` on every configuration: what [`Program::eval`] returns, in the same order,
    /// with the same error for a loop past the limit. Each call takes `per_call` configurations'
    /// scenes, filled in place (no allocation per configuration); a last group short of
    /// `per_call` is padded with copies of its last configuration, whose results are dropped.
    pub(super) fn eval(&self, configs: &[&Config]) -> Result<Vec<f64>> {
        let mut out = vec![0.0f64; configs.len()];
        let (n, total) = (self.native.per_call, self.from.len());
        let over = out
            .par_chunks_mut(CHUNK)
            .zip(configs.par_chunks(CHUNK))
            .any(|(out, chunk)| {
                let mut all = [0.0f64; SCENE_COMPONENTS];
                let mut scene = vec![0.0f64; total * n];
                let mut res = vec![0.0f64; n];
                for (outs, group) in out.chunks_mut(n).zip(chunk.chunks(n)) {
                    for (lane, s) in scene.chunks_mut(total).enumerate() {
                        SceneInput::new(group[lane.min(group.len() - 1)]).flatten(&mut all);
                        for (s, &k) in s.iter_mut().zip(&self.from) {
                            // The f32 mode reads its scene in f32, as the interpreter's f32 lanes.
                            *s = match self.mode {
                                Mode::F32 => all[k] as f32 as f64,
                                Mode::F64 => all[k],
                            };
                        }
                    }
                    // SAFETY: `scene` holds `n` scenes of every component the code reads
                    // (the Scene's `total`, checked when compiling) and `res` the `n` f64
                    // it writes.
                    if unsafe { (self.native.entry)(scene.as_ptr(), res.as_mut_ptr()) } != 0 {
                        return true;
                    }
                    outs.copy_from_slice(&res[..outs.len()]);
                }
                false
            });
        if over {
            bail!("CPU evaluator: a loop ran more than 2^24 iterations");
        }
        Ok(out)
    }
}
