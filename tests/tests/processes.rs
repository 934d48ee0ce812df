//! `learner serve` and `actor` as real OS processes over loopback TCP:
//! the learner picks a free port, the actor connects, the run finishes,
//! both exit 0 and the learner leaves its outputs.

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The workspace's binaries, built by the same cargo and profile as this
/// test (a no-op when `cargo test --workspace` has built them already).
fn binaries() -> (PathBuf, PathBuf) {
    let exe = std::env::current_exe().unwrap();
    // target/<profile>/deps/processes-<hash>
    let profile_dir = exe.parent().unwrap().parent().unwrap().to_path_buf();
    let target_dir = profile_dir.parent().unwrap();
    let profile = profile_dir.file_name().unwrap().to_str().unwrap();
    let mut build = Command::new(env!("CARGO"));
    build
        .args([
            "build",
            "--quiet",
            "-p",
            "buridan-cli",
            "-p",
            "buridan-actor",
            "--bins",
        ])
        .arg("--target-dir")
        .arg(target_dir)
        .current_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/.."));
    if profile == "release" {
        build.arg("--release");
    }
    let status = build.status().expect("cargo runs");
    assert!(status.success(), "building the binaries failed");
    let ext = std::env::consts::EXE_SUFFIX;
    (
        profile_dir.join(format!("learner{ext}")),
        profile_dir.join(format!("actor{ext}")),
    )
}

struct KillOnDrop(std::process::Child);

impl Drop for KillOnDrop {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

#[test]
fn learner_and_actor_processes_finish_a_run_over_loopback() {
    let (learner_bin, actor_bin) = binaries();
    let out = tempfile::tempdir().unwrap();
    let mut learner = KillOnDrop(
        Command::new(&learner_bin)
            .args([
                "serve",
                "--listen",
                "127.0.0.1:0",
                "--map",
                "rm-1.1",
                "--agents",
                "2",
                "--starts",
                "fixed",
                "--algo",
                "ppo",
                "--mode",
                "ctde",
                "--steps",
                "12000",
                "--set",
                "envs_per_actor=4",
                "--set",
                "ppo.clip=0.2",
                "--out",
            ])
            .arg(out.path())
            .env("RUST_LOG", "warn")
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("learner starts"),
    );
    // The learner prints its bound address on stderr.
    let stderr = learner.0.stderr.take().unwrap();
    let (addr_tx, addr_rx) = std::sync::mpsc::channel();
    let reader = std::thread::spawn(move || {
        let mut log = String::new();
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            if let Some(rest) = line.strip_prefix("learner listening on ") {
                let addr = rest.split(';').next().unwrap().to_string();
                let _ = addr_tx.send(addr);
            }
            log.push_str(&line);
            log.push('\n');
        }
        log
    });
    let addr = addr_rx
        .recv_timeout(Duration::from_secs(60))
        .expect("the learner announces its address");
    let actor = Command::new(&actor_bin)
        .args([
            "--connect",
            &format!("http://{addr}"),
            "--give-up-after",
            "60",
        ])
        .env("RUST_LOG", "warn")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("actor starts");
    let started = Instant::now();
    let actor_out = actor.wait_with_output().unwrap();
    let actor_log = String::from_utf8_lossy(&actor_out.stderr);
    assert!(actor_out.status.success(), "actor failed:\n{actor_log}");
    assert!(actor_log.contains("run finished"), "{actor_log}");
    let status = loop {
        if let Some(s) = learner.0.try_wait().unwrap() {
            break s;
        }
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "the learner does not exit"
        );
        std::thread::sleep(Duration::from_millis(100));
    };
    let learner_log = reader.join().unwrap();
    assert!(status.success(), "learner failed:\n{learner_log}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.path().join("summary.json")).unwrap())
            .unwrap();
    // The run ends at its step budget, or earlier once the greedy check
    // (the recipe's `[stop.greedy]`) has seen the deployed policy solve its
    // held-out episodes; imitation on rm-1.1 usually gets it there at once.
    match summary["stop_reason"].as_str() {
        Some("greedy") => {
            let check = &summary["greedy_check"];
            let solved = check["solved"].as_u64().unwrap();
            let episodes = check["episodes"].as_u64().unwrap();
            assert!(episodes > 0 && solved * 100 >= episodes * 99, "{summary}");
        }
        _ => assert!(
            summary["env_steps"].as_u64().unwrap() >= 12_000,
            "{summary}"
        ),
    }
    assert!(out
        .path()
        .join("checkpoints/final/model.safetensors")
        .is_file());
    assert!(out.path().join("learning_curve.png").is_file());
}
