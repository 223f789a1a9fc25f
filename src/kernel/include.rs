//! `#include` for GLSL and HLSL kernels, expanded here before either front end sees the text
//! (naga's GLSL preprocessor has no `#include`; glslang's is given the expanded text so that
//! one rule holds for both). `#include "f"` is looked up beside the including file, then in
//! the `--include` folders in order; `#include <f>` in the folders only. A cycle is refused,
//! and so are nesting deeper than `limits::MAX_INCLUDE_DEPTH` and a total above
//! `limits::MAX_INCLUDE_BYTES`. An include is confined ([`confined`]): it resolves, symlinks
//! followed, inside the kernel file's folder or an `--include` folder, never to an absolute
//! name, a `..` out of them or a link out, and a refused file is never read, so no message can
//! show what it holds. Each line of the expansion remembers its file and line, and
//! the line of the kernel file that brought it in.

use super::HeaderError;
use std::path::{Path, PathBuf};

/// The `--include` folders `#include` searches after the including file's own, in order: a
/// value made where the command line is parsed and passed down to every kernel file read
/// (`KernelFile::read`, `methods::kernel_set`). None: a kernel includes only what lies beside
/// it (GLSL, HLSL) or in `kernels/lib/` (WGSL).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Includes {
    dirs: Vec<PathBuf>,
}

impl Includes {
    /// The folders, searched in the order given.
    pub fn new(dirs: Vec<PathBuf>) -> Includes {
        Includes { dirs }
    }

    /// No folders.
    pub fn none() -> Includes {
        Includes::default()
    }

    /// The folders, in search order.
    pub fn dirs(&self) -> &[PathBuf] {
        &self.dirs
    }
}

/// Where one line of an expansion came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct From {
    /// Index into [`Expanded::files`]; 0 is the kernel file.
    pub file: usize,
    /// 1-based line in that file.
    pub line: u32,
    /// The kernel file's line that brought this one in (its own line, or its `#include`).
    pub top: u32,
}

/// A kernel with its includes expanded.
#[derive(Clone, Debug)]
pub struct Expanded {
    pub text: String,
    /// One entry per line of `text`.
    pub lines: Vec<From>,
    /// Paths as shown, and texts, of every file read; the kernel file first.
    pub files: Vec<(String, String)>,
}

impl Expanded {
    /// A kernel without includes (its text as it is).
    pub fn plain(shown: &str, text: &str) -> Expanded {
        Expanded {
            text: text.lines().map(|l| format!("{l}\n")).collect(),
            lines: (1..=text.lines().count() as u32)
                .map(|line| From {
                    file: 0,
                    line,
                    top: line,
                })
                .collect(),
            files: vec![(shown.to_string(), text.to_string())],
        }
    }

    /// `path:line` of 1-based line `n` of the expansion.
    pub fn locate(&self, n: usize) -> Option<(&str, u32)> {
        let f = self.lines.get(n.checked_sub(1)?)?;
        Some((self.files[f.file].0.as_str(), f.line))
    }
}

/// Expands the `#include`s of `text`, the kernel file `path` (shown as `shown`), searching
/// beside each including file and then in `includes`.
pub fn expand(path: &Path, shown: &str, text: &str, includes: &Includes) -> Result<Expanded, HeaderError> {
    let mut out = Expanded {
        text: String::new(),
        lines: Vec::new(),
        files: vec![(shown.to_string(), text.to_string())],
    };
    let dirs = includes.dirs();
    let mut total = text.len() as u64;
    let canonical = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    let folder = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let roots = Roots::new(Some(folder), dirs);
    walk(
        &mut out,
        0,
        path,
        text,
        &mut vec![canonical],
        None,
        (dirs, &roots),
        &mut total,
    )?;
    Ok(out)
}

/// The folders an include may resolve inside, canonical (symlinks resolved), with the names a
/// message shows them by.
pub(super) struct Roots {
    roots: Vec<(PathBuf, String)>,
}

impl Roots {
    /// The kernel file's folder (`kernel`: none for a WGSL kernel, whose includes are
    /// `kernels/lib/` or the `--include` folders) and the `--include` folders.
    pub(super) fn new(kernel: Option<&Path>, dirs: &[PathBuf]) -> Roots {
        let named = kernel
            .map(|k| (k, format!("the kernel's folder {}", k.display())))
            .into_iter()
            .chain(dirs.iter().map(|d| (d.as_path(), format!("--include {}", d.display()))));
        Roots {
            roots: named
                .filter_map(|(p, shown)| Some((std::fs::canonicalize(p).ok()?, shown)))
                .collect(),
        }
    }
}

/// The refusal of an absolute include name, if `name` is one.
fn absolute(name: &str) -> Option<String> {
    Path::new(name).is_absolute().then(|| {
        format!(
            "`{}`: an include names a path relative to the kernel's folder or an --include folder, not an \
             absolute path",
            crate::input::names::clip(name)
        )
    })
}

/// The canonical path of `found` (the file include `name` resolved to), or why it is refused:
/// an absolute name, or a file that resolves (through `..` or a symlink) outside every root.
/// Nothing is read from a refused file.
pub(super) fn confined(name: &str, found: &Path, roots: &Roots) -> Result<PathBuf, String> {
    if let Some(refused) = absolute(name) {
        return Err(refused);
    }
    let shown = crate::input::names::clip(name);
    let canonical = std::fs::canonicalize(found).map_err(|e| format!("included file `{shown}`: {e}"))?;
    if roots.roots.iter().any(|(root, _)| canonical.starts_with(root)) {
        return Ok(canonical);
    }
    let inside: Vec<&str> = roots.roots.iter().map(|(_, shown)| shown.as_str()).collect();
    Err(format!(
        "included file `{shown}` resolves to {}, outside {}: an include stays inside the kernel's folder \
         and the --include folders (no `..` out of them, no symlink out); it was not read",
        crate::input::names::clip(&canonical.display().to_string()),
        if inside.is_empty() {
            "every folder given".to_string()
        } else {
            inside.join(" and ")
        }
    ))
}

/// The file an include directive names: (name, quoted), or None when the line is no include.
pub(super) fn directive(line: &str) -> Option<Result<(String, bool), String>> {
    let rest = line
        .trim_start()
        .strip_prefix('#')?
        .trim_start()
        .strip_prefix("include")?;
    let rest = rest.trim();
    let parsed = if let Some(r) = rest.strip_prefix('"') {
        r.split_once('"').map(|(n, _)| (n.to_string(), true))
    } else if let Some(r) = rest.strip_prefix('<') {
        r.split_once('>').map(|(n, _)| (n.to_string(), false))
    } else {
        None
    };
    Some(parsed.filter(|(n, _)| !n.is_empty()).ok_or_else(|| {
        format!(
            "`{}`: an include names its file as \"file\" or <file>",
            crate::input::names::clip(line.trim())
        )
    }))
}

#[allow(clippy::too_many_arguments)]
fn walk(
    out: &mut Expanded,
    file: usize,
    path: &Path,
    text: &str,
    stack: &mut Vec<PathBuf>,
    top: Option<u32>,
    (dirs, roots): (&[PathBuf], &Roots),
    total: &mut u64,
) -> Result<(), HeaderError> {
    let shown = out.files[file].0.clone();
    for (i, line) in text.lines().enumerate() {
        let here = i as u32 + 1;
        let top_line = top.unwrap_or(here);
        let err = |message: String| HeaderError {
            path: shown.clone(),
            line: here as usize,
            message,
        };
        let Some(d) = directive(line) else {
            out.text.push_str(line);
            out.text.push('\n');
            out.lines.push(From {
                file,
                line: here,
                top: top_line,
            });
            continue;
        };
        let (name, quoted) = d.map_err(err)?;
        if let Some(refused) = absolute(&name) {
            return Err(err(refused));
        }
        if stack.len() > crate::limits::MAX_INCLUDE_DEPTH {
            return Err(err(format!(
                "includes nest deeper than {} files",
                crate::limits::MAX_INCLUDE_DEPTH
            )));
        }
        let beside = path.parent().map(|p| p.join(&name));
        let candidates: Vec<PathBuf> = beside
            .into_iter()
            .filter(|_| quoted)
            .chain(dirs.iter().map(|d| d.join(&name)))
            .collect();
        let Some(found) = candidates.iter().find(|p| p.is_file()) else {
            let looked: Vec<String> = candidates.iter().map(|p| p.display().to_string()).collect();
            return Err(err(format!(
                "cannot find included file `{}` (looked in: {}; add folders with --include DIR)",
                crate::input::names::clip(&name),
                if looked.is_empty() {
                    "no folder".to_string()
                } else {
                    looked.join(", ")
                }
            )));
        };
        let canonical = confined(&name, found, roots).map_err(err)?;
        if let Some(at) = stack.iter().position(|p| *p == canonical) {
            let chain: Vec<String> = stack[at..].iter().map(|p| p.display().to_string()).collect();
            return Err(err(format!(
                "`{}` includes itself: {} → {}",
                crate::input::names::clip(&name),
                chain.join(" → "),
                canonical.display()
            )));
        }
        let bytes = crate::io::read_bounded(found, "included file", crate::limits::MAX_TEXT_INPUT)
            .map_err(|e| err(e.to_string()))?;
        *total += bytes.len() as u64;
        if *total > crate::limits::MAX_INCLUDE_BYTES {
            return Err(err(format!(
                "the kernel and its includes exceed {} bytes",
                crate::limits::MAX_INCLUDE_BYTES
            )));
        }
        let included = String::from_utf8(bytes)
            .map_err(|_| err(format!("included file {} is not UTF-8 text", found.display())))?;
        let included = included.strip_prefix('\u{feff}').unwrap_or(&included).to_string();
        out.files.push((found.display().to_string(), included.clone()));
        let index = out.files.len() - 1;
        stack.push(canonical);
        walk(
            out,
            index,
            found,
            &included,
            stack,
            Some(top_line),
            (dirs, roots),
            total,
        )?;
        stack.pop();
    }
    Ok(())
}
