//! Lists the built-in method kernels for `src/kernel/file.rs`: every `.wgsl` file under
//! `kernels/`, subfolders included (`kernels/engines/`), except the prelude and
//! `kernels/lib/` (shared pieces, not methods), and those pieces apart for
//! `src/kernel/pieces.rs` (what a kernel's `#include "lib/…"` names). Generated so a kernel
//! or a piece added in any folder is built in without a list to keep in step.

use std::path::{Path, PathBuf};

fn collect(dir: &Path, root: &Path, out: &mut Vec<String>) {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", dir.display()))
        .map(|e| e.expect("directory entry").path())
        .collect();
    entries.sort();
    for path in entries {
        let rel = path
            .strip_prefix(root)
            .expect("under kernels/")
            .to_string_lossy()
            .replace('\\', "/");
        if path.is_dir() {
            if rel != "lib" {
                collect(&path, root, out);
            }
        } else if rel.ends_with(".wgsl") && rel != "prelude.wgsl" {
            out.push(rel);
        }
    }
}

/// Writes `OUT_DIR/name`: a `&[(path, text)]` of `files` (relative to `kernels/`).
fn write_list(root: &Path, files: &[String], name: &str) {
    let mut text = String::from("&[\n");
    for rel in files {
        // Relative to the manifest at compile time, so a target/ copied to another checkout
        // reads that checkout's kernels, not the ones it was first built from.
        debug_assert!(root.join(rel).is_file());
        text.push_str(&format!(
            "    (\"kernels/{rel}\", include_str!(concat!(env!(\"CARGO_MANIFEST_DIR\"), \"/kernels/{rel}\"))),\n"
        ));
    }
    text.push_str("]\n");
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets OUT_DIR")).join(name);
    std::fs::write(&out, text).unwrap_or_else(|e| panic!("cannot write {}: {e}", out.display()));
}

fn main() {
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    let root = manifest.join("kernels");
    println!("cargo:rerun-if-changed=kernels");
    let mut files = Vec::new();
    collect(&root, &root, &mut files);
    write_list(&root, &files, "builtin_kernels.rs");
    let mut pieces = Vec::new();
    let lib = root.join("lib");
    if lib.is_dir() {
        collect_all(&lib, &root, &mut pieces);
    }
    write_list(&root, &pieces, "builtin_lib.rs");
}

/// Every `.wgsl` file under `dir` (the pieces of `kernels/lib/`), subfolders included.
fn collect_all(dir: &Path, root: &Path, out: &mut Vec<String>) {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", dir.display()))
        .map(|e| e.expect("directory entry").path())
        .collect();
    entries.sort();
    for path in entries {
        if path.is_dir() {
            collect_all(&path, root, out);
        } else if path.extension().is_some_and(|e| e == "wgsl") {
            let rel = path
                .strip_prefix(root)
                .expect("under kernels/")
                .to_string_lossy()
                .replace('\\', "/");
            out.push(rel);
        }
    }
}
