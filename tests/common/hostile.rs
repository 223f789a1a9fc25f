//! What a hostile-input test asserts besides the exit code: that nothing outside the intended
//! files changed (a snapshot of a folder before and after) and that a refusal is exit 2 with
//! a short message naming what it must. (The same helpers as tests/robustness.rs's own.)

use std::collections::BTreeMap;
use std::os::unix::fs::{FileTypeExt, MetadataExt};
use std::path::{Path, PathBuf};
use std::process::Output;

/// Every entry under `dir`: its kind and, for files and links, what it holds.
pub fn snapshot(dir: &Path) -> BTreeMap<PathBuf, String> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            let m = std::fs::symlink_metadata(&p).unwrap();
            let t = m.file_type();
            let what = if t.is_symlink() {
                format!("link -> {}", std::fs::read_link(&p).unwrap().display())
            } else if t.is_dir() {
                stack.push(p.clone());
                "dir".to_string()
            } else if t.is_fifo() {
                "fifo".to_string()
            } else if t.is_char_device() {
                format!("char device {}", m.rdev())
            } else {
                format!("file {:?}", std::fs::read(&p).unwrap())
            };
            out.insert(p.strip_prefix(dir).unwrap().to_path_buf(), what);
        }
    }
    out
}

/// Asserts that only `changed` (relative paths, and what is under them) differ.
pub fn only_changed(before: &BTreeMap<PathBuf, String>, after: &BTreeMap<PathBuf, String>, changed: &[&str]) {
    let keys: std::collections::BTreeSet<_> = before.keys().chain(after.keys()).collect();
    for k in keys {
        if changed.iter().any(|c| k.starts_with(c)) {
            continue;
        }
        assert_eq!(before.get(k), after.get(k), "{} changed", k.display());
    }
}

/// Asserts exit 2 with a message (under 4000 bytes) holding each of `what`.
pub fn refused(o: &Output, what: &[&str]) {
    let e = super::stderr(o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    for w in what {
        assert!(e.contains(w), "`{w}` not in: {e}");
    }
    assert!(e.len() < 4000, "message too long: {} bytes", e.len());
}
