//! Lifelong throughput on goal files: POGEMA's seed-0 warehouse tasks
//! (`data/lifelong/`, written by `scripts/pogema/export_lifelong.py`),
//! shared goals, the benchmark over a directory, and refused input.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use buridan_env::{Cell, Grid, Map};
use buridan_eval::by_name::Labelled;
use buridan_eval::goal_sequences::GoalFile;
use buridan_eval::lifelong_bench::{
    markdown, pool, run_bench, write_results, BenchPlan, PUBLISHED,
};
use buridan_eval::throughput::{run_goal_file, LifelongRun, LifelongSpec, ThroughputError};

fn data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/lifelong")
}

fn warehouse() -> (Arc<Map>, GoalFile) {
    let map = Map::from_file(&data().join("warehouse.map")).unwrap();
    let file = GoalFile::read(&data().join("warehouse-lifelong-0.goals")).unwrap();
    (Arc::new(map), file)
}

fn run(map: &Arc<Map>, file: &GoalFile, controller: &str, spec: &LifelongSpec) -> LifelongRun {
    run_goal_file(map, file, "test.goals", &controller.parse().unwrap(), spec).unwrap()
}

/// A run without its wall time, to compare two runs.
fn outcome(mut run: LifelongRun) -> LifelongRun {
    run.wall_s = 0.0;
    run
}

#[test]
fn the_fixture_is_pogemas_seed_0_with_enough_goals() {
    let (map, file) = warehouse();
    assert_eq!(
        (file.map.as_str(), file.agents(), file.steps),
        ("warehouse", 192, 256)
    );
    assert_eq!(map.name, "warehouse");
    // Starts in the end blocks, goals beside the shelves, all free.
    for (start, seq) in file.starts.iter().zip(&file.sequences) {
        assert!(!map.grid.is_wall(*start));
        assert!(seq.iter().all(|g| !map.grid.is_wall(*g)));
        // As many goals as shortest paths could reach in 256 steps, plus one.
        let mut budget = 0;
        let mut here = *start;
        for g in seq {
            budget += usize::from(map.grid.distances_to(*g)[map.grid.index(here)]).max(1);
            here = *g;
        }
        assert!(budget > 256, "{budget}");
    }
    // The first goals are one draw without repetition (as the one-shot
    // instances'); later ones are drawn per agent, and may coincide.
    let mut first: Vec<Cell> = file.sequences.iter().map(|s| s[0]).collect();
    first.sort();
    first.dedup();
    assert_eq!(first.len(), 192);
}

#[test]
fn lifelong_pibt_on_pogemas_warehouse_is_plausible_collision_free_and_deterministic() {
    let (map, file) = warehouse();
    let spec = LifelongSpec::default();
    let a = run(&map, &file, "lifelong-pibt", &spec);
    assert_eq!((a.steps, a.collisions, a.gave_up_steps), (256, 0, 0));
    assert_eq!(a.per_step.iter().sum::<u32>(), a.goals_reached);
    // POGEMA's published figures at 192 agents lie between 1.57 (RHCR) and
    // 3.94 (Follower) goals per step.
    eprintln!(
        "lifelong-pibt, 192 agents, seed 0: {} goals per step",
        a.throughput
    );
    assert!((1.5..5.0).contains(&a.throughput), "{}", a.throughput);
    assert!(a.most_goals_given < file.sequences.iter().map(Vec::len).max().unwrap());
    assert_eq!(
        outcome(a),
        outcome(run(&map, &file, "lifelong-pibt", &spec))
    );
    // With delays: seeded, so again deterministic; fewer goals.
    let delayed = LifelongSpec { delay: 0.1, ..spec };
    let d = run(&map, &file.first(64).unwrap(), "lifelong-pibt", &delayed);
    assert!(d.delayed_moves > 0 && d.collisions == 0);
    assert_eq!(
        outcome(d.clone()),
        outcome(run(
            &map,
            &file.first(64).unwrap(),
            "lifelong-pibt",
            &delayed
        ))
    );
}

/// Two robots whose sequences start with the same cell, in a corridor.
fn shared_goal_file(map: &Map) -> GoalFile {
    let c = |r, col| Cell::new(r, col);
    GoalFile {
        map: map.name.clone(),
        steps: 40,
        starts: vec![c(0, 0), c(0, 6)],
        sequences: vec![
            [c(0, 3)]
                .into_iter()
                .chain([c(0, 0), c(0, 6)].repeat(20))
                .collect(),
            [c(0, 3)]
                .into_iter()
                .chain([c(0, 6), c(0, 0)].repeat(20))
                .collect(),
        ],
        comments: vec![],
    }
}

#[test]
fn shared_goals_neither_deadlock_nor_panic() {
    // A corridor with a siding in the middle, so robots can pass.
    let grid = Grid::from_rows(&[".......", "@@@.@@@"]).unwrap();
    let map = Arc::new(Map {
        name: "corridor".into(),
        grid,
        scenario: None,
    });
    let file = shared_goal_file(&map);
    let spec = LifelongSpec {
        steps: 40,
        ..LifelongSpec::default()
    };
    for controller in ["lifelong-pibt", "lacam"] {
        let r = run(&map, &file, controller, &spec);
        // Both reach the shared cell and go on with their sequences.
        assert!(r.goals_reached >= 4, "{controller}: {r:?}");
        assert_eq!(r.collisions, 0, "{controller}");
    }
}

#[test]
fn bad_files_and_short_sequences_are_refused_with_the_file() {
    let (map, file) = warehouse();
    let mut short = file.first(2).unwrap();
    short.sequences = vec![vec![short.sequences[0][0]], vec![short.sequences[1][0]]];
    let err = run_goal_file(
        &map,
        &short,
        "short.goals",
        &"lifelong-pibt".parse().unwrap(),
        &LifelongSpec::default(),
    )
    .unwrap_err();
    assert!(matches!(err, ThroughputError::Exhausted { .. }), "{err}");
    assert!(err.to_string().starts_with("short.goals: agent "), "{err}");
    let mut walled = file.first(1).unwrap();
    walled.sequences[0].push(Cell::new(2, 7));
    let err = run_goal_file(
        &map,
        &walled,
        "walled.goals",
        &"lifelong-pibt".parse().unwrap(),
        &LifelongSpec::default(),
    )
    .unwrap_err();
    assert_eq!(
        err.to_string(),
        format!(
            "walled.goals: agent 0: goal {} of its sequence (2, 7) is a wall",
            walled.sequences[0].len() - 1
        )
    );
    let other = Arc::new(Map::load("rm-2.1").unwrap());
    let err = run_goal_file(
        &other,
        &file,
        "w.goals",
        &"lifelong-pibt".parse().unwrap(),
        &LifelongSpec::default(),
    )
    .unwrap_err();
    assert_eq!(
        err.to_string(),
        "w.goals: made for map 'warehouse', run on 'rm-2.1'"
    );
}

#[test]
fn the_benchmark_pools_seeds_and_writes_its_table() {
    let dir = std::env::temp_dir().join(format!("buridan-lifelong-bench-{}", std::process::id()));
    let plan = BenchPlan {
        goals_dir: data(),
        controllers: vec!["lifelong-pibt".parse::<Labelled>().unwrap()],
        counts: vec![32, 64],
        seeds: vec![0],
        spec: LifelongSpec {
            steps: 32,
            ..LifelongSpec::default()
        },
        jobs: 2,
        keep: Some(dir.join("runs")),
    };
    let seen = std::sync::atomic::AtomicUsize::new(0);
    let count = |_: &_| {
        seen.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    };
    let runs = run_bench(&plan, &count).unwrap();
    assert_eq!(
        (runs.len(), seen.load(std::sync::atomic::Ordering::Relaxed)),
        (2, 2)
    );
    assert!(dir.join("runs/lifelong-pibt/agents-64.csv").is_file());
    // Run again: the kept cells are read back, nothing runs.
    assert_eq!(run_bench(&plan, &count).unwrap(), runs);
    assert_eq!(seen.load(std::sync::atomic::Ordering::Relaxed), 2);
    let other_seeds = BenchPlan {
        seeds: vec![0, 0],
        ..plan.clone()
    };
    let err = run_bench(&other_seeds, &count).unwrap_err();
    assert!(
        err.to_string()
            .contains("holds seeds [0], not the [0, 0] asked for"),
        "{err}"
    );
    let delayed = BenchPlan {
        spec: LifelongSpec {
            delay: 0.1,
            ..plan.spec.clone()
        },
        ..plan.clone()
    };
    let err = run_bench(&delayed, &count).unwrap_err();
    assert!(
        err.to_string()
            .contains("holds runs of 32 steps at delay 0, not the 32 steps at delay 0.1 asked for"),
        "{err}"
    );
    let rows = pool(&runs);
    // Two measured rows, then Follower and RHCR at 32 and 64.
    assert_eq!(rows.len(), 2 + 2 * PUBLISHED.len());
    assert_eq!((rows[0].agents, rows[0].instances), (32, 1));
    assert_eq!(rows[2].throughput, 1.13);
    let table = markdown(&rows);
    assert!(
        table.contains("| lifelong-pibt | Follower (published) | RHCR (published) |"),
        "{table}"
    );
    let files = write_results(&dir, &runs, &rows, "test").unwrap();
    assert_eq!(files.len(), 4);
    assert!(files.iter().all(|f| f.is_file()));
    std::fs::remove_dir_all(&dir).unwrap();
    // A seed without a file, and too many agents, fail before any run.
    let no_file = BenchPlan {
        seeds: vec![1],
        keep: None,
        ..plan.clone()
    };
    let err = run_bench(&no_file, &|_| {}).unwrap_err();
    assert!(
        err.to_string().contains("warehouse-lifelong-1.goals"),
        "{err}"
    );
    let too_many = BenchPlan {
        counts: vec![256],
        keep: None,
        ..plan
    };
    let err = run_bench(&too_many, &|_| {}).unwrap_err();
    assert!(
        err.to_string()
            .ends_with("192 agents, fewer than the 256 asked for"),
        "{err}"
    );
}
