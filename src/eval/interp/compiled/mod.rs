//! The compiled CPU evaluator: a [`Program`]'s `method` compiled once per run and mode to
//! native code by Cranelift (`lower.rs`), giving the interpreter's values bit for bit (NaN
//! payloads aside) at a fraction of its cost. The interpreter stays the specification: a
//! kernel this compiler does not handle is interpreted, with the reason kept
//! ([`Program::engine`]); attribution and the envelope are always interpreted.
//! `tests/compiled.rs` checks the bits on every built-in kernel.

mod lower;
mod shims;

use super::{Mode, Program};
use crate::input::scene::{scene_member, Config, SceneInput, SCENE_COMPONENTS};
use anyhow::{bail, Result};
use rayon::prelude::*;

/// A kernel compiled in one mode.
pub(super) struct Compiled {
    native: lower::Native,
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
        Ok(Compiled {
            native: lower::compile(p, mode)?,
            mode,
            from,
        })
    }

    /// `method` on every configuration: what [`Program::eval`] returns, in the same order,
    /// with the same error for a loop past the limit. Each configuration's scene is filled
    /// in place (no allocation per configuration), results are written where they go.
    pub(super) fn eval(&self, configs: &[&Config]) -> Result<Vec<f64>> {
        let mut out = vec![0.0f64; configs.len()];
        let over = out
            .par_chunks_mut(CHUNK)
            .zip(configs.par_chunks(CHUNK))
            .any(|(out, chunk)| {
                let mut all = [0.0f64; SCENE_COMPONENTS];
                let mut scene = vec![0.0f64; self.from.len()];
                for (v, c) in out.iter_mut().zip(chunk) {
                    SceneInput::new(c).flatten(&mut all);
                    for (s, &k) in scene.iter_mut().zip(&self.from) {
                        // The f32 mode reads its scene in f32, as the interpreter's f32 lanes.
                        *s = match self.mode {
                            Mode::F32 => all[k] as f32 as f64,
                            Mode::F64 => all[k],
                        };
                    }
                    // SAFETY: `scene` holds every component the code reads (the Scene's
                    // `total`, checked when compiling) and `v` is the one f64 it writes.
                    if unsafe { (self.native.entry)(scene.as_ptr(), v) } != 0 {
                        return true;
                    }
                }
                false
            });
        if over {
            bail!("CPU evaluator: a loop ran more than 2^24 iterations");
        }
        Ok(out)
    }
}
