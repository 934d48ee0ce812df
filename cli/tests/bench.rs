//! `learner bench pogema` end to end on a tiny instance set, and training
//! under pogema rules (the benchmark's learned row).

mod common;

use std::path::{Path, PathBuf};

use buridan_cli::bench::{self, BenchCommand};
use buridan_cli::train;
use buridan_env::Rules;
use clap::Parser;

/// `learner bench pogema` arguments as the command line gives them.
fn run_pogema(command: &BenchCommand) -> anyhow::Result<Vec<buridan_eval::benchmark::Row>> {
    match command {
        BenchCommand::Pogema(args) => bench::run_pogema(args),
        other => panic!("not the pogema benchmark: {other:?}"),
    }
}

fn bench_args<S: AsRef<str>>(flags: &[S]) -> BenchCommand {
    #[derive(Parser)]
    struct Bench {
        #[command(subcommand)]
        command: BenchCommand,
    }
    let argv = ["bench", "pogema"]
        .into_iter()
        .chain(flags.iter().map(AsRef::as_ref));
    Bench::try_parse_from(argv)
        .unwrap_or_else(|e| panic!("bad bench flags: {e}"))
        .command
}

/// A 3×5 room with a pillar, two instances of 1 and 2 agents (seeds 0, 1),
/// and published results of one method on them.
fn instance_set(dir: &Path) -> PathBuf {
    let set = dir.join("set");
    std::fs::create_dir_all(&set).unwrap();
    std::fs::write(
        set.join("room.map"),
        "type octile\nheight 3\nwidth 5\nmap\n.....\n..@..\n.....\n",
    )
    .unwrap();
    // Agent i is line i: (x, y) start then goal; the N-agent instance is the
    // first N lines.
    let scen = |lines: &[(usize, usize, usize, usize)]| {
        let mut text = String::from("version 1\n");
        for &(sx, sy, gx, gy) in lines {
            text += &format!("0\troom.map\t5\t3\t{sx}\t{sy}\t{gx}\t{gy}\t0\n");
        }
        text
    };
    let seed0 = [(0, 0, 4, 0), (4, 2, 0, 2)];
    let seed1 = [(0, 1, 4, 1), (4, 0, 0, 0)];
    for agents in [1, 2] {
        std::fs::write(
            set.join(format!("room-{agents}-0.scen")),
            scen(&seed0[..agents]),
        )
        .unwrap();
        std::fs::write(
            set.join(format!("room-{agents}-1.scen")),
            scen(&seed1[..agents]),
        )
        .unwrap();
    }
    let mut csv = String::from("map,agents,seed,algorithm,success,makespan,soc,isr\n");
    for agents in [1, 2] {
        for seed in [0, 1] {
            // Seed 1 with 2 agents unsolved: half the instances at 2 agents.
            let solved = !(agents == 2 && seed == 1);
            let (s, m, soc) = if solved {
                (1, 4, 4 * agents)
            } else {
                (0, 128, 256)
            };
            csv += &format!("room,{agents},{seed},Oracle,{s},{m},{soc},1.0\n");
        }
    }
    std::fs::write(set.join("room-published.csv"), csv).unwrap();
    set
}

#[test]
fn the_benchmark_runs_planners_and_a_pogema_policy_beside_published_rows() {
    let dir = tempfile::tempdir().unwrap();
    let set = instance_set(dir.path());

    // A policy trained under pogema rules, off the benchmark's map.
    let run = dir.path().join("run");
    let mut args = common::train_args(run.clone());
    args.rules = Some(Rules::Pogema);
    let summary = train::run(&args).unwrap();
    assert!(summary.env_steps >= 3000);
    let config = std::fs::read_to_string(run.join("config.toml")).unwrap();
    assert!(
        config.contains("rules = \"pogema\"") && config.contains("t_max = 128"),
        "the rule set and its T_max are recorded: {config}"
    );
    let spec = std::fs::read_to_string(run.join("checkpoints/final/spec.json")).unwrap();
    assert!(
        spec.contains("pogema"),
        "the checkpoint records the rule set: {spec}"
    );

    let out = dir.path().join("bench");
    let ckpt = format!("checkpoint:{}", run.display());
    let flags = |controllers: &[String]| {
        let mut f: Vec<String> = [
            "--instances",
            set.to_str().unwrap(),
            "--map-name",
            "room",
            "--agents",
            "1,2",
            "--seeds",
            "0..1",
            "--published-methods",
            "Oracle",
            "--time-limit",
            "1",
            "--out",
            out.to_str().unwrap(),
        ]
        .map(String::from)
        .to_vec();
        for c in controllers {
            f.extend(["--controller".to_string(), c.clone()]);
        }
        f
    };
    let controllers = [
        "lacam".to_string(),
        format!("learned={ckpt}"),
        format!("learned-sampled=sampled:{ckpt}"),
    ];
    let rows = run_pogema(&bench_args(&flags(&controllers))).unwrap();
    // Three measured methods and one published, at two agent counts.
    assert_eq!(rows.len(), 8);
    let lacam: Vec<_> = rows.iter().filter(|r| r.method == "lacam").collect();
    assert!(lacam
        .iter()
        .all(|r| r.success_rate == 1.0 && r.instances == 2));
    let oracle: Vec<_> = rows.iter().filter(|r| r.method == "Oracle").collect();
    assert_eq!((oracle[0].agents, oracle[0].success_rate), (1, 1.0));
    assert_eq!((oracle[1].agents, oracle[1].success_rate), (2, 0.5));
    for file in ["table.csv", "table.md", "success.png", "soc_ratio.png"] {
        assert!(out.join(file).is_file(), "missing {file}");
    }
    for label in ["lacam", "learned", "learned-sampled"] {
        let summary = out.join(label).join("agents-2/summary.json");
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&summary).unwrap()).unwrap();
        assert_eq!(json["rules"], "pogema", "{label}");
        assert_eq!(json["t_max"], 128, "{label}");
    }
    let md = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert!(
        md.contains("| agents | lacam | learned | learned-sampled | Oracle (published) |"),
        "{md}"
    );

    // Run again: finished cells are read back, not evaluated again.
    let episodes = out.join("lacam/agents-1/episodes.csv");
    std::fs::remove_file(&episodes).unwrap();
    let again = run_pogema(&bench_args(&flags(&controllers))).unwrap();
    assert_eq!(again, rows);
    assert!(!episodes.exists(), "a kept cell is not run again");

    // Errors say what is wrong.
    let twice = ["lacam".to_string(), "lacam".to_string()];
    let err = format!("{:#}", run_pogema(&bench_args(&flags(&twice))).unwrap_err());
    assert!(
        err.contains("two controllers are labelled 'lacam'"),
        "{err}"
    );
    let mut unknown = flags(&["pibt".to_string()]);
    let at = unknown.iter().position(|f| f == "Oracle").unwrap();
    unknown[at] = "Sage".into();
    let err = format!("{:#}", run_pogema(&bench_args(&unknown)).unwrap_err());
    assert!(
        err.contains("no published results for 'Sage' (the file holds: Oracle)"),
        "{err}"
    );
    let mut missing_seed = flags(&["pibt".to_string()]);
    let at = missing_seed.iter().position(|f| f == "0..1").unwrap();
    missing_seed[at] = "0..2".into();
    let err = format!("{:#}", run_pogema(&bench_args(&missing_seed)).unwrap_err());
    assert!(err.contains("room-1-2.scen"), "{err}");
}

/// `--controller shield-lanes=16:checkpoint:DIR` is the shield with lanes,
/// not a row labelled `shield-lanes` of a controller `16:checkpoint:DIR`;
/// `LABEL@CONTROLLER` and the older `LABEL=CONTROLLER` name rows.
#[test]
fn controllers_with_a_patience_parse_as_controllers() {
    let BenchCommand::Pogema(args) = bench_args(&[
        "--instances",
        "set",
        "--out",
        "out",
        "--controller",
        "shield-lanes=16:checkpoint:runs/a",
        "--controller",
        "learned@backstop:sampled:shield[patience=16,settle,lanes]:checkpoint:runs/a",
        "--controller",
        "learned-fallback#0=shield=16:checkpoint:runs/a",
    ]) else {
        panic!("not the pogema benchmark")
    };
    let rows: Vec<(String, String)> = args
        .controllers
        .iter()
        .map(|c| (c.label.clone(), c.controller.to_string()))
        .collect();
    assert_eq!(
        rows,
        [
            (
                "shield-lanes-16-checkpoint-runs-a".to_string(),
                "shield-lanes=16:checkpoint:runs/a".to_string()
            ),
            (
                "learned".into(),
                "backstop:sampled:shield[patience=16,settle,lanes]:checkpoint:runs/a".into()
            ),
            (
                "learned-fallback#0".into(),
                "shield=16:checkpoint:runs/a".into()
            ),
        ]
    );
    let BenchCommand::Pogema(defaults) = bench_args(&["--instances", "set", "--out", "out"]) else {
        panic!("not the pogema benchmark")
    };
    let chosen = defaults.chosen_controllers().unwrap();
    let labels: Vec<_> = chosen.iter().map(|c| c.label.as_str()).collect();
    assert_eq!(labels, ["lacam", "pibt", "lacam-star", "cbs"]);
    let BenchCommand::Pogema(lifelong) =
        bench_args(&["--lifelong", "--goals", "g", "--out", "out"])
    else {
        panic!("not the pogema benchmark")
    };
    let chosen = lifelong.chosen_controllers().unwrap();
    let labels: Vec<_> = chosen.iter().map(|c| c.label.as_str()).collect();
    assert_eq!(labels, ["lifelong-pibt"]);
}

/// Two maps with one instance each (seed 0, as POGEMA's mazes), and one
/// method's published results on both: the second map unsolved at 2 agents.
fn maze_set(dir: &Path) -> PathBuf {
    let set = dir.join("mazes");
    std::fs::create_dir_all(&set).unwrap();
    let mut csv = String::from("map,agents,seed,algorithm,success,makespan,soc,isr\n");
    for (name, rows) in [
        ("maze-a", ".....\n.@.@.\n....."),
        ("maze-b", "..@..\n.....\n..@.."),
    ] {
        std::fs::write(
            set.join(format!("{name}.map")),
            format!("type octile\nheight 3\nwidth 5\nmap\n{rows}\n"),
        )
        .unwrap();
        let lines = [(0, 0, 4, 2), (4, 0, 0, 2)];
        for agents in [1, 2] {
            let mut text = String::from("version 1\n");
            for &(sx, sy, gx, gy) in &lines[..agents] {
                text += &format!("0\t{name}.map\t5\t3\t{sx}\t{sy}\t{gx}\t{gy}\t0\n");
            }
            std::fs::write(set.join(format!("{name}-{agents}-0.scen")), text).unwrap();
            let s = u8::from(!(name == "maze-b" && agents == 2));
            csv += &format!("{name},{agents},0,Oracle,{s},8,{},1.0\n", 8 * agents);
        }
    }
    // A map the pattern leaves out.
    std::fs::write(
        set.join("room.map"),
        "type octile\nheight 1\nwidth 2\nmap\n..\n",
    )
    .unwrap();
    std::fs::write(set.join("published.csv"), csv).unwrap();
    set
}

#[test]
fn a_map_pattern_pools_every_matching_map_into_one_row_per_count() {
    let dir = tempfile::tempdir().unwrap();
    let set = maze_set(dir.path());
    let out = dir.path().join("bench");
    let flags = |pattern: &str| {
        [
            "--instances",
            set.to_str().unwrap(),
            "--map-name",
            pattern,
            "--agents",
            "1,2",
            "--seeds",
            "0",
            "--published-methods",
            "Oracle",
            "--controller",
            "lacam",
            "--out",
            out.to_str().unwrap(),
        ]
        .map(String::from)
        .to_vec()
    };
    let rows = run_pogema(&bench_args(&flags("maze-*"))).unwrap();
    assert_eq!(rows.len(), 4, "{rows:?}");
    for row in &rows {
        assert_eq!(row.instances, 2, "one instance per map and count: {row:?}");
    }
    let lacam: Vec<f64> = rows
        .iter()
        .filter(|r| r.method == "lacam")
        .map(|r| r.success_rate)
        .collect();
    assert_eq!(lacam, [1.0, 1.0]);
    let oracle: Vec<f64> = rows
        .iter()
        .filter(|r| r.method == "Oracle")
        .map(|r| r.success_rate)
        .collect();
    assert_eq!(oracle, [1.0, 0.5], "each map's own published result counts");
    let summary = std::fs::read_to_string(out.join("lacam/agents-2/summary.json")).unwrap();
    assert!(summary.contains("\"map\": \"maze-*\""), "{summary}");
    let episodes = std::fs::read_to_string(out.join("lacam/agents-2/episodes.csv")).unwrap();
    assert!(
        episodes.contains("maze-a-2-0.scen") && episodes.contains("maze-b-2-0.scen"),
        "{episodes}"
    );
    assert!(
        !out.join("lacam/agents-2/heatmap.png").exists(),
        "no one grid to draw"
    );

    let err = run_pogema(&bench_args(&flags("hall-*"))).unwrap_err();
    assert!(
        format!("{err:#}").contains("no map matches 'hall-*'"),
        "{err:#}"
    );
}

/// `learner bench pogema --lifelong`: throughput on a folder of goal files
/// (POGEMA's seed-0 warehouse tasks, served as seeds 0 and 1), kept cells
/// reused, flags that do not fit refused.
#[test]
fn the_lifelong_benchmark_measures_throughput_on_goal_files() {
    let dir = tempfile::tempdir().unwrap();
    let goals = dir.path().join("goals");
    std::fs::create_dir_all(&goals).unwrap();
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../eval/tests/data/lifelong");
    std::fs::copy(data.join("warehouse.map"), goals.join("warehouse.map")).unwrap();
    for seed in [0, 1] {
        std::fs::copy(
            data.join("warehouse-lifelong-0.goals"),
            goals.join(format!("warehouse-lifelong-{seed}.goals")),
        )
        .unwrap();
    }
    let out = dir.path().join("out");
    let flags = |extra: &[&str]| {
        let mut f: Vec<String> = [
            "--lifelong",
            "--goals",
            goals.to_str().unwrap(),
            "--agents",
            "32,64",
            "--seeds",
            "0..1",
            "--steps",
            "24",
            "--jobs",
            "2",
            "--out",
            out.to_str().unwrap(),
        ]
        .map(String::from)
        .to_vec();
        f.extend(extra.iter().map(|s| s.to_string()));
        f
    };
    let run = |f: &[String]| match bench_args(f) {
        BenchCommand::Pogema(args) => bench::run_lifelong(&args),
        other => panic!("not the pogema benchmark: {other:?}"),
    };
    let both = flags(&[
        "--delay",
        "0.1",
        "--controller",
        "lifelong-pibt",
        "--controller",
        "lacam",
    ]);
    let rows = run(&both).unwrap();
    // Two controllers and two published methods at two counts.
    assert_eq!(rows.len(), 8);
    let measured: Vec<_> = rows.iter().filter(|r| r.source == "measured").collect();
    assert_eq!(measured.len(), 4);
    for r in &measured {
        assert_eq!(r.instances, 2, "{r:?}");
        // The same tasks under seeded delays: both seeds' files are one.
        assert!(r.throughput > 0.0, "{r:?}");
    }
    for file in ["instances.csv", "table.csv", "table.md", "throughput.png"] {
        assert!(out.join(file).is_file(), "missing {file}");
    }
    let md = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert!(
        md.contains("| agents | lifelong-pibt | lacam | Follower (published) | RHCR (published) |"),
        "{md}"
    );
    // Run again: kept cells are read back.
    let kept = out.join("lacam/agents-32.csv");
    assert!(kept.is_file());
    assert_eq!(run(&both).unwrap(), rows);
    // The kept cells were run at delay 0.1: a run at delay 0 (and, without
    // --controller, of lifelong-pibt) does not take them.
    let err = format!("{:#}", run(&flags(&[])).unwrap_err());
    assert!(
        err.contains("lifelong-pibt/agents-32.csv: holds runs of 24 steps at delay 0.1"),
        "{err}"
    );
    // Flags that do not fit.
    let err = format!("{:#}", run(&flags(&["--delay", "1.5"])).unwrap_err());
    assert!(err.contains("--delay must lie in [0, 1)"), "{err}");
    let mut missing = flags(&[]);
    let at = missing.iter().position(|f| f == "0..1").unwrap();
    missing[at] = "0..2".into();
    let err = format!("{:#}", run(&missing).unwrap_err());
    assert!(err.contains("warehouse-lifelong-2.goals"), "{err}");
    #[derive(Parser)]
    struct Bench {
        #[command(subcommand)]
        command: BenchCommand,
    }
    for bad in [
        vec!["bench", "pogema", "--lifelong", "--out", "x"],
        vec!["bench", "pogema", "--goals", "g", "--out", "x"],
        vec![
            "bench",
            "pogema",
            "--lifelong",
            "--goals",
            "g",
            "--instances",
            "i",
            "--out",
            "x",
        ],
        vec!["bench", "pogema", "--out", "x"],
    ] {
        assert!(Bench::try_parse_from(&bad).is_err(), "{bad:?}");
    }
}
