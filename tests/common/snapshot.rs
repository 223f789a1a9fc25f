//! Checking that a hostile run changed nothing it should not: a snapshot of a folder before
//! and after (FIFOs, symlinks and device nodes included), and a refusal's exit code and message.

use std::collections::BTreeMap;
use std::os::unix::fs::{FileTypeExt, MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::process::Output;

use super::stderr;

pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Every entry under `dir`: its kind, its permission bits and, for files and links, what it holds.
pub fn snapshot(dir: &Path) -> BTreeMap<PathBuf, String> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            let m = std::fs::symlink_metadata(&p).unwrap();
            let t = m.file_type();
            let mode = m.permissions().mode() & 0o7777;
            let what = if t.is_symlink() {
                format!("link -> {}", std::fs::read_link(&p).unwrap().display())
            } else if t.is_dir() {
                stack.push(p.clone());
                format!("dir {mode:o}")
            } else if t.is_fifo() {
                format!("fifo {mode:o}")
            } else if t.is_char_device() {
                format!("char device {}", m.rdev())
            } else {
                format!("file {mode:o} {:?}", std::fs::read(&p).unwrap())
            };
            out.insert(p.strip_prefix(dir).unwrap().to_path_buf(), what);
        }
    }
    out
}

/// Asserts that only the paths starting with one of `changed` (relative) differ.
pub fn only_changed(before: &BTreeMap<PathBuf, String>, after: &BTreeMap<PathBuf, String>, changed: &[&str]) {
    let keys: std::collections::BTreeSet<_> = before.keys().chain(after.keys()).collect();
    for k in keys {
        if changed.iter().any(|c| k.starts_with(c)) {
            continue;
        }
        assert_eq!(before.get(k), after.get(k), "{} changed", k.display());
    }
}

/// Asserts a refusal: exit 2, a message holding every one of `what`, and a bounded message.
pub fn refused(o: &Output, what: &[&str]) {
    assert_eq!(o.status.code(), Some(2), "{}", stderr(o));
    let e = stderr(o);
    for w in what {
        assert!(e.contains(w), "`{w}` not in: {e}");
    }
    assert!(e.len() < 4000, "message too long: {} bytes", e.len());
}
