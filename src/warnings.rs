//! What a run warns of, typed (as hyperfine's `Warnings`): each is raised where it is found
//! ([`raise`]), kept once however often it is found (a kernel read by several commands' steps,
//! an input read in several passes), and printed in one place, to stderr when the command ends,
//! whether it succeeded or failed ([`print`], from main.rs).

use std::fmt;
use std::sync::Mutex;

/// One warning.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Warning {
    /// A GLSL or HLSL kernel whose constants lost their written digits in translation: its f64
    /// column is refused (src/kernel/written.rs).
    LostDigits { kernel: String, constants: Vec<String> },
    /// An eval input line whose `rect.normal` was not perpendicular to the segment and was made
    /// so; the output's `rect` records the normal used.
    NormalMadePerpendicular { at: String, id: String },
    /// The chain runs without the published table (it could not be read): the report's table
    /// loses a row.
    PublishedFeedLeftOut { reason: String },
    /// A method `scan` leaves out because it approximates another target than `line`.
    MethodNotScanned { method: String, target: String },
    /// A family `scan` leaves out because its M⁻¹ comes from a fitted table.
    FamilyNotScanned { family: String, kind: String },
    /// A method the CPU evaluator cannot run: its f64 and cpu_f32 columns stay empty (the
    /// first reason found is kept, once per method).
    NoCpuValues { method: String, reason: String },
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Warning::LostDigits { kernel, constants } => write!(
                f,
                "warning: {kernel}: {} constant(s) lost their written digits (the f64 column of a method that reaches one is refused):\n  {}",
                constants.len(),
                constants.join("\n  ")
            ),
            Warning::NormalMadePerpendicular { at, id } => write!(
                f,
                "note: {at}: `{id}`: rect.normal made perpendicular to the segment (docs/conventions.md); \
                 the output's `rect` records the normal used"
            ),
            Warning::PublishedFeedLeftOut { reason } => {
                write!(f, "WARNING: the `published` feed is left out of this chain: {reason}")
            }
            Warning::MethodNotScanned { method, target } => write!(
                f,
                "note: `{method}` is not scanned: it approximates `{target}`, and scan generates line configurations"
            ),
            Warning::FamilyNotScanned { family, kind } => write!(
                f,
                "note: family `{family}` ({kind}) is not scanned: its M⁻¹ comes from a fitted table"
            ),
            Warning::NoCpuValues { method, reason } => {
                write!(f, "note: `{method}` has no f64/cpu_f32 values: {reason}")
            }
        }
    }
}

static RAISED: Mutex<Vec<Warning>> = Mutex::new(Vec::new());

fn raised() -> std::sync::MutexGuard<'static, Vec<Warning>> {
    RAISED.lock().unwrap_or_else(|p| p.into_inner())
}

/// Records `w` for this run, unless it is already recorded.
pub fn raise(w: Warning) {
    let mut all = raised();
    let known = |x: &Warning| match (x, &w) {
        (Warning::NoCpuValues { method: a, .. }, Warning::NoCpuValues { method: b, .. }) => a == b,
        _ => *x == w,
    };
    if !all.iter().any(known) {
        all.push(w);
    }
}

/// The warnings recorded so far, in the order first raised.
pub fn collected() -> Vec<Warning> {
    raised().clone()
}

/// Prints every recorded warning to stderr, one after another, and forgets them.
pub fn print() {
    for w in std::mem::take(&mut *raised()) {
        eprintln!("{w}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_warning_is_kept_once_and_says_what_it_found() {
        let w = Warning::LostDigits {
            kernel: "k.glsl".into(),
            constants: vec!["PI".into(), "E".into()],
        };
        raise(w.clone());
        raise(w.clone());
        assert_eq!(collected().iter().filter(|x| **x == w).count(), 1);
        assert_eq!(
            w.to_string(),
            "warning: k.glsl: 2 constant(s) lost their written digits (the f64 column of a method that reaches one is refused):\n  PI\n  E"
        );
    }
}
