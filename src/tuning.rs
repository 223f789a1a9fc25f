//! The environment, read once: every `LINELIGHT_*` variable a command obeys, parsed into one
//! [`Tuning`] the first time any part asks ([`tuning`]), and checked before any work
//! ([`init`], from main.rs), so a bad value is refused up front and no part reads the
//! environment on its own. The evaluator's switches (`LINELIGHT_EVALUATOR`,
//! `LINELIGHT_LANES`, `LINELIGHT_F64_PATH`, `LINELIGHT_VECTORS`) are read here too and obeyed by
//! src/eval, which documents what each path is.

use std::time::Duration;

/// The interval of plain progress lines, unless [`PROGRESS_SECONDS`] sets another.
pub const PROGRESS_INTERVAL: Duration = Duration::from_secs(10);

/// Seconds between plain progress lines when stderr is not a terminal (0.001 to 86400).
pub const PROGRESS_SECONDS: &str = "LINELIGHT_PROGRESS_SECONDS";

/// Configurations `eval` holds at a time (tests use a small one to cover several chunks with
/// a few lines); a value that is not a positive count is ignored.
pub const EVAL_CHUNK: &str = "LINELIGHT_EVAL_CHUNK";

/// The glslang binary an HLSL kernel is compiled with (`glslangValidator` on the path unless
/// set).
pub const GLSLANG: &str = "LINELIGHT_GLSLANG";

/// A test hook (tests/promises.rs), not for users: with `N` set, every chunk dispatch after the
/// first N of the process fails as a lost device would, so that a real CLI run ends in exit 4
/// (N = 1 lets the driver's loop-limit probe through).
pub const TEST_FAIL_DISPATCH: &str = "LINELIGHT_TEST_FAIL_DISPATCH";

/// `interpreter`: every CPU value on the interpreter (src/eval/interp).
pub const EVALUATOR: &str = "LINELIGHT_EVALUATOR";

/// 1 to 4: vectors per call on the compiled SIMD path (src/eval/interp/compiled).
pub const VECTORS: &str = "LINELIGHT_VECTORS";

/// `lanes`: compiled f64 on 4 interleaved scalar lanes instead of F64X2 vectors.
pub const F64_PATH: &str = "LINELIGHT_F64_PATH";

/// 1 to 16: configurations per call on the compiled interleaved lane path, no SIMD.
pub const LANES: &str = "LINELIGHT_LANES";

/// What the environment asks of this process.
#[derive(Clone, Debug)]
pub struct Tuning {
    /// [`PROGRESS_SECONDS`], or [`PROGRESS_INTERVAL`].
    pub progress_interval: Duration,
    /// [`EVAL_CHUNK`], when set to a positive count.
    pub eval_chunk: Option<usize>,
    /// [`GLSLANG`], or `glslangValidator`.
    pub glslang: String,
    /// [`TEST_FAIL_DISPATCH`], when set to a count.
    pub fail_dispatch: Option<usize>,
    /// [`EVALUATOR`] `= interpreter`.
    pub interpreter_forced: bool,
    /// [`VECTORS`], when a count from 1 to 4.
    pub vectors: Option<usize>,
    /// [`F64_PATH`] `= lanes`.
    pub f64_lanes: bool,
    /// [`LANES`], when a count from 1 to 16.
    pub lanes: Option<usize>,
}

impl Tuning {
    /// Reads every variable from `var` (the environment, or a test's map).
    pub fn read(var: impl Fn(&str) -> Option<String>) -> Result<Tuning, String> {
        let progress_interval = match var(PROGRESS_SECONDS) {
            None => PROGRESS_INTERVAL,
            Some(text) => text
                .trim()
                .parse::<f64>()
                .ok()
                .filter(|s| (0.001..=86400.0).contains(s))
                .map(Duration::from_secs_f64)
                .ok_or_else(|| format!("{PROGRESS_SECONDS}=`{text}`: need a number of seconds from 0.001 to 86400"))?,
        };
        Ok(Tuning {
            progress_interval,
            eval_chunk: var(EVAL_CHUNK).and_then(|v| v.parse().ok()).filter(|&n: &usize| n > 0),
            glslang: var(GLSLANG).unwrap_or_else(|| "glslangValidator".to_string()),
            fail_dispatch: var(TEST_FAIL_DISPATCH).and_then(|v| v.parse().ok()),
            interpreter_forced: var(EVALUATOR).is_some_and(|v| v == "interpreter"),
            vectors: count(var(VECTORS), 4),
            f64_lanes: var(F64_PATH).is_some_and(|v| v == "lanes"),
            lanes: count(var(LANES), 16),
        })
    }

    fn from_env() -> Result<Tuning, String> {
        Tuning::read(|name| std::env::var(name).ok())
    }
}

/// A count from 1 to `most`, or None.
fn count(text: Option<String>, most: usize) -> Option<usize> {
    text.and_then(|v| v.parse().ok()).filter(|n| (1..=most).contains(n))
}

static TUNING: std::sync::OnceLock<Result<Tuning, String>> = std::sync::OnceLock::new();

fn read_once() -> &'static Result<Tuning, String> {
    TUNING.get_or_init(Tuning::from_env)
}

/// Reads the environment before any work (main.rs): a bad value is bad input.
pub fn init() -> Result<&'static Tuning, String> {
    read_once().as_ref().map_err(Clone::clone)
}

/// This process's tuning. A value [`init`] would refuse falls back to its default here (a
/// library caller that never called `init`).
pub fn tuning() -> &'static Tuning {
    static FALLBACK: std::sync::OnceLock<Tuning> = std::sync::OnceLock::new();
    match read_once() {
        Ok(t) => t,
        Err(_) => FALLBACK.get_or_init(|| {
            Tuning::read(|name| (name != PROGRESS_SECONDS).then(|| std::env::var(name).ok()).flatten())
                .expect("only the progress interval is refused")
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(pairs: &[(&str, &str)]) -> Result<Tuning, String> {
        Tuning::read(|name| pairs.iter().find(|(k, _)| *k == name).map(|(_, v)| v.to_string()))
    }

    #[test]
    fn unset_variables_give_the_defaults() {
        let t = read(&[]).unwrap();
        assert_eq!(t.progress_interval, PROGRESS_INTERVAL);
        assert_eq!(t.eval_chunk, None);
        assert_eq!(t.glslang, "glslangValidator");
        assert_eq!(t.fail_dispatch, None);
    }

    #[test]
    fn each_variable_is_read_and_a_bad_interval_refused() {
        let t = read(&[
            (PROGRESS_SECONDS, "0.5"),
            (EVAL_CHUNK, "3"),
            (GLSLANG, "/opt/glslang"),
            (TEST_FAIL_DISPATCH, "1"),
        ])
        .unwrap();
        assert_eq!(t.progress_interval, Duration::from_millis(500));
        assert_eq!((t.eval_chunk, t.fail_dispatch), (Some(3), Some(1)));
        assert_eq!(t.glslang, "/opt/glslang");
        assert_eq!(read(&[(EVAL_CHUNK, "0")]).unwrap().eval_chunk, None);
        let e = read(&[(PROGRESS_SECONDS, "soon")]).unwrap_err();
        assert!(e.contains("LINELIGHT_PROGRESS_SECONDS=`soon`"), "{e}");
    }
}
