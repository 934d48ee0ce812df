//! A supervisor's SIGTERM stops `learner train` with a checkpoint of the
//! current update, not with whatever periodic checkpoint happens to be newest.
#![cfg(unix)]

mod common;

use std::io::Read;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Rows of `metrics.csv` under `out` (one per update), 0 while it is absent.
fn updates_logged(out: &Path) -> usize {
    std::fs::read_to_string(out.join("metrics.csv"))
        .map(|s| s.lines().count().saturating_sub(1))
        .unwrap_or(0)
}

#[test]
fn sigterm_checkpoints_the_current_update_and_says_how_to_resume() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let config = common::tiny_config(dir.path());
    // No periodic checkpoint within the test's reach: whatever checkpoint
    // exists afterwards was written on the way out.
    let mut child = Command::new(env!("CARGO_BIN_EXE_learner"))
        .args(["train", "--config"])
        .arg(&config)
        .args(["--steps", "100000000", "--seed", "5", "--quiet"])
        .args(["--set", "checkpoint_every=100000", "--out"])
        .arg(&out)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while updates_logged(&out) < 2 {
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "no two updates within 120 s"
        );
        if let Some(status) = child.try_wait().unwrap() {
            panic!("learner train ended early: {status}");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let killed = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let waited = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if waited.elapsed() > Duration::from_secs(60) {
            child.kill().unwrap();
            panic!("learner train still running 60 s after SIGTERM");
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let mut stderr = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut stderr)
        .unwrap();
    assert!(
        status.code().is_some(),
        "ended by the signal itself ({status}), not by the run: {stderr}"
    );
    assert!(!status.success(), "an interrupted run is not a success");

    // "interrupted after update N; resume with --resume OUT/checkpoints/update-N"
    let line = stderr
        .lines()
        .find(|l| l.contains("interrupted after update"))
        .unwrap_or_else(|| panic!("no interruption message in: {stderr}"));
    let checkpoint = line
        .split("--resume ")
        .nth(1)
        .unwrap_or_else(|| panic!("no resume hint in: {line}"))
        .trim();
    let updates: usize = line
        .split("interrupted after update ")
        .nth(1)
        .and_then(|s| s.split(';').next())
        .and_then(|s| s.trim().parse().ok())
        .unwrap_or_else(|| panic!("no update count in: {line}"));
    assert!(updates >= 2, "{line}");
    assert!(
        updates >= updates_logged(&out),
        "the checkpoint ({updates}) is older than the log ({} updates)",
        updates_logged(&out)
    );
    let checkpoint = Path::new(checkpoint);
    assert_eq!(
        checkpoint,
        buridan_policy::checkpoint::update_dir(&out, updates as u64)
    );
    assert!(
        buridan_policy::checkpoint::is_checkpoint(checkpoint),
        "{} is not a checkpoint",
        checkpoint.display()
    );
}
