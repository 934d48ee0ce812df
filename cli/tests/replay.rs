//! `learner replay` and `learner eval --replays`: GIFs of the episodes the
//! evaluation plays, and clear errors for bad requests.

mod common;

use std::path::PathBuf;

use buridan_cli::eval;
use buridan_cli::replay::{self, ReplayArgs};
use buridan_env::Starts;

fn replay_args(out: PathBuf) -> ReplayArgs {
    ReplayArgs {
        map: "rm-2.1".into(),
        agents: 8,
        seed: 42,
        episode: 3,
        episodes: 100,
        controller: "random".into(),
        starts: Starts::Random,
        t_max: 30,
        time_limit: 10.0,
        memory_limit: 256,
        sample: false,
        cell_px: 0,
        delay: 15,
        out,
    }
}

#[test]
fn a_replay_is_the_evaluated_episode() {
    let dir = tempfile::tempdir().unwrap();
    let args = replay_args(dir.path().join("ep3.gif"));
    let trace = replay::run(&args).unwrap();
    let bytes = std::fs::read(&args.out).unwrap();
    assert_eq!(&bytes[..6], b"GIF89a");
    let (out, replays) = (dir.path().join("eval"), dir.path().join("replays"));
    let eval_args = common::eval_args(&[
        "--map",
        "rm-2.1",
        "--agents",
        "8",
        "--episodes",
        "4",
        "--controller",
        "random",
        "--t-max",
        "30",
        "--time-limit",
        "10",
        "--memory-limit",
        "256",
        "--json",
        "--out",
        &out.display().to_string(),
        "--replays",
        &replays.display().to_string(),
        "--replays-max",
        "2",
    ]);
    eval::run(&eval_args).unwrap();
    let csv = std::fs::read_to_string(dir.path().join("eval/episodes.csv")).unwrap();
    let row = csv.lines().nth(4).unwrap();
    let fields: Vec<&str> = row.split(',').collect();
    assert_eq!(fields[0], "3");
    assert_eq!(fields[2], trace.record.timesteps.to_string());
    // Random crowds of 8 fail within 30 steps: the first two failures are drawn.
    let gifs = std::fs::read_dir(dir.path().join("replays"))
        .unwrap()
        .count();
    assert_eq!(gifs, 2);
}

#[test]
fn bad_requests_are_reported() {
    let dir = tempfile::tempdir().unwrap();
    let mut args = replay_args(dir.path().join("x.gif"));
    args.episode = 100;
    let err = format!("{:#}", replay::run(&args).unwrap_err());
    assert!(err.contains("episode 100 is out of range"), "{err}");
    let mut args = replay_args(dir.path().join("x.gif"));
    args.controller = "teleport".into();
    let err = format!("{:#}", replay::run(&args).unwrap_err());
    assert!(err.contains("unknown controller 'teleport'"), "{err}");
    let args = replay_args(dir.path().join("x.png"));
    let err = format!("{:#}", replay::run(&args).unwrap_err());
    assert!(err.contains("name it *.gif"), "{err}");
}
