//! A SIGTERM stops `learner study` gracefully: the training cell under way
//! checkpoints its current update, the study says how to continue, and the
//! same command resumes the cell from that checkpoint.
#![cfg(unix)]

mod common;

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Rows of `metrics.csv` in `run` (one per update), 0 while it is absent.
fn updates_logged(run: &Path) -> usize {
    std::fs::read_to_string(run.join("metrics.csv"))
        .map(|s| s.lines().count().saturating_sub(1))
        .unwrap_or(0)
}

/// A running `learner study` and the lines of its stderr so far.
struct Study {
    child: Child,
    lines: Arc<Mutex<Vec<String>>>,
    reader: Option<std::thread::JoinHandle<()>>,
}

impl Study {
    fn start(experiment: &Path, out: &Path) -> Self {
        let mut child = Command::new(env!("CARGO_BIN_EXE_learner"))
            .arg("study")
            .arg(experiment)
            .arg("--out")
            .arg(out)
            .arg("--quiet")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let lines = Arc::new(Mutex::new(Vec::new()));
        let stderr = child.stderr.take().unwrap();
        let sink = lines.clone();
        let reader = std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                sink.lock().unwrap().push(line);
            }
        });
        Self {
            child,
            lines,
            reader: Some(reader),
        }
    }

    /// Waits (at most 120 s) until `ready` holds; the study must not end first.
    fn wait_for(&mut self, what: &str, ready: impl Fn(&[String]) -> bool) {
        let start = Instant::now();
        while !ready(&self.lines.lock().unwrap()) {
            assert!(
                start.elapsed() < Duration::from_secs(120),
                "not within 120 s: {what}"
            );
            if let Some(status) = self.child.try_wait().unwrap() {
                panic!(
                    "learner study ended ({status}) before {what}: {:?}",
                    self.lines.lock().unwrap()
                );
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// Sends SIGTERM and waits (at most 60 s) for the exit; returns the
    /// exit code and the whole stderr.
    fn terminate(mut self) -> (Option<i32>, String) {
        let killed = Command::new("kill")
            .args(["-TERM", &self.child.id().to_string()])
            .status()
            .unwrap();
        assert!(killed.success());
        let waited = Instant::now();
        let status = loop {
            if let Some(status) = self.child.try_wait().unwrap() {
                break status;
            }
            if waited.elapsed() > Duration::from_secs(60) {
                self.child.kill().unwrap();
                panic!("learner study still running 60 s after SIGTERM");
            }
            std::thread::sleep(Duration::from_millis(50));
        };
        self.reader.take().unwrap().join().unwrap();
        let text = self.lines.lock().unwrap().join("\n");
        (status.code(), text)
    }
}

#[test]
fn sigterm_checkpoints_the_running_cell_and_the_same_command_resumes_it() {
    let dir = tempfile::tempdir().unwrap();
    common::tiny_config(dir.path());
    let experiment = dir.path().join("experiment.toml");
    // A budget no test reaches and no periodic checkpoint: a checkpoint
    // afterwards was written on the way out.
    std::fs::write(
        &experiment,
        r#"
[experiment]
name = "endless"
layouts = ["rm-1.1"]
seeds = 1
steps = 100_000_000
[experiment.eval]
episodes = 5
[[method]]
name = "ppo"
config = "tiny.toml"
set = ["checkpoint_every=100000"]
"#,
    )
    .unwrap();
    let out = dir.path().join("out");
    let run = out.join("runs/rm-1.1/ppo/seed-0");

    let mut study = Study::start(&experiment, &out);
    study.wait_for("two updates", |_| updates_logged(&run) >= 2);
    let (code, stderr) = study.terminate();
    assert!(
        code.is_some_and(|c| c != 0),
        "a stopped study exits with an error status of its own, got {code:?}: {stderr}"
    );
    assert!(
        stderr.contains("stopped by a signal with 1 of 1 jobs left")
            && stderr.contains("rerun the same command"),
        "{stderr}"
    );
    assert!(!run.join("summary.json").exists(), "{stderr}");
    let checkpoints: Vec<_> = std::fs::read_dir(run.join("checkpoints"))
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    assert!(
        checkpoints.iter().any(|c| c.starts_with("update-")),
        "{checkpoints:?}"
    );
    // The report covers what is done (nothing yet) instead of failing.
    assert!(out.join("table.md").is_file());
    let updates_before = updates_logged(&run);

    // The same command continues the cell from its checkpoint.
    let mut again = Study::start(&experiment, &out);
    again.wait_for("the resumed cell", |lines| {
        lines
            .iter()
            .any(|l| l.contains("train rm-1.1 ppo seed 0 (resumed)"))
    });
    again.wait_for("an update after the resume", |_| {
        updates_logged(&run) > updates_before
    });
    let (code, stderr) = again.terminate();
    assert!(code.is_some_and(|c| c != 0), "{stderr}");
    assert!(stderr.contains("1 of 1 jobs left"), "{stderr}");
}
