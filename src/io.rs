//! All file writing, in one place, so no output is ever destructive:
//!
//! - a regular file (or a path that does not exist yet) is written to a temporary file in
//!   its own directory and renamed over it, so a failed run leaves the old file whole;
//! - a symlink is followed, and the file it points to is replaced the same way (the link
//!   stays a link);
//! - anything else (a FIFO, a character device such as `/dev/null` or `/dev/stdout`, a
//!   socket) is written through, never replaced;
//! - every output of a run is checked before any work, by one plan ([`OutputPlan`]): one
//!   that is one of the run's inputs, is another output, lies inside a report folder (this
//!   run's or one on disk), or that the user cannot write, is refused;
//! - a report set (a sweep's, scan's or chain's report folder, a baseline) is written into a
//!   sibling temporary directory and swapped in whole ([`write_set`]): a folder only ever
//!   holds one run's files, of one kind of set ([`SetKind`]);
//! - an input that a folder names (a baseline's files) is read only when it is a regular
//!   file of bounded size ([`read_regular`]);
//! - temporaries of killed runs (sets and single files) are removed by the next run that
//!   writes the same path;
//! - a tool's scratch folder (glslang's input and output for an HLSL kernel) is a fresh folder
//!   under the system's temporary directory, removed when done ([`Scratch`]).

use std::collections::BTreeSet;
use std::ffi::CString;
use std::fs;
use std::io::Write;
use std::os::unix::ffi::OsStrExt;
use std::os::unix::fs::MetadataExt;
use std::path::{Component, Path, PathBuf};

/// A refused or failed output, with the path and the reason (exit 2).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct OutputError(pub String);

/// An input file refused or unreadable ([`read_regular`]), with the path and the reason (exit 2).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct InputError(pub String);

fn fail(message: String) -> OutputError {
    OutputError(message)
}

/// `path` made absolute and free of `.`/`..`, with every existing ancestor's symlinks
/// resolved: two spellings of one place compare equal even when the file does not exist.
pub fn resolved(path: &Path) -> PathBuf {
    let absolute = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let mut out = PathBuf::new();
    for c in absolute.components() {
        match c {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            other => out.push(other),
        }
    }
    // The longest existing prefix, canonicalised (symlinks resolved), then the rest.
    let mut existing = out.clone();
    let mut rest = Vec::new();
    while !existing.as_os_str().is_empty() {
        if let Ok(c) = fs::canonicalize(&existing) {
            let mut p = c;
            for r in rest.iter().rev() {
                p.push(r);
            }
            return p;
        }
        match existing.file_name() {
            Some(name) => rest.push(name.to_os_string()),
            None => break,
        }
        existing.pop();
    }
    out
}

/// (device, inode) of what `path` names after following symlinks, when it exists.
fn identity(path: &Path) -> Option<(u64, u64)> {
    fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
}

/// Whether the calling user may write `path` (access(2), which also answers for FIFOs
/// and devices without opening them: opening a FIFO would block until a reader comes).
fn writable(path: &Path) -> bool {
    match CString::new(path.as_os_str().as_bytes()) {
        // SAFETY: `c` is a valid NUL-terminated string for the duration of the call.
        Ok(c) => unsafe { libc::access(c.as_ptr(), libc::W_OK) == 0 },
        Err(_) => false,
    }
}

/// Which command a report folder belongs to. A folder holds one kind of set only, so no
/// command replaces another's folder or mixes its files into it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SetKind {
    /// `sweep` and `merge`: OUT/<case>/.
    Sweep,
    /// `scan`: OUT/<case>-scan/.
    Scan,
    /// `chain`: OUT/<case>-chain/, or its --out.
    Chain,
    /// `sweep --save-baseline DIR`.
    Baseline,
    /// `render`: OUT/<scene>/.
    Render,
    /// `render --save-baseline DIR`: a render baseline (src/app/gate/render.rs).
    RenderBaseline,
    /// `objectives`: OUT, by default reports/ggx-objectives/.
    Objectives,
}

impl SetKind {
    pub const ALL: [SetKind; 7] = [
        SetKind::Sweep,
        SetKind::Scan,
        SetKind::Chain,
        SetKind::Baseline,
        SetKind::Render,
        SetKind::RenderBaseline,
        SetKind::Objectives,
    ];

    /// The name written in the folder's [`KIND_MARKER`].
    pub fn name(self) -> &'static str {
        match self {
            SetKind::Sweep => "sweep",
            SetKind::Scan => "scan",
            SetKind::Chain => "chain",
            SetKind::Baseline => "baseline",
            SetKind::Render => "render",
            SetKind::RenderBaseline => "render-baseline",
            SetKind::Objectives => "objectives",
        }
    }

    /// What messages call a folder of this kind.
    pub fn folder(self) -> &'static str {
        match self {
            SetKind::Sweep => "report folder",
            SetKind::Scan => "scan report folder",
            SetKind::Chain => "chain report folder",
            SetKind::Baseline => "baseline folder",
            SetKind::Render => "render folder",
            SetKind::RenderBaseline => "render baseline folder",
            SetKind::Objectives => "objectives report folder",
        }
    }

    /// The command that writes (and replaces) a folder of this kind.
    fn writer(self) -> &'static str {
        match self {
            SetKind::Sweep => "linelight sweep",
            SetKind::Scan => "linelight scan",
            SetKind::Chain => "linelight chain",
            SetKind::Baseline => "linelight sweep --save-baseline",
            SetKind::Render => "linelight render",
            SetKind::RenderBaseline => "linelight render --save-baseline",
            SetKind::Objectives => "linelight objectives",
        }
    }

    /// Whether a file or folder of this name, at the top of a folder of this kind, is one
    /// the command writes. A baseline is committed into the user's repository, where other
    /// files may be put beside it: a folder holding one is not replaced. Report folders are
    /// generated and replaced whole (docs/robustness.md).
    fn owns(self, name: &str) -> bool {
        match self {
            SetKind::Baseline => [KIND_MARKER, "baseline.json", "timings.json", "errors"].contains(&name),
            SetKind::RenderBaseline => [KIND_MARKER, "render-baseline.json", "images"].contains(&name),
            _ => true,
        }
    }
}

/// The file in every report folder that says which kind of set it is (it holds the kind's
/// name): a folder without one (or, written before it, without [`SET_MARKER`]) is no report
/// folder and is never replaced.
pub const KIND_MARKER: &str = ".linelight-set";

/// The kind of report set `dir` is, if it is one: its [`KIND_MARKER`], or for folders
/// written before the marker, the file every set of its kind holds.
pub fn set_kind(dir: &Path) -> Option<SetKind> {
    let marker = dir.join(KIND_MARKER);
    if fs::symlink_metadata(&marker).is_ok() {
        let text = read_regular(&marker, "report folder marker", 64).ok()?;
        let text = String::from_utf8_lossy(&text);
        return SetKind::ALL.into_iter().find(|k| k.name() == text.trim());
    }
    if dir.join("render.json").is_file() && dir.join("render.md").is_file() {
        return Some(SetKind::Render);
    }
    if dir.join(SET_MARKER).is_file() {
        return Some(if dir.join("scan.md").is_file() {
            SetKind::Scan
        } else {
            SetKind::Sweep
        });
    }
    dir.join("baseline.json").is_file().then_some(SetKind::Baseline)
}

/// The nearest folder above `path` (not `path` itself) that is a report set, and its kind.
/// A folder written before the marker counts only with its pair of files (`summary.json` and
/// `report.md` or `scan.md`; `baseline.json` and `errors/`): a project folder that happens to
/// hold a `summary.json` does not make every output below it refused.
fn enclosing_set(path: &Path) -> Option<(PathBuf, SetKind)> {
    path.ancestors().skip(1).find_map(|a| {
        let kind = set_kind(a)?;
        let marked = fs::symlink_metadata(a.join(KIND_MARKER)).is_ok();
        let paired = match kind {
            SetKind::Sweep => a.join("report.md").is_file(),
            SetKind::Scan => true,
            SetKind::Baseline => a.join("errors").is_dir(),
            SetKind::Chain => false,
            SetKind::Render => true,
            // Written with its marker from the start.
            SetKind::RenderBaseline => false,
            SetKind::Objectives => false,
        };
        (marked || paired).then(|| (a.to_path_buf(), kind))
    })
}

/// An input file or folder a run reads, which no output may be, replace or hold.
struct Input {
    what: String,
    path: PathBuf,
}

/// One output of a run: a file, or a report set written whole into a folder.
enum Planned {
    File { flag: String, path: PathBuf },
    Set { flag: String, dir: PathBuf, kind: SetKind },
}

impl Planned {
    fn flag_path(&self) -> (&str, &Path) {
        match self {
            Planned::File { flag, path } => (flag, path),
            Planned::Set { flag, dir, .. } => (flag, dir),
        }
    }
}

/// Every output of one run and every input it reads, checked together before any work
/// ([`OutputPlan::check`]). Every command builds one: `--raw`, `--junit`, `--save-baseline`,
/// `--output`, `--json`, shard states, fitted tables and the report folders of sweep, merge,
/// scan and chain all pass the same rules.
#[derive(Default)]
pub struct OutputPlan {
    inputs: Vec<Input>,
    outputs: Vec<Planned>,
}

impl OutputPlan {
    pub fn new() -> OutputPlan {
        OutputPlan::default()
    }

    /// An input file or folder (`what` names it in messages: "the case file", "--kernel").
    pub fn input(&mut self, what: &str, path: &Path) -> &mut Self {
        self.inputs.push(Input {
            what: what.to_string(),
            path: path.to_path_buf(),
        });
        self
    }

    /// An output file, given as `flag`.
    pub fn file(&mut self, flag: &str, path: &Path) -> &mut Self {
        self.outputs.push(Planned::File {
            flag: flag.to_string(),
            path: path.to_path_buf(),
        });
        self
    }

    /// A report set of `kind` written whole into `dir` ([`write_set`]).
    pub fn set(&mut self, flag: &str, dir: &Path, kind: SetKind) -> &mut Self {
        self.outputs.push(Planned::Set {
            flag: flag.to_string(),
            dir: dir.to_path_buf(),
            kind,
        });
        self
    }

    /// Checks every output, before any work. An output file is not an input (compared by
    /// device and inode, or by its resolved path), not a directory, and writable or
    /// creatable. A report folder is absent, empty or a set of its own kind, and holds no
    /// input. No output is another, or lies inside a report folder this run writes or one
    /// already on disk (whose next run would delete it): one set per folder.
    pub fn check(&self) -> Result<(), OutputError> {
        let inputs: Vec<(&Input, PathBuf)> = self.inputs.iter().map(|i| (i, resolved(&i.path))).collect();
        let mut seen: Vec<(&Planned, PathBuf)> = Vec::new();
        for out in &self.outputs {
            let (flag, path) = out.flag_path();
            let shown = path.display();
            let target = resolved(path);
            // Two outputs that collide first: that is the mistake, whatever else holds.
            for (other, at) in &seen {
                let (other_flag, other_path) = other.flag_path();
                let same = match (out, other) {
                    (Planned::File { .. }, Planned::File { .. }) => same_file(path, &target, other_path, at),
                    _ => target == *at,
                };
                if same {
                    return Err(fail(format!(
                        "{flag} {shown} and {other_flag} {} are the same path: each output needs its own",
                        other_path.display()
                    )));
                }
                let nested =
                    |outer: &Planned, outer_at: &Path, inner_flag: &str, inner: &Path, inner_at: &Path| match outer {
                        Planned::Set { flag, dir, kind } if inner_at.starts_with(outer_at) => Some(fail(format!(
                            "{inner_flag} {} lies inside the {} {} this run writes ({flag}), which is \
                             replaced whole: choose a path outside it",
                            inner.display(),
                            kind.folder(),
                            dir.display()
                        ))),
                        _ => None,
                    };
                if let Some(e) =
                    nested(other, at, flag, path, &target).or_else(|| nested(out, &target, other_flag, other_path, at))
                {
                    return Err(e);
                }
            }
            match out {
                Planned::File { .. } => check_file(flag, path, &target, &inputs)?,
                Planned::Set { kind, .. } => {
                    check_set(flag, path, *kind)?;
                    for (input, at) in &inputs {
                        if at.starts_with(&target) {
                            return Err(fail(format!(
                                "{flag} {shown}: this {} is replaced whole, and it holds {} {}, an input of \
                                 this run: choose another folder",
                                kind.folder(),
                                input.what,
                                input.path.display()
                            )));
                        }
                    }
                }
            }
            if let Some((dir, kind)) = enclosing_set(&target) {
                return Err(fail(format!(
                    "{flag} {shown} lies inside {}, a {} that `{}` replaces whole: choose a path outside it",
                    dir.display(),
                    kind.folder(),
                    kind.writer()
                )));
            }
            seen.push((out, target));
        }
        Ok(())
    }
}

/// Whether two output files are one: the same device and inode when both exist, else the
/// same resolved path. Character devices (`/dev/null`) are written through and never
/// replaced, so two outputs may share one.
fn same_file(a: &Path, a_at: &Path, b: &Path, b_at: &Path) -> bool {
    use std::os::unix::fs::FileTypeExt;
    if fs::metadata(a).is_ok_and(|m| m.file_type().is_char_device()) {
        return false;
    }
    match (identity(a), identity(b)) {
        (Some(x), Some(y)) => x == y,
        _ => a_at == b_at,
    }
}

/// One output file: not an input, not a directory, writable or creatable.
fn check_file(flag: &str, path: &Path, target: &Path, inputs: &[(&Input, PathBuf)]) -> Result<(), OutputError> {
    let shown = path.display();
    let id = identity(path);
    for (input, at) in inputs {
        let same = match (id, identity(&input.path)) {
            (Some(a), Some(b)) => a == b,
            _ => target == at,
        };
        if same {
            return Err(fail(format!(
                "{flag} {shown} is the same file as {} {}: refusing to overwrite an input",
                input.what,
                input.path.display()
            )));
        }
    }
    if names_a_directory(path) {
        return Err(fail(format!(
            "{flag} {shown} names a directory (it ends with `/`, `.` or `..`), not a file: give a file name"
        )));
    }
    match fs::metadata(path) {
        Ok(m) if m.is_dir() => Err(fail(format!("{flag} {shown} is a directory, not a file"))),
        Ok(_) if !writable(path) => Err(fail(format!("{flag} {shown}: permission denied (not writable)"))),
        Ok(_) => Ok(()),
        Err(_) => check_creatable(flag, target),
    }
}

/// Whether `path` as spelled can only name a directory: it ends with `/` or its last part is
/// `.` or `..` (`out/`, `out/.`), so no file can be written there, whether or not it exists.
fn names_a_directory(path: &Path) -> bool {
    let bytes = path.as_os_str().as_bytes();
    bytes.is_empty() || bytes.ends_with(b"/") || bytes == b"." || bytes.ends_with(b"/.") || path.file_name().is_none()
}

/// A file that does not exist yet can be made when its nearest existing ancestor is a
/// writable directory (the directories in between are created).
fn check_creatable(flag: &str, target: &Path) -> Result<(), OutputError> {
    let mut dir = target.parent();
    while let Some(d) = dir {
        match fs::metadata(d) {
            Ok(m) if m.is_dir() => {
                return if writable(d) {
                    Ok(())
                } else {
                    Err(fail(format!(
                        "{flag} {}: directory {} is not writable",
                        target.display(),
                        d.display()
                    )))
                };
            }
            Ok(_) => {
                return Err(fail(format!(
                    "{flag} {}: {} is not a directory",
                    target.display(),
                    d.display()
                )))
            }
            Err(_) => dir = d.parent(),
        }
    }
    Err(fail(format!(
        "{flag} {}: no existing parent directory",
        target.display()
    )))
}

/// An output written but not yet in place: [`Staged::commit`] renames it over its path,
/// dropping it removes it. (A FIFO or device is written through at once: there is nothing
/// to replace.)
#[must_use = "a staged output is removed unless committed"]
pub struct Staged {
    tmp: Option<PathBuf>,
    target: PathBuf,
}

impl Staged {
    /// Puts the output in place (one rename).
    pub fn commit(mut self) -> Result<(), OutputError> {
        if let Some(tmp) = self.tmp.take() {
            if let Err(e) = fs::rename(&tmp, &self.target) {
                let _ = fs::remove_file(&tmp);
                return Err(fail(format!("cannot write {}: {e}", self.target.display())));
            }
        }
        Ok(())
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        if let Some(tmp) = self.tmp.take() {
            let _ = fs::remove_file(tmp);
        }
    }
}

/// Writes an output file through `write` and puts it in place: see the module doc for
/// what happens to each kind of path.
pub fn write_output(
    path: &Path,
    write: &mut dyn FnMut(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), OutputError> {
    stage_output(path, write)?.commit()
}

/// Writes an output next to its path without replacing it yet ([`Staged`]), so that
/// several outputs can be put in place together once all are complete.
pub fn stage_output(
    path: &Path,
    write: &mut dyn FnMut(&mut dyn Write) -> std::io::Result<()>,
) -> Result<Staged, OutputError> {
    let err = |e: std::io::Error| fail(format!("cannot write {}: {e}", path.display()));
    if let Ok(m) = fs::metadata(path) {
        if m.is_dir() {
            return Err(fail(format!("cannot write {}: it is a directory", path.display())));
        }
        if !m.is_file() {
            // FIFO, device, socket: written through, never replaced.
            let f = fs::OpenOptions::new().write(true).open(path).map_err(err)?;
            let mut w = std::io::BufWriter::new(f);
            write(&mut w).map_err(err)?;
            w.flush().map_err(err)?;
            return Ok(Staged {
                tmp: None,
                target: path.to_path_buf(),
            });
        }
    }
    // A symlink: the file it names is replaced; the link stays.
    let target = if fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink()) {
        resolved(path)
    } else {
        path.to_path_buf()
    };
    let dir = target
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    fs::create_dir_all(dir).map_err(|e| fail(format!("cannot create {}: {e}", dir.display())))?;
    let name = target
        .file_name()
        .map_or("out".into(), |n| n.to_string_lossy().into_owned());
    clean_stale(dir, &name);
    let tmp = dir.join(format!(".{name}.tmp-{}", std::process::id()));
    let staged = Staged {
        tmp: Some(tmp.clone()),
        target: target.clone(),
    };
    let result = (|| -> std::io::Result<()> {
        let f = fs::File::create(&tmp)?;
        let mut w = std::io::BufWriter::new(f);
        write(&mut w)?;
        let f = w.into_inner().map_err(|e| e.into_error())?;
        // A replaced file keeps its permissions.
        if let Ok(old) = fs::metadata(&target) {
            f.set_permissions(old.permissions())?;
        }
        f.sync_all()
    })();
    // On an error `staged` drops and removes the temporary.
    result.map_err(err)?;
    Ok(staged)
}

/// Writes `contents` to `path` without destroying anything: [`write_bytes`] as an
/// `anyhow` error (its source kept).
pub fn write_atomic(path: &Path, contents: &[u8]) -> anyhow::Result<()> {
    Ok(write_bytes(path, contents)?)
}

/// Writes `bytes` to `path` (see [`write_output`]).
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    write_output(path, &mut |w| w.write_all(bytes))
}

/// Removes the file `path` (`what` names it in the message), e.g. a finished run's checkpoint.
pub fn remove(path: &Path, what: &str) -> Result<(), OutputError> {
    fs::remove_file(path).map_err(|e| fail(format!("{what} {} could not be removed: {e}", path.display())))
}

/// The file every report folder written before [`KIND_MARKER`] holds: a folder with neither
/// is not replaced.
pub const SET_MARKER: &str = "summary.json";

/// Checks, before any work, that `dir` (given as `flag`) can be written as a report set of
/// `kind`: it is absent, empty or such a set already (never another command's), holds
/// nothing the command does not write (a baseline), and its parent is writable.
pub fn check_set(flag: &str, dir: &Path, kind: SetKind) -> Result<(), OutputError> {
    match fs::metadata(dir) {
        Ok(m) if !m.is_dir() => Err(fail(format!(
            "{flag} {}: the {} exists and is not a directory",
            dir.display(),
            kind.folder()
        ))),
        Ok(_) => {
            let mut entries = fs::read_dir(dir)
                .map_err(|e| fail(format!("{flag} {}: cannot read the folder: {e}", dir.display())))?
                .flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned());
            if let Some(first) = entries.next() {
                match set_kind(dir) {
                    None => {
                        return Err(fail(format!(
                            "{flag} {} exists and is not a linelight report folder (no {KIND_MARKER} or \
                             {SET_MARKER}): it would be replaced whole; move it or choose another folder",
                            dir.display()
                        )))
                    }
                    Some(found) if found != kind => {
                        return Err(fail(format!(
                            "{flag} {} is a {} (written by `{}`), not a {}: it would be replaced whole; \
                             choose another folder",
                            dir.display(),
                            found.folder(),
                            found.writer(),
                            kind.folder()
                        )))
                    }
                    Some(_) => {
                        if let Some(foreign) = std::iter::once(first).chain(entries).find(|n| !kind.owns(n)) {
                            return Err(fail(format!(
                                "{flag} {}: the {} holds `{}`, which `{}` does not write; the folder is \
                                 replaced whole, so move it out first",
                                dir.display(),
                                kind.folder(),
                                foreign.chars().take(80).collect::<String>(),
                                kind.writer()
                            )));
                        }
                    }
                }
            }
            let parent = resolved(dir);
            let parent = parent.parent().unwrap_or(Path::new("/"));
            if writable(parent) {
                Ok(())
            } else {
                Err(fail(format!(
                    "{flag} {}: directory {} is not writable",
                    dir.display(),
                    parent.display()
                )))
            }
        }
        Err(_) => check_creatable(flag, &resolved(dir).join(KIND_MARKER)),
    }
}

/// Reads an input file the user named (a case file, a kernel): any kind of file, a pipe
/// from `<(…)` included, but at most `max` bytes, so `/dev/zero` or a runaway generator is
/// refused rather than read without end.
pub fn read_bounded(path: &Path, what: &str, max: u64) -> Result<Vec<u8>, InputError> {
    use std::io::Read;
    let shown = path.display();
    let err = |e: std::io::Error| InputError(format!("cannot read {what} {shown}: {e}"));
    let f = fs::File::open(path).map_err(err)?;
    let mut bytes = Vec::new();
    f.take(max + 1).read_to_end(&mut bytes).map_err(err)?;
    if bytes.len() as u64 > max {
        return Err(InputError(format!(
            "{what} {shown} is larger than {max} bytes: not read further"
        )));
    }
    Ok(bytes)
}

/// [`read_bounded`], as UTF-8 text (a scene file).
pub fn read_text(path: &Path, what: &str, max: u64) -> Result<String, InputError> {
    String::from_utf8(read_bounded(path, what, max)?)
        .map_err(|e| InputError(format!("cannot read {what} {}: not UTF-8 text ({e})", path.display())))
}

/// Opens an input read as a stream, a block or a line at a time, never held whole (a JSONL
/// file of configurations: its size is refused by the memory estimate, not here).
pub fn open_stream(path: &Path, what: &str) -> Result<fs::File, InputError> {
    fs::File::open(path).map_err(|e| InputError(format!("cannot read {what} {}: {e}", path.display())))
}

/// A JSON run record (a fit's `*.run.json` beside its table), None when absent, unreadable,
/// larger than `limits::MAX_RECORD_BYTES` or not JSON: the report then leaves its sentence out.
pub fn read_record(path: &Path, max: u64) -> Option<serde_json::Value> {
    serde_json::from_slice(&read_regular(path, "run record", max).ok()?).ok()
}

/// A small file of the system (`/proc/meminfo`, the host name), None when it cannot be read
/// or is larger than `max` bytes.
pub fn read_system(path: &str, max: u64) -> Option<String> {
    String::from_utf8(read_bounded(Path::new(path), path, max).ok()?).ok()
}

/// Reads an input file that a folder names (a baseline's files, a report folder's marker):
/// it must be a regular file of at most `max` bytes. It is opened without blocking, so a
/// FIFO is refused, never waited on, and a device is never read without end.
pub fn read_regular(path: &Path, what: &str, max: u64) -> Result<Vec<u8>, InputError> {
    use std::io::Read;
    let (mut f, len) = open_regular(path, what, max)?;
    let mut bytes = Vec::with_capacity(len as usize);
    f.read_to_end(&mut bytes)
        .map_err(|e| InputError(format!("cannot read {what} {}: {e}", path.display())))?;
    if bytes.len() as u64 > max {
        return Err(InputError(format!(
            "{what} {} grew past {max} bytes while read",
            path.display()
        )));
    }
    Ok(bytes)
}

/// [`read_regular`]'s checks, with the file left to read as a stream (at most `max + 1`
/// bytes: a reader that finds more says the file grew); also its length when opened.
pub fn open_regular(path: &Path, what: &str, max: u64) -> Result<(std::io::Take<fs::File>, u64), InputError> {
    use std::io::Read;
    use std::os::unix::fs::OpenOptionsExt;
    let shown = path.display();
    let err = |e: std::io::Error| InputError(format!("cannot read {what} {shown}: {e}"));
    let f = fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK)
        .open(path)
        .map_err(err)?;
    let m = f.metadata().map_err(err)?;
    if !m.is_file() {
        return Err(InputError(format!(
            "{what} {shown} is not a regular file (a FIFO, a device or a folder): not read"
        )));
    }
    if m.len() > max {
        return Err(InputError(format!(
            "{what} {shown} has {} bytes, more than the {max} it can hold",
            m.len()
        )));
    }
    Ok((f.take(max + 1), m.len()))
}

fn process_alive(pid: u32) -> bool {
    Path::new(&format!("/proc/{pid}")).exists()
}

/// Removes temporaries of report sets (folders) or outputs (files) named `.<name>.tmp-<pid>`
/// (or `.old-<pid>`) that runs no longer running left in `parent`.
fn clean_stale(parent: &Path, name: &str) {
    let Ok(entries) = fs::read_dir(parent) else {
        return;
    };
    for e in entries.flatten() {
        let file = e.file_name();
        let file = file.to_string_lossy();
        let Some(rest) = file.strip_prefix(&format!(".{name}.")) else {
            continue;
        };
        let pid = rest
            .strip_prefix("tmp-")
            .or_else(|| rest.strip_prefix("old-"))
            .and_then(|p| p.parse::<u32>().ok());
        if pid.is_some_and(|p| !process_alive(p)) {
            let path = e.path();
            let _ = if path.is_dir() {
                fs::remove_dir_all(path)
            } else {
                fs::remove_file(path)
            };
        }
    }
}

/// Swaps two directory entries atomically (Linux renameat2 RENAME_EXCHANGE).
fn exchange(a: &Path, b: &Path) -> std::io::Result<()> {
    let ca = CString::new(a.as_os_str().as_bytes())?;
    let cb = CString::new(b.as_os_str().as_bytes())?;
    // SAFETY: both paths are valid NUL-terminated strings for the duration of the call.
    let r = unsafe {
        libc::renameat2(
            libc::AT_FDCWD,
            ca.as_ptr(),
            libc::AT_FDCWD,
            cb.as_ptr(),
            libc::RENAME_EXCHANGE,
        )
    };
    if r == 0 {
        Ok(())
    } else {
        Err(std::io::Error::last_os_error())
    }
}

/// Writes a report set of `kind` into `dir` as one: every file (names relative to `dir`, `/`
/// for sub-folders) and the [`KIND_MARKER`] go into a sibling temporary folder, which then
/// replaces `dir` whole. On any error nothing in `dir` has changed. Returns the paths written.
pub fn write_set(dir: &Path, kind: SetKind, files: &[(String, Vec<u8>)]) -> Result<Vec<PathBuf>, OutputError> {
    check_set(kind.folder(), dir, kind)?;
    let mut names = BTreeSet::new();
    for (name, _) in files {
        let relative = Path::new(name);
        if relative.components().any(|c| !matches!(c, Component::Normal(_))) || name == KIND_MARKER {
            return Err(fail(format!("report file name `{name}` leaves the report folder")));
        }
        if !names.insert(name.as_str()) {
            return Err(fail(format!("two report files are both named `{name}`")));
        }
    }
    // A symlinked report folder is replaced where it lives.
    let dir = if fs::symlink_metadata(dir).is_ok_and(|m| m.file_type().is_symlink()) {
        resolved(dir)
    } else {
        dir.to_path_buf()
    };
    let name = dir
        .file_name()
        .ok_or_else(|| fail(format!("report folder {} has no name", dir.display())))?
        .to_string_lossy()
        .into_owned();
    let parent = dir
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
        .to_path_buf();
    fs::create_dir_all(&parent).map_err(|e| fail(format!("cannot create {}: {e}", parent.display())))?;
    clean_stale(&parent, &name);
    let tmp = parent.join(format!(".{name}.tmp-{}", std::process::id()));
    let _ = fs::remove_dir_all(&tmp);
    let result = (|| -> std::io::Result<()> {
        fs::create_dir(&tmp)?;
        fs::write(tmp.join(KIND_MARKER), format!("{}\n", kind.name()))?;
        for (file, bytes) in files {
            let path = tmp.join(file);
            if let Some(p) = path.parent() {
                fs::create_dir_all(p)?;
            }
            // A full disk names the file it stopped at.
            let named = |e: std::io::Error| std::io::Error::new(e.kind(), format!("{file}: {e}"));
            let mut f = fs::File::create(&path).map_err(named)?;
            f.write_all(bytes).map_err(named)?;
            f.sync_all().map_err(named)?;
        }
        if fs::symlink_metadata(&dir).is_ok() {
            if exchange(&tmp, &dir).is_err() {
                // No RENAME_EXCHANGE (another OS or file system): two renames.
                let old = parent.join(format!(".{name}.old-{}", std::process::id()));
                fs::rename(&dir, &old)?;
                if let Err(e) = fs::rename(&tmp, &dir) {
                    let _ = fs::rename(&old, &dir);
                    return Err(e);
                }
                let _ = fs::remove_dir_all(&old);
            } else {
                // `tmp` now holds the previous set.
                let _ = fs::remove_dir_all(&tmp);
            }
        } else {
            fs::rename(&tmp, &dir)?;
        }
        Ok(())
    })();
    if let Err(e) = result {
        let _ = fs::remove_dir_all(&tmp);
        return Err(fail(format!("cannot write report folder {}: {e}", dir.display())));
    }
    Ok(files.iter().map(|(f, _)| dir.join(f)).collect())
}

/// A number as docs/eval-format.md writes it: NaN and infinities as strings, never dropped
/// (eval's rows, `--raw`, chain.json).
pub fn json_number(x: f64) -> serde_json::Value {
    if x.is_nan() {
        serde_json::json!("NaN")
    } else if x == f64::INFINITY {
        serde_json::json!("inf")
    } else if x == f64::NEG_INFINITY {
        serde_json::json!("-inf")
    } else {
        serde_json::json!(x)
    }
}

/// Serialises rows as JSONL (one compact JSON value per line): eval's output, the report's
/// replayable files, `--raw`.
pub fn to_jsonl(rows: &[serde_json::Value]) -> Vec<u8> {
    let mut out = Vec::new();
    for r in rows {
        out.extend(serde_json::to_vec(r).expect("JSON values serialise"));
        out.push(b'\n');
    }
    out
}

/// A fresh folder under the system's temporary directory for a tool's input and output (glslang
/// for an HLSL kernel, src/kernel/hlsl.rs), removed with everything in it when dropped.
pub struct Scratch {
    pub path: PathBuf,
}

impl Scratch {
    pub fn new(prefix: &str) -> std::io::Result<Scratch> {
        static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.subsec_nanos());
        let path = std::env::temp_dir().join(format!("{prefix}-{}-{n}-{nanos}", std::process::id()));
        fs::create_dir(&path)?;
        Ok(Scratch { path })
    }

    /// Writes `name` in the folder; its path.
    pub fn write(&self, name: &str, bytes: &[u8]) -> std::io::Result<PathBuf> {
        let p = self.path.join(name);
        fs::write(&p, bytes)?;
        Ok(p)
    }

    /// Makes `name` a file of `len` bytes that holds none (sparse: a size check's input).
    pub fn sized(&self, name: &str, len: u64) -> std::io::Result<PathBuf> {
        let p = self.path.join(name);
        fs::File::create(&p)?.set_len(len)?;
        Ok(p)
    }

    /// Makes `name` an empty folder in the folder; its path.
    pub fn folder(&self, name: &str) -> std::io::Result<PathBuf> {
        let p = self.path.join(name);
        fs::create_dir(&p)?;
        Ok(p)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = fs::remove_dir_all(&self.path);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_replaces_whole_and_drops_stale_files() {
        let t = tempfile::tempdir().unwrap();
        let dir = t.path().join("case");
        let files = vec![
            ("summary.json".to_string(), b"{}".to_vec()),
            ("old.jsonl".to_string(), b"x".to_vec()),
        ];
        write_set(&dir, SetKind::Sweep, &files).unwrap();
        assert!(dir.join("old.jsonl").is_file());
        let files = vec![
            ("summary.json".to_string(), b"{\"new\":1}".to_vec()),
            ("maps/a.svg".to_string(), b"<svg/>".to_vec()),
        ];
        write_set(&dir, SetKind::Sweep, &files).unwrap();
        assert!(!dir.join("old.jsonl").exists(), "stale file kept");
        assert!(dir.join("maps/a.svg").is_file());
        assert_eq!(fs::read(dir.join("summary.json")).unwrap(), b"{\"new\":1}");
        let left: Vec<_> = fs::read_dir(t.path())
            .unwrap()
            .flatten()
            .map(|e| e.file_name())
            .collect();
        assert_eq!(left, vec![std::ffi::OsString::from("case")], "temporaries left");
    }

    #[test]
    fn an_error_partway_leaves_the_old_set_and_no_temporary() {
        let t = tempfile::tempdir().unwrap();
        let dir = t.path().join("case");
        write_set(&dir, SetKind::Sweep, &[("summary.json".into(), b"old".to_vec())]).unwrap();
        // `a` as a file, then `a/b` needs it as a folder: the second write fails.
        let files = vec![
            ("summary.json".to_string(), b"new".to_vec()),
            ("a".to_string(), vec![]),
            ("a/b".to_string(), vec![]),
        ];
        assert!(write_set(&dir, SetKind::Sweep, &files).is_err());
        assert_eq!(fs::read(dir.join("summary.json")).unwrap(), b"old");
        assert_eq!(fs::read_dir(t.path()).unwrap().count(), 1, "a temporary was left");
        // A staged output that is never committed leaves nothing either.
        let out = t.path().join("raw.jsonl");
        drop(stage_output(&out, &mut |w| w.write_all(b"x")).unwrap());
        assert_eq!(fs::read_dir(t.path()).unwrap().count(), 1);
    }

    #[test]
    fn stale_temporaries_of_dead_runs_are_removed() {
        let t = tempfile::tempdir().unwrap();
        // No process has pid 4294967; a live one (this) is kept.
        let dead = t.path().join(".case.tmp-4294967");
        let live = t.path().join(format!(".case.tmp-{}x", std::process::id()));
        fs::create_dir(&dead).unwrap();
        fs::create_dir(&live).unwrap();
        write_set(
            &t.path().join("case"),
            SetKind::Sweep,
            &[("summary.json".into(), vec![])],
        )
        .unwrap();
        assert!(!dead.exists() && live.exists());
    }

    #[test]
    fn a_folder_that_is_no_report_is_not_replaced() {
        let t = tempfile::tempdir().unwrap();
        fs::write(t.path().join("precious.txt"), "keep").unwrap();
        let e = write_set(t.path(), SetKind::Sweep, &[("summary.json".into(), vec![])]).unwrap_err();
        assert!(e.to_string().contains("not a linelight report folder"), "{e}");
        assert_eq!(fs::read_to_string(t.path().join("precious.txt")).unwrap(), "keep");
    }

    #[test]
    fn outputs_that_are_inputs_or_in_a_set_are_refused() {
        let t = tempfile::tempdir().unwrap();
        let input = t.path().join("in.jsonl");
        fs::write(&input, "x").unwrap();
        let check = |out: &Path, sets: &[&Path]| {
            let mut plan = OutputPlan::new();
            plan.input("--input", &input);
            for s in sets {
                plan.set("--out", s, SetKind::Sweep);
            }
            plan.file("--output", out).check()
        };
        let spelled = t.path().join("sub/../in.jsonl");
        let e = check(&spelled, &[]).unwrap_err();
        assert!(e.to_string().contains("same file as --input"), "{e}");
        let link = t.path().join("link");
        std::os::unix::fs::symlink(&input, &link).unwrap();
        assert!(check(&link, &[]).is_err());
        let set = t.path().join("reports/case");
        let e = check(&set.join("report.md"), &[&set]).unwrap_err();
        assert!(e.to_string().contains("inside the report folder"), "{e}");
        assert!(check(&t.path().join("new/raw.jsonl"), &[&set]).is_ok());
    }

    #[test]
    fn outputs_are_distinct_and_never_nest_in_a_set() {
        let t = tempfile::tempdir().unwrap();
        let d = t.path();
        let plan = |build: &dyn Fn(&mut OutputPlan)| {
            let mut p = OutputPlan::new();
            build(&mut p);
            p.check().map_err(|e| e.to_string())
        };
        // Two outputs on one file (spelled apart), or a file inside another output's set.
        let e = plan(&|p| {
            p.file("--raw", &d.join("a.xml")).file("--junit", &d.join("x/../a.xml"));
        })
        .unwrap_err();
        assert!(e.contains("--junit") && e.contains("same path"), "{e}");
        let e = plan(&|p| {
            p.set("--save-baseline", &d.join("base"), SetKind::Baseline)
                .file("--junit", &d.join("base/junit.xml"));
        })
        .unwrap_err();
        assert!(e.contains("inside the baseline folder"), "{e}");
        // A set inside another set, either way round.
        let e = plan(&|p| {
            p.set("--out", &d.join("r/case"), SetKind::Sweep).set(
                "--save-baseline",
                &d.join("r/case/base"),
                SetKind::Baseline,
            );
        })
        .unwrap_err();
        assert!(
            e.contains("--save-baseline") && e.contains("inside the report folder"),
            "{e}"
        );
        let e = plan(&|p| {
            p.set("--save-baseline", &d.join("r"), SetKind::Baseline)
                .set("--out", &d.join("r/case"), SetKind::Sweep);
        })
        .unwrap_err();
        assert!(e.contains("--out") && e.contains("inside the baseline folder"), "{e}");
        // A set that holds an input would delete it.
        let case = d.join("cases/case.toml");
        fs::create_dir_all(d.join("cases")).unwrap();
        fs::write(&case, "x").unwrap();
        let e = plan(&|p| {
            p.input("the case file", &case)
                .set("--out", &d.join("cases"), SetKind::Chain);
        })
        .unwrap_err();
        assert!(e.contains("not a linelight report folder"), "{e}");
        fs::write(d.join("cases").join(KIND_MARKER), "chain\n").unwrap();
        let e = plan(&|p| {
            p.input("the case file", &case)
                .set("--out", &d.join("cases"), SetKind::Chain);
        })
        .unwrap_err();
        assert!(e.contains("holds the case file"), "{e}");
    }

    #[test]
    fn a_folder_holds_one_kind_of_set_and_outputs_stay_out_of_sets_on_disk() {
        let t = tempfile::tempdir().unwrap();
        let dir = t.path().join("x-scan");
        write_set(&dir, SetKind::Sweep, &[("summary.json".into(), b"{}".to_vec())]).unwrap();
        assert_eq!(set_kind(&dir), Some(SetKind::Sweep));
        let e = write_set(&dir, SetKind::Scan, &[("scan.md".into(), vec![])]).unwrap_err();
        assert!(
            e.to_string()
                .contains("is a report folder (written by `linelight sweep`)"),
            "{e}"
        );
        // A file output inside any set on disk would be deleted by that set's next run.
        let mut p = OutputPlan::new();
        let e = p.file("--junit", &dir.join("j.xml")).check().unwrap_err();
        assert!(
            e.to_string()
                .contains("a report folder that `linelight sweep` replaces whole"),
            "{e}"
        );
        // Folders written before the marker keep their kind.
        let legacy = t.path().join("legacy");
        fs::create_dir(&legacy).unwrap();
        fs::write(legacy.join("summary.json"), "[]").unwrap();
        fs::write(legacy.join("scan.md"), "").unwrap();
        assert_eq!(set_kind(&legacy), Some(SetKind::Scan));
        // Above an output, only a whole legacy set counts: a lone summary.json is not one.
        let project = t.path().join("project");
        fs::create_dir(&project).unwrap();
        fs::write(project.join("summary.json"), "{}").unwrap();
        assert!(OutputPlan::new()
            .file("--junit", &project.join("j.xml"))
            .check()
            .is_ok());
        fs::write(project.join("report.md"), "").unwrap();
        assert!(OutputPlan::new()
            .file("--junit", &project.join("j.xml"))
            .check()
            .is_err());
        // A baseline folder with a file the save does not write is not replaced.
        let base = t.path().join("base");
        fs::create_dir(&base).unwrap();
        fs::write(base.join("baseline.json"), "{}").unwrap();
        fs::write(base.join("README.md"), "ours").unwrap();
        let e = check_set("--save-baseline", &base, SetKind::Baseline).unwrap_err();
        assert!(e.to_string().contains("holds `README.md`"), "{e}");
    }

    #[test]
    fn only_bounded_regular_files_are_read() {
        let t = tempfile::tempdir().unwrap();
        let fifo = t.path().join("fifo");
        let c = CString::new(fifo.as_os_str().as_bytes()).unwrap();
        // SAFETY: a valid C string; mkfifo only creates a node.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o644) }, 0);
        let e = read_regular(&fifo, "errors file", 100).unwrap_err();
        assert!(e.to_string().contains("not a regular file"), "{e}");
        let big = t.path().join("big");
        fs::write(&big, vec![b'x'; 101]).unwrap();
        let e = read_regular(&big, "errors file", 100).unwrap_err();
        assert!(e.to_string().contains("101 bytes, more than the 100"), "{e}");
        assert_eq!(read_regular(&big, "errors file", 101).unwrap().len(), 101);
    }

    #[test]
    fn symlinks_stay_links_and_keep_their_target_written() {
        let t = tempfile::tempdir().unwrap();
        let target = t.path().join("target.txt");
        fs::write(&target, "old").unwrap();
        let link = t.path().join("link.txt");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        write_bytes(&link, b"new").unwrap();
        assert!(fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
        assert_eq!(fs::read_to_string(&target).unwrap(), "new");
    }
}
