//! Kernel errors reported against the file that owns them.
//!
//! The composed module is prelude + kernel + entry point (+ for a composite, its inner line
//! method and the glue between them), so naga's spans are byte offsets into that
//! concatenation. Each error is mapped back to the owning file's own text and
//! rendered by naga's own emitter, so the user reads `my_kernel.wgsl:7:12` and the line
//! they wrote, not a line number of a file they never saw.

use super::rename::{original_offset, Rename};
use crate::kernel::Origin;
use naga::{Span, WithSpan};
use std::fmt;
use std::sync::Arc;

/// The name errors in the generated entry point are reported under.
pub const ENTRY_PATH: &str = "<linelight entry point>";

/// A kernel that cannot be compiled: a WGSL error, a broken kernel contract (no `method`,
/// a header param without its `override`) or a pipeline wgpu rejected.
#[derive(Clone, Debug, thiserror::Error)]
#[error("{report}")]
pub struct KernelError {
    /// The file the error is in: the kernel's path, `kernels/prelude.wgsl` or
    /// [`ENTRY_PATH`].
    pub path: String,
    /// 1-based line and column in that file, when the error points at source.
    pub location: Option<(u32, u32)>,
    /// The one-line message, without location.
    pub message: String,
    /// The full text: message, `path:line:column` and the offending line with a caret.
    pub report: String,
}

impl KernelError {
    /// An error that points at no particular source line.
    pub(crate) fn plain(path: &str, message: impl Into<String>) -> KernelError {
        let message = message.into();
        KernelError {
            path: path.to_string(),
            location: None,
            report: format!("{path}: {message}"),
            message,
        }
    }

    /// Adds a hint below the report, as naga renders its own notes.
    pub(crate) fn with_note(mut self, note: &str) -> KernelError {
        self.report.push_str(&format!("\n  = note: {note}"));
        self
    }
}

/// One file of the composed source.
#[derive(Clone, Debug)]
struct Segment {
    path: String,
    /// Where it starts in the composed source, and how long it is there.
    start: usize,
    len: usize,
    /// The file's own text, as errors show it.
    text: String,
    /// Identifiers renamed on the way into the composed source (the inner line method's).
    renames: Vec<Rename>,
}

/// Which file each byte of the composed source came from.
#[derive(Clone, Debug)]
pub(crate) struct SourceMap {
    segments: Vec<Segment>,
    /// The file blamed for errors that carry no span: the kernel, the likeliest culprit.
    fallback: String,
    /// Files translated from another language (GLSL), by path: their lines are shown
    /// instead of the translation's.
    origins: Vec<(String, Arc<Origin>)>,
}

impl SourceMap {
    pub(crate) fn new(fallback: &str) -> SourceMap {
        SourceMap {
            segments: Vec::new(),
            fallback: fallback.to_string(),
            origins: Vec::new(),
        }
    }

    /// Shows the lines of `path`'s segments as the lines of the file it was translated from.
    pub(crate) fn translated_from(&mut self, path: &str, origin: &Arc<Origin>) {
        self.origins.push((path.to_string(), origin.clone()));
    }

    fn origin(&self, path: &str) -> Option<&Origin> {
        self.origins.iter().find(|(p, _)| p == path).map(|(_, o)| &**o)
    }

    /// Appends `text` (owned by `path`) to `source`, recording where it landed. A missing
    /// final newline is added so the next file starts on a line of its own.
    pub(crate) fn push(&mut self, source: &mut String, path: &str, text: &str) {
        self.push_renamed(source, path, text, text, Vec::new());
    }

    /// Appends `renamed`, which is `original` with `renames` applied: errors in it are
    /// shown in `original`, at the original line and column.
    pub(crate) fn push_renamed(
        &mut self,
        source: &mut String,
        path: &str,
        original: &str,
        renamed: &str,
        renames: Vec<Rename>,
    ) {
        let start = source.len();
        source.push_str(renamed);
        let mut text = original.to_string();
        if !renamed.ends_with('\n') {
            source.push('\n');
            text.push('\n');
        }
        self.segments.push(Segment {
            path: path.to_string(),
            start,
            len: source.len() - start,
            text,
            renames,
        });
    }

    /// The segment holding byte `offset`; an offset at the very end (naga's "unexpected end
    /// of file") belongs to the last one.
    fn segment(&self, offset: usize) -> &Segment {
        self.segments
            .iter()
            .rev()
            .find(|s| s.start <= offset)
            .unwrap_or(&self.segments[0])
    }

    /// `span` relative to its segment's own text, clamped to it.
    fn local(&self, span: Span) -> (&Segment, Span) {
        let range = span.to_range().unwrap_or(0..0);
        let seg = self.segment(range.start);
        let clamp = |o: usize| {
            let composed = o.saturating_sub(seg.start).min(seg.len);
            original_offset(&seg.renames, composed).min(seg.text.len())
        };
        (seg, Span::from(clamp(range.start)..clamp(range.end)))
    }

    /// The file, 1-based line and text of that line holding byte `offset` of the
    /// composed source (for the CPU evaluator's per-line attribution).
    pub(crate) fn locate(&self, offset: usize) -> (String, usize, String) {
        let (seg, span) = self.local(Span::from(offset..offset));
        let at = span.to_range().map_or(0, |r| r.start);
        let line = seg.text[..at].matches('\n').count() + 1;
        if let Some((line, text)) = self.origin(&seg.path).and_then(|o| o.line(line)) {
            return (seg.path.clone(), line, text.to_string());
        }
        let text = seg.text.lines().nth(line - 1).unwrap_or("").to_string();
        (seg.path.clone(), line, text)
    }

    pub(crate) fn parse_error(&self, e: &naga::front::wgsl::ParseError) -> KernelError {
        let labels = e.labels().map(|(span, label)| (span, label.to_string())).collect();
        self.diagnose(e.message(), labels, e.notes().map(str::to_string).collect())
    }

    pub(crate) fn validation_error(&self, e: &WithSpan<naga::valid::ValidationError>) -> KernelError {
        // naga also labels the enclosing item (the whole function), which would move the
        // reported location to the function's first line: keep only the innermost labels.
        let spans: Vec<_> = e.spans().cloned().collect();
        let encloses = |outer: Span, inner: Span| {
            let (o, i) = (outer.to_range().unwrap_or(0..0), inner.to_range().unwrap_or(0..0));
            outer != inner && o.start <= i.start && i.end <= o.end
        };
        let mut labels: Vec<_> = spans
            .iter()
            .filter(|(s, _)| !spans.iter().any(|(t, _)| encloses(*s, *t)))
            .cloned()
            .collect();
        labels.reverse();
        let mut notes = Vec::new();
        let mut cause = std::error::Error::source(e.as_inner());
        while let Some(c) = cause {
            notes.push(c.to_string());
            cause = c.source();
        }
        self.diagnose(&e.as_inner().to_string(), labels, notes)
    }

    /// Renders `message` at its first labelled span, in the file that owns that span.
    /// Labels in other files become notes with their own `path:line:column`.
    pub(crate) fn diagnose(&self, message: &str, labels: Vec<(Span, String)>, notes: Vec<String>) -> KernelError {
        let labels: Vec<_> = labels.into_iter().filter(|(s, _)| s.is_defined()).collect();
        let Some(&(primary, _)) = labels.first() else {
            return notes
                .iter()
                .fold(KernelError::plain(&self.fallback, message), |e, n| e.with_note(n));
        };
        let (seg, local) = self.local(primary);
        if let Some(origin) = self.origin(&seg.path) {
            return self.diagnose_translated(seg, local, origin, message, notes);
        }
        let mut spans = Vec::new();
        let mut other = Vec::new();
        for (span, label) in labels {
            let (s, l) = self.local(span);
            if s.start == seg.start {
                spans.push((l, label));
            } else {
                let at = l.location(&s.text);
                other.push(format!("{label} at {}:{}:{}", s.path, at.line_number, at.line_position));
            }
        }
        let notes = other.into_iter().chain(notes).map(|n| format!("note: {n}")).collect();
        let mut diagnostic = WithSpan::new(Message {
            text: message.to_string(),
            notes: Note::chain(notes),
        });
        for (span, label) in spans {
            diagnostic = diagnostic.with_span(span, label);
        }
        let at = local.location(&seg.text);
        KernelError {
            path: seg.path.clone(),
            location: Some((at.line_number, at.line_position)),
            message: message.to_string(),
            report: diagnostic
                .emit_to_string_with_path(&seg.text, &seg.path)
                .trim_end()
                .to_string(),
        }
    }
}

impl SourceMap {
    /// An error in a translated kernel: shown at the original file's line, with the line of
    /// the translation it was found in as a note.
    fn diagnose_translated(
        &self,
        seg: &Segment,
        local: Span,
        origin: &Origin,
        message: &str,
        notes: Vec<String>,
    ) -> KernelError {
        let at = local.location(&seg.text);
        let translated = seg.text.lines().nth(at.line_number as usize - 1).unwrap_or("").trim();
        let Some((line, original)) = origin.line(at.line_number as usize) else {
            return KernelError::plain(&seg.path, message)
                .with_note(&format!("in the WGSL translation of the kernel: `{translated}`"));
        };
        let start: usize = origin.text.split_inclusive('\n').take(line - 1).map(str::len).sum();
        let len = origin.text.lines().nth(line - 1).map_or(0, str::len);
        let translation =
            (original.trim() != translated).then(|| format!("note: in the WGSL translation: `{translated}`"));
        let notes = translation
            .into_iter()
            .chain(notes.into_iter().map(|n| format!("note: {n}")))
            .collect();
        let diagnostic = WithSpan::new(Message {
            text: message.to_string(),
            notes: Note::chain(notes),
        })
        .with_span(Span::from(start..start + len), "here");
        KernelError {
            path: seg.path.clone(),
            location: Some((line as u32, 1)),
            message: message.to_string(),
            report: diagnostic
                .emit_to_string_with_path(&origin.text, &seg.path)
                .trim_end()
                .to_string(),
        }
    }
}

/// A message for naga's emitter, which takes its notes from the `source()` chain.
#[derive(Debug)]
struct Message {
    text: String,
    notes: Option<Box<Note>>,
}

#[derive(Debug)]
struct Note {
    text: String,
    next: Option<Box<Note>>,
}

impl Note {
    fn chain(notes: Vec<String>) -> Option<Box<Note>> {
        notes
            .into_iter()
            .rev()
            .fold(None, |next, text| Some(Box::new(Note { text, next })))
    }
}

impl fmt::Display for Message {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text)
    }
}

impl fmt::Display for Note {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text)
    }
}

impl std::error::Error for Message {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.notes.as_deref().map(|n| n as _)
    }
}

impl std::error::Error for Note {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.next.as_deref().map(|n| n as _)
    }
}
