//! The evaluation harness end to end: planners, random, limits, output files.

use std::sync::Arc;
use std::time::Duration;

use buridan_env::{Map, Starts, REFERENCE_MODELS};
use buridan_eval::output::{write_report, write_sweep};
use buridan_eval::planner::PlannerController;
use buridan_eval::stats::BoxStats;
use buridan_eval::{evaluate, Controller, EvalSpec, RandomController};
use buridan_mapf::{planner_by_name, Limits};

fn planner(name: &str, limits: Limits) -> impl Fn() -> Box<dyn Controller> + Sync {
    let planner: Arc<dyn buridan_mapf::Planner> = planner_by_name(name).unwrap().into();
    move || Box::new(PlannerController::new(planner.clone(), limits))
}

#[test]
fn planners_solve_every_fixed_scenario_in_the_env() {
    // Which planner struggles where (plain CBS on single-lane arms, MA-A*
    // with Σ Manhattan on long aisles) is documented and tested in the mapf
    // crate; here every fixed scenario must be solved by one of them within
    // 5 s, and every plan found must play out in the env exactly as planned.
    for model in REFERENCE_MODELS {
        let map = Arc::new(model.load());
        let agents = map.scenario.as_ref().unwrap().starts.len();
        let spec = EvalSpec {
            agents,
            episodes: 1,
            starts: Starts::Fixed,
            ..EvalSpec::default()
        };
        let mut solved = Vec::new();
        for name in ["cbs", "ma-astar"] {
            let report = evaluate(
                &map,
                &spec,
                &planner(name, Limits::with_time(Duration::from_secs(5))),
                &|_| {},
            )
            .unwrap();
            let r = &report.records[0];
            if r.success {
                // Following is forbidden by default, so the env replays the plan exactly.
                assert_eq!(Some(r.timesteps), r.plan_makespan, "{} {name}", model.id);
                assert_eq!(r.sum_of_costs, r.plan_sum_of_costs, "{} {name}", model.id);
                solved.push(name);
            } else if r.gave_up.is_none() {
                // A plan longer than T_max is found but truncated in the env.
                assert!(
                    r.plan_makespan.unwrap() > 100 && r.timesteps == 100,
                    "{} {name}: {r:?}",
                    model.id
                );
            }
        }
        assert!(!solved.is_empty(), "{}: no planner solved it", model.id);
    }
}

#[test]
fn rm_1_1_fixed_scenario_numbers() {
    // Under the env's rules the shortest rm-1.1 episode lasts 10 steps and
    // scores 3 (0.5 + 0.5 first-reach, +1 each when both are home).
    let map = Arc::new(Map::load("rm-1.1").unwrap());
    let spec = EvalSpec {
        agents: 2,
        episodes: 1,
        starts: Starts::Fixed,
        ..EvalSpec::default()
    };
    for name in ["cbs", "ma-astar"] {
        let report = evaluate(&map, &spec, &planner(name, Limits::default()), &|_| {}).unwrap();
        let r = &report.records[0];
        assert!(r.success, "{name}");
        assert_eq!(r.reward, 3.0, "{name}");
        assert!(
            r.timesteps >= 10,
            "{name}: {} steps is below the env's optimum of 10",
            r.timesteps
        );
        assert_eq!(report.summary.success_rate, 1.0);
    }
}

#[test]
fn identical_episodes_for_every_controller() {
    let map = Arc::new(Map::load("rm-2.1").unwrap());
    let spec = EvalSpec {
        agents: 4,
        episodes: 5,
        ..EvalSpec::default()
    };
    let a = evaluate(&map, &spec, &planner("cbs", Limits::default()), &|_| {}).unwrap();
    let b = evaluate(
        &map,
        &spec,
        &planner("ma-astar", Limits::default()),
        &|_| {},
    )
    .unwrap();
    // Both optimal in their own sense on the same instances: CBS minimises the
    // sum of costs, so MA-A* can never beat it there.
    for (x, y) in a.records.iter().zip(&b.records) {
        assert_eq!(x.episode, y.episode);
        if let (Some(sx), Some(sy)) = (x.plan_sum_of_costs, y.plan_sum_of_costs) {
            assert!(sx <= sy, "episode {}: cbs {sx} > ma-astar {sy}", x.episode);
        }
    }
    // Parallel evaluation gives the same records as serial.
    let par = evaluate(
        &map,
        &EvalSpec {
            jobs: 2,
            ..spec.clone()
        },
        &planner("cbs", Limits::default()),
        &|_| {},
    )
    .unwrap();
    let strip = |r: &buridan_eval::EpisodeRecord| {
        (
            r.episode,
            r.success,
            r.timesteps,
            r.sum_of_costs,
            r.plan_makespan,
        )
    };
    assert_eq!(
        a.records.iter().map(strip).collect::<Vec<_>>(),
        par.records.iter().map(strip).collect::<Vec<_>>()
    );
}

#[test]
fn random_controller_is_reproducible_and_rarely_succeeds_on_a_warehouse() {
    let map = Arc::new(Map::load("rm-2.1").unwrap());
    let spec = EvalSpec {
        agents: 4,
        episodes: 20,
        ..EvalSpec::default()
    };
    let run = || {
        evaluate(
            &map,
            &spec,
            &|| Box::new(RandomController::new(42)),
            &|_| {},
        )
        .unwrap()
    };
    let (a, b) = (run(), run());
    assert_eq!(
        a.records,
        b.records
            .iter()
            .map(|r| buridan_eval::EpisodeRecord {
                compute_ms: a.records[r.episode as usize].compute_ms,
                ..r.clone()
            })
            .collect::<Vec<_>>()
    );
    assert!(
        a.summary.success_rate < 0.2,
        "random succeeded in {}",
        a.summary.success_rate
    );
    assert!(a.records.iter().all(|r| r.timesteps <= 100));
    let visits: u64 = a.visits.iter().sum();
    // Each episode: 4 start visits + 4 per step.
    let expected: u64 = a
        .records
        .iter()
        .map(|r| 4 + 4 * u64::from(r.timesteps))
        .sum();
    assert_eq!(visits, expected);
}

#[test]
fn time_limit_is_a_counted_failure_not_a_hang() {
    let map = Arc::new(Map::load("rm-2.1").unwrap());
    let spec = EvalSpec {
        agents: 14,
        episodes: 2,
        ..EvalSpec::default()
    };
    let limits = Limits::with_time(Duration::from_millis(100));
    let started = std::time::Instant::now();
    let report = evaluate(&map, &spec, &planner("ma-astar", limits), &|_| {}).unwrap();
    assert!(
        started.elapsed() < Duration::from_secs(10),
        "took {:?}",
        started.elapsed()
    );
    assert_eq!(
        report
            .summary
            .gave_up
            .get("time limit")
            .copied()
            .unwrap_or(0)
            + report
                .summary
                .gave_up
                .get("memory limit")
                .copied()
                .unwrap_or(0),
        2
    );
    assert_eq!(report.summary.success_rate, 0.0);
    assert!(report.records.iter().all(|r| r.compute_ms < 2000.0));
}

#[test]
fn too_many_agents_is_a_typed_error() {
    let map = Arc::new(Map::load("rm-1.1").unwrap());
    let spec = EvalSpec {
        agents: 10,
        episodes: 1,
        ..EvalSpec::default()
    };
    let err = evaluate(&map, &spec, &|| Box::new(RandomController::new(0)), &|_| {}).unwrap_err();
    assert!(
        matches!(err, buridan_env::EnvError::TooFewFreeCells { .. }),
        "{err}"
    );
}

#[test]
fn report_files_are_written() {
    let map = Arc::new(Map::load("rm-1.3").unwrap());
    let dir = std::env::temp_dir().join(format!("buridan-eval-test-{}", std::process::id()));
    let mut summaries = Vec::new();
    for agents in [2, 3] {
        let spec = EvalSpec {
            agents,
            episodes: 4,
            ..EvalSpec::default()
        };
        let report = evaluate(&map, &spec, &planner("cbs", Limits::default()), &|_| {}).unwrap();
        let files = write_report(&dir.join(format!("a{agents}")), &report, &map.grid).unwrap();
        let names: Vec<_> = files
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(
            names,
            [
                "episodes.csv",
                "summary.json",
                "heatmap.png",
                "timesteps_boxplot.png"
            ]
        );
        let csv = std::fs::read_to_string(&files[0]).unwrap();
        assert_eq!(csv.lines().count(), 1 + 4, "header + one row per episode");
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&files[1]).unwrap()).unwrap();
        for field in [
            "success_rate",
            "episodes",
            "timesteps_median",
            "timesteps_q1",
            "timesteps_q3",
            "compute_ms_median",
        ] {
            assert!(json.get(field).is_some(), "summary.json lacks {field}");
        }
        assert_eq!(json["episodes"], 4);
        for png in &files[2..] {
            let bytes = std::fs::read(png).unwrap();
            assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{}", png.display());
        }
        summaries.push(report.summary);
    }
    let sweep = write_sweep(&dir, &summaries).unwrap();
    let csv = std::fs::read_to_string(&sweep[0]).unwrap();
    assert!(csv.lines().nth(1).unwrap().starts_with("cbs,rm-1.3,2,4,"));
    assert!(csv.lines().nth(2).unwrap().starts_with("cbs,rm-1.3,3,4,"));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn box_stats_by_hand() {
    // Sorted: 18 20 22 23 24 30 60. q1 at rank 1.5 = 21, median 23, q3 at
    // rank 4.5 = 27; IQR 6 → fences 12 and 36 → whiskers 18 and 30; 60 is an outlier.
    let b = BoxStats::of(&[24.0, 18.0, 60.0, 22.0, 20.0, 30.0, 23.0]).unwrap();
    assert_eq!(
        (b.whisker_low, b.q1, b.median, b.q3, b.whisker_high, b.count),
        (18.0, 21.0, 23.0, 27.0, 30.0, 7)
    );
    // The dissertation's 22.5: an even count takes the mean of the middle two.
    assert_eq!(
        BoxStats::of(&[21.0, 22.0, 23.0, 40.0]).unwrap().median,
        22.5
    );
    assert!(BoxStats::of(&[]).is_none());
}
