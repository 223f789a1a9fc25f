//! What the command-line tests share: running the binary, its stderr, writing an input file.
#![allow(dead_code)] // each test binary uses its own share of these

pub mod independent;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs `linelight` with `args` from the test's working directory.
pub fn linelight(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_linelight"))
        .args(args)
        .output()
        .expect("linelight runs")
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Writes `text` to `dir/name` and returns the path.
pub fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}
