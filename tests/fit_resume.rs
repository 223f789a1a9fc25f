//! `linelight fit --aniso` is resumable: a run killed after a checkpoint and resumed writes
//! the same table bytes as a run never interrupted, on any thread count, and a checkpoint of
//! another size or another file is refused before any work.

use std::path::Path;
use std::process::{Command, Output};

const SIZE: &str = "2,2,3,2";

fn fit(out: &Path, threads: &str, extra: &[&str]) -> Command {
    fit_size(out, SIZE, threads, extra)
}

fn fit_size(out: &Path, size: &str, threads: &str, extra: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_linelight"));
    c.args(["fit", "--aniso", "--aniso-size", size, "--out", out.to_str().unwrap()])
        .args(extra)
        .env("RAYON_NUM_THREADS", threads);
    c
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn a_killed_fit_resumes_to_the_same_bytes() {
    let t = tempfile::tempdir().unwrap();
    // Uninterrupted, two threads.
    let whole = t.path().join("whole.csv");
    let o = fit(&whole, "2", &[]).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        !whole.with_extension("checkpoint.csv").exists(),
        "a finished run removes its checkpoint"
    );
    let expected = std::fs::read(&whole).unwrap();
    // 2 θ × 2 φ × 2 r = 8 chains, θ = 0 only at φ = 0: 6 chains of 3 entries.
    let text = String::from_utf8(expected.clone()).unwrap();
    assert_eq!(text.lines().filter(|l| l.ends_with(",fit")).count(), 18);
    assert_eq!(text.lines().filter(|l| l.ends_with(",theta0")).count(), 6);

    // One thread, a checkpoint after every chain, killed once the first checkpoint is there.
    let out = t.path().join("resumed.csv");
    let checkpoint = out.with_extension("checkpoint.csv");
    let mut child = fit(&out, "1", &["--checkpoint-every", "1"]).spawn().unwrap();
    let start = std::time::Instant::now();
    while !checkpoint.exists() {
        assert!(start.elapsed().as_secs() < 600, "no checkpoint after 10 minutes");
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run ended before its first checkpoint"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(!out.exists(), "killed before the table was written");
    let saved = std::fs::read_to_string(&checkpoint).unwrap();
    let rows = saved.lines().filter(|l| l.ends_with(",fit")).count();
    assert!(
        rows >= 3 && rows % 3 == 0 && rows < 18,
        "whole chains only: {rows} rows"
    );

    // A checkpoint of another size is refused (exit 2) and left alone.
    let other = fit_size(&out, "2,2,2,2", "1", &[]).output().unwrap();
    assert_eq!(other.status.code(), Some(2), "{}", stderr(&other));
    assert!(
        stderr(&other).contains("checkpoint of a [2, 2, 3, 2] table"),
        "{}",
        stderr(&other)
    );
    assert_eq!(std::fs::read_to_string(&checkpoint).unwrap(), saved);

    // Resumed: the same bytes.
    let o = fit(&out, "2", &[]).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("resuming from"), "{}", stderr(&o));
    assert_eq!(std::fs::read(&out).unwrap(), expected, "resumed table differs");
    assert!(!checkpoint.exists());
    let record: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.with_extension("run.json")).unwrap()).unwrap();
    assert_eq!(record["resumed"], true);
}

#[test]
fn a_file_that_is_no_checkpoint_is_refused() {
    let t = tempfile::tempdir().unwrap();
    let out = t.path().join("t.csv");
    let checkpoint = t.path().join("c.csv");
    std::fs::write(&checkpoint, "i_theta,i_phi\n").unwrap();
    let o = fit(&out, "1", &["--checkpoint", checkpoint.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("not a checkpoint"), "{}", stderr(&o));
    assert!(!out.exists());
    // A chain cut short is refused too.
    std::fs::write(
        &checkpoint,
        "# linelight fit --aniso checkpoint v1\n# size 2,2,3,2\n# seconds 1e0\n\
         1,1,0,0,1e0,1e0,1e0,1e0,1e0,0e0,0e0,0e0,1e0,0e0,0e0,0e0,1e0,1e0,1e-1,1e-1,1e-1,fit\n",
    )
    .unwrap();
    let o = fit(&out, "1", &["--checkpoint", checkpoint.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("chain [1, 1, 0] has 1 of 3 entries"),
        "{}",
        stderr(&o)
    );
}
