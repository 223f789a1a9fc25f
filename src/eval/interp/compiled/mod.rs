//! The compiled CPU evaluator: a [`Program`]'s `method` compiled once per run and mode to
//! native code by Cranelift (`lower.rs`), giving the interpreter's values bit for bit (NaN
//! payloads aside) at a fraction of its cost. The interpreter stays the specification: a
//! kernel this compiler does not handle is interpreted, with the reason kept
//! ([`Program::engine`]); attribution and the envelope are always interpreted.
//! `tests/compiled.rs` checks the bits on every built-in kernel.

mod lower;
mod shims;

use super::{Mode, Program};
use crate::input::scene::{Config, SceneInput};
use anyhow::{bail, Result};
use rayon::prelude::*;

/// A kernel compiled in one mode.
pub(super) struct Compiled {
    native: lower::Native,
    mode: Mode,
}

/// Configurations per parallel task (as the interpreter's chunk).
const CHUNK: usize = 1024;

impl Compiled {
    pub(super) fn new(p: &Program, mode: Mode) -> Result<Compiled, String> {
        Ok(Compiled {
            native: lower::compile(p, mode)?,
            mode,
        })
    }

    /// `method` on every configuration: what [`Program::eval`] returns, in the same order,
    /// with the same error for a loop past the limit.
    pub(super) fn eval(&self, p: &Program, configs: &[&Config]) -> Result<Vec<f64>> {
        let total: usize = p.scene.iter().map(|s| s.2).sum();
        let parts = configs
            .par_chunks(CHUNK)
            .map(|chunk| {
                let mut scene = vec![0.0f64; total];
                let mut out = Vec::with_capacity(chunk.len());
                for c in chunk {
                    let input = SceneInput::new(c);
                    for (name, off, _) in &p.scene {
                        let v = input.member(name).expect("checked in prepare");
                        for (k, x) in v.into_iter().enumerate() {
                            // The f32 mode reads its scene in f32, as the interpreter's f32 lanes.
                            scene[off + k] = match self.mode {
                                Mode::F32 => x as f32 as f64,
                                Mode::F64 => x,
                            };
                        }
                    }
                    let mut v = 0.0f64;
                    // SAFETY: `scene` holds every component the code reads (the Scene's
                    // `total`, checked when compiling) and `v` is the one f64 it writes.
                    let status = unsafe { (self.native.entry)(scene.as_ptr(), &mut v) };
                    if status != 0 {
                        bail!("CPU evaluator: a loop ran more than 2^24 iterations");
                    }
                    out.push(v);
                }
                Ok(out)
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(parts.concat())
    }
}
