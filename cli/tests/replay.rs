//! `learner replay` and `learner eval --replays`: GIFs of the episodes the
//! evaluation plays, and clear errors for bad requests.

mod common;

use std::path::PathBuf;

use buridan_cli::eval;
use buridan_cli::replay::{self, ReplayArgs};
use buridan_env::{Rules, Starts};

fn replay_args(out: PathBuf) -> ReplayArgs {
    ReplayArgs {
        map: "rm-2.1".into(),
        agents: 8,
        seed: 42,
        episode: 3,
        episodes: 100,
        controller: "random".into(),
        starts: Starts::Random,
        rules: Rules::Thesis,
        t_max: Some(30),
        time_limit: 10.0,
        memory_limit: 256,
        sample: false,
        cell_px: 0,
        delay: 15,
        exec_delay: 0.0,
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
    assert!(err.contains("name the replay *.gif"), "{err}");
}

#[test]
fn a_json_replay_is_the_trace_of_the_drawn_episode() {
    let dir = tempfile::tempdir().unwrap();
    let drawn = replay::run(&replay_args(dir.path().join("ep3.gif"))).unwrap();
    let args = replay_args(dir.path().join("traces/ep3.json"));
    let trace = replay::run(&args).unwrap();
    // The same episode (the compute time aside).
    assert_eq!(
        (&trace.snapshots, &trace.goals, trace.record.timesteps),
        (&drawn.snapshots, &drawn.goals, drawn.record.timesteps)
    );
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&args.out).unwrap()).unwrap();
    let snapshots = json["snapshots"].as_array().unwrap();
    assert_eq!(snapshots.len() as u32, trace.record.timesteps + 1);
    let last = snapshots.last().unwrap();
    let cells = last["positions"].as_array().unwrap();
    assert_eq!(cells.len(), 8);
    let final_cells = &trace.snapshots.last().unwrap().positions;
    assert_eq!(cells[0], serde_json::to_value(final_cells[0]).unwrap());
    assert_eq!(json["goals"].as_array().unwrap().len(), 8);
    assert_eq!(json["episode"], 3);
}

#[test]
fn a_replay_under_pogema_rules_is_the_episode_eval_plays_under_them() {
    let dir = tempfile::tempdir().unwrap();
    let mut args = replay_args(dir.path().join("pogema.gif"));
    (args.controller, args.rules, args.t_max, args.episode) =
        ("pibt".into(), Rules::Pogema, None, 1);
    let trace = replay::run(&args).unwrap();
    let out = dir.path().join("eval");
    let flags = [
        "--map",
        "rm-2.1",
        "--agents",
        "8",
        "--episodes",
        "2",
        "--controller",
        "pibt",
        "--rules",
        "pogema",
        "--time-limit",
        "10",
        "--memory-limit",
        "256",
        "--out",
    ];
    let mut flags: Vec<String> = flags.map(String::from).to_vec();
    flags.push(out.display().to_string());
    let summaries = eval::run(&common::eval_args(&flags)).unwrap();
    assert_eq!(summaries[0].t_max, 128, "pogema's T_max by default");
    let csv = std::fs::read_to_string(out.join("episodes.csv")).unwrap();
    let row: Vec<String> = csv
        .lines()
        .nth(2)
        .unwrap()
        .split(',')
        .map(String::from)
        .collect();
    assert_eq!(row[0], "1");
    assert_eq!(row[2], trace.record.timesteps.to_string());
    assert_eq!(trace.record.success, row[1] == "true");
    // OD-A* searches the thesis step: refused under pogema, and says so.
    args.controller = "od-astar".into();
    let err = format!("{:#}", replay::run(&args).unwrap_err());
    assert!(err.contains("cannot plan under pogema rules"), "{err}");
}

#[test]
fn an_evaluation_under_delays_records_them_and_replays_each_episode() {
    let dir = tempfile::tempdir().unwrap();
    let eval_dir = |name: &str| dir.path().join(name).display().to_string();
    let run = |delay: &str, out: &str| {
        let args = common::eval_args(&[
            "--map",
            "rm-2.1",
            "--agents",
            "8",
            "--episodes",
            "6",
            "--rules",
            "pogema",
            "--controller",
            "pibt",
            "--delay",
            delay,
            "--json",
            "--out",
            out,
        ]);
        eval::run(&args)
    };
    run("0.3", &eval_dir("lagging")).unwrap();
    run("0", &eval_dir("prompt")).unwrap();
    let summary = |name: &str| -> serde_json::Value {
        let text = std::fs::read_to_string(dir.path().join(name).join("summary.json")).unwrap();
        serde_json::from_str(&text).unwrap()
    };
    let delay = summary("lagging")["delay"].as_f64().unwrap();
    assert!((delay - 0.3).abs() < 1e-6, "{delay}");
    assert!(
        summary("prompt").get("delay").is_none(),
        "no delays, no key"
    );
    let steps = |name: &str| -> Vec<String> {
        let csv = std::fs::read_to_string(dir.path().join(name).join("episodes.csv")).unwrap();
        csv.lines()
            .skip(1)
            .map(|l| l.split(',').nth(2).unwrap().to_string())
            .collect()
    };
    assert_ne!(
        steps("lagging"),
        steps("prompt"),
        "lagging robots take longer"
    );
    // The replay of an episode under the same delays is that episode.
    let mut args = replay_args(dir.path().join("ep3.json"));
    (args.rules, args.t_max, args.controller) = (Rules::Pogema, None, "pibt".into());
    args.exec_delay = 0.3;
    let trace = replay::run(&args).unwrap();
    assert_eq!(steps("lagging")[3], trace.record.timesteps.to_string());
    // A delay that is no probability is refused, naming it.
    let err = format!("{:#}", run("1.5", &eval_dir("bad")).unwrap_err());
    assert!(
        err.contains("delay must be a probability in [0, 1)"),
        "{err}"
    );
}
