//! All file writing, in one place, so no output is ever destructive:
//!
//! - a regular file (or a path that does not exist yet) is written to a temporary file in
//!   its own directory and renamed over it, so a failed run leaves the old file whole;
//! - a symlink is followed, and the file it points to is replaced the same way (the link
//!   stays a link);
//! - anything else (a FIFO, a character device such as `/dev/null` or `/dev/stdout`, a
//!   socket) is written through, never replaced;
//! - an output that is one of the run's inputs, or lies inside a report folder, is refused
//!   before any work ([`check_output`]), as is one the user cannot write;
//! - a report set is written into a sibling temporary directory and swapped in whole
//!   ([`write_set`]): a report folder only ever holds one run's files;
//! - temporaries of killed runs (sets and single files) are removed by the next run that
//!   writes the same path.

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

/// Checks, before any work, that `path` (given as `flag`) may be written: it is not one
/// of `inputs` (flag and path), not inside one of `sets` (report folders this run
/// writes), not a directory, and writable (or creatable) by this user.
pub fn check_output(flag: &str, path: &Path, inputs: &[(&str, &Path)], sets: &[&Path]) -> Result<(), OutputError> {
    let shown = path.display();
    let id = identity(path);
    for (input_flag, input) in inputs {
        let same = match (id, identity(input)) {
            (Some(a), Some(b)) => a == b,
            _ => resolved(path) == resolved(input),
        };
        if same {
            return Err(fail(format!(
                "{flag} {shown} is the same file as {input_flag} {}: refusing to overwrite an input",
                input.display()
            )));
        }
    }
    let target = resolved(path);
    for set in sets {
        let set = resolved(set);
        if target.starts_with(&set) {
            return Err(fail(format!(
                "{flag} {shown} lies inside the report folder {} this run writes: choose a path outside it",
                set.display()
            )));
        }
    }
    match fs::metadata(path) {
        Ok(m) if m.is_dir() => Err(fail(format!("{flag} {shown} is a directory, not a file"))),
        Ok(_) if !writable(path) => Err(fail(format!("{flag} {shown}: permission denied (not writable)"))),
        Ok(_) => Ok(()),
        Err(_) => check_creatable(flag, &target),
    }
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

/// The file in a report folder that marks it as one: a folder without it is not replaced.
pub const SET_MARKER: &str = "summary.json";

/// Checks, before any work, that the report folder `dir` can be written as a set: it is a
/// report folder of an earlier run (or empty, or absent) and its parent is writable.
pub fn check_set(dir: &Path) -> Result<(), OutputError> {
    match fs::metadata(dir) {
        Ok(m) if !m.is_dir() => Err(fail(format!(
            "report folder {} exists and is not a directory",
            dir.display()
        ))),
        Ok(_) => {
            let empty = fs::read_dir(dir).map(|mut d| d.next().is_none()).unwrap_or(false);
            if !empty && !dir.join(SET_MARKER).is_file() {
                return Err(fail(format!(
                    "{} exists and is not a linelight report folder (no {SET_MARKER}): \
                     it would be replaced whole; move it or choose another --out",
                    dir.display()
                )));
            }
            let parent = resolved(dir);
            let parent = parent.parent().unwrap_or(Path::new("/"));
            if writable(parent) {
                Ok(())
            } else {
                Err(fail(format!(
                    "report folder {}: directory {} is not writable",
                    dir.display(),
                    parent.display()
                )))
            }
        }
        Err(_) => check_creatable("--out", &resolved(dir).join(SET_MARKER)),
    }
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

/// Writes a report set into `dir` as one: every file (names relative to `dir`, `/` for
/// sub-folders) goes into a sibling temporary folder, which then replaces `dir` whole.
/// On any error nothing in `dir` has changed. Returns the paths written.
pub fn write_set(dir: &Path, files: &[(String, Vec<u8>)]) -> Result<Vec<PathBuf>, OutputError> {
    check_set(dir)?;
    let mut names = BTreeSet::new();
    for (name, _) in files {
        let relative = Path::new(name);
        if relative.components().any(|c| !matches!(c, Component::Normal(_))) {
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
        write_set(&dir, &files).unwrap();
        assert!(dir.join("old.jsonl").is_file());
        let files = vec![
            ("summary.json".to_string(), b"{\"new\":1}".to_vec()),
            ("maps/a.svg".to_string(), b"<svg/>".to_vec()),
        ];
        write_set(&dir, &files).unwrap();
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
        write_set(&dir, &[("summary.json".into(), b"old".to_vec())]).unwrap();
        // `a` as a file, then `a/b` needs it as a folder: the second write fails.
        let files = vec![
            ("summary.json".to_string(), b"new".to_vec()),
            ("a".to_string(), vec![]),
            ("a/b".to_string(), vec![]),
        ];
        assert!(write_set(&dir, &files).is_err());
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
        write_set(&t.path().join("case"), &[("summary.json".into(), vec![])]).unwrap();
        assert!(!dead.exists() && live.exists());
    }

    #[test]
    fn a_folder_that_is_no_report_is_not_replaced() {
        let t = tempfile::tempdir().unwrap();
        fs::write(t.path().join("precious.txt"), "keep").unwrap();
        let e = write_set(t.path(), &[("summary.json".into(), vec![])]).unwrap_err();
        assert!(e.to_string().contains("not a linelight report folder"), "{e}");
        assert_eq!(fs::read_to_string(t.path().join("precious.txt")).unwrap(), "keep");
    }

    #[test]
    fn outputs_that_are_inputs_or_in_a_set_are_refused() {
        let t = tempfile::tempdir().unwrap();
        let input = t.path().join("in.jsonl");
        fs::write(&input, "x").unwrap();
        let spelled = t.path().join("sub/../in.jsonl");
        let e = check_output("--output", &spelled, &[("--input", &input)], &[]).unwrap_err();
        assert!(e.to_string().contains("same file as --input"), "{e}");
        let link = t.path().join("link");
        std::os::unix::fs::symlink(&input, &link).unwrap();
        assert!(check_output("--output", &link, &[("--input", &input)], &[]).is_err());
        let set = t.path().join("reports/case");
        let e = check_output("--raw", &set.join("report.md"), &[], &[&set]).unwrap_err();
        assert!(e.to_string().contains("inside the report folder"), "{e}");
        assert!(check_output("--raw", &t.path().join("new/raw.jsonl"), &[], &[&set]).is_ok());
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
