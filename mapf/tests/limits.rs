//! Limits are honoured with typed errors; malformed and trivial instances;
//! planners are usable through `dyn Planner` from several threads.

use buridan_mapf::Problem;
use std::time::{Duration, Instant};

use buridan_env::{episode_instance, Cell, Grid, Map, Starts};
use buridan_mapf::{
    planner_by_name, validate_with, Cbs, ConflictModel, Heuristic, InstanceError, Lacam, Limits,
    MaAstar, Planner, SolveError,
};

fn planners() -> Vec<Box<dyn Planner>> {
    vec![
        Box::new(MaAstar::default()),
        Box::new(MaAstar::with_heuristic(Heuristic::MaxDistance)),
        Box::new(Cbs::default()),
        Box::new(Cbs::improved()),
    ]
}

/// rm-2.1 with 16 random agents (seed 42, episode 0): neither CBS variant
/// solves it within 1 s on the development machine, MA-A* does not finish
/// one expansion of its 5^16 joint moves. A 200 ms limit must end each
/// search with `TimeLimit` well within 2 s.
#[test]
fn time_limit_is_honoured_on_a_hard_instance() {
    let map = Map::load("rm-2.1").unwrap();
    let scen = episode_instance(&map, 16, Starts::Random, 42, 0).unwrap();
    let limits = Limits::with_time(Duration::from_millis(200));
    for planner in planners() {
        let t = Instant::now();
        let res = planner.solve(Problem::new(&map.grid, &scen.starts, &scen.goals), &limits);
        let wall = t.elapsed();
        match res {
            Err(SolveError::TimeLimit { elapsed, .. }) => {
                assert!(elapsed >= limits.time, "{}: {elapsed:?}", planner.name());
                assert!(
                    elapsed < Duration::from_secs(2),
                    "{}: {elapsed:?}",
                    planner.name()
                );
            }
            other => panic!("{}: expected TimeLimit, got {other:?}", planner.name()),
        }
        // Including tearing down the search structures.
        assert!(
            wall < Duration::from_secs(2),
            "{}: {wall:?}",
            planner.name()
        );
    }
}

/// MA-A* on an open 12×12 grid with 8 agents crossing over: hard for a joint
/// search, so a 1 MB memory budget runs out first.
#[test]
fn memory_and_node_limits() {
    let grid = Grid::from_walls(12, 12, vec![false; 144]);
    let starts: Vec<Cell> = (0..8).map(|i| Cell::new(i, 0)).collect();
    let goals: Vec<Cell> = (0..8).map(|i| Cell::new(7 - i, 11)).collect();
    let small = Limits {
        memory_bytes: 1 << 20,
        ..Limits::with_time(Duration::from_secs(20))
    };
    match MaAstar::default().solve(Problem::new(&grid, &starts, &goals), &small) {
        Err(SolveError::MemoryLimit {
            estimated_bytes,
            limit_bytes,
            ..
        }) => assert!(estimated_bytes > limit_bytes && limit_bytes == 1 << 20),
        other => panic!("expected MemoryLimit, got {other:?}"),
    }
    // CBS on rm-2.1 with 16 agents: its constraint tree outgrows 64 kB.
    let map = Map::load("rm-2.1").unwrap();
    let scen = episode_instance(&map, 16, Starts::Random, 42, 0).unwrap();
    let tiny = Limits {
        memory_bytes: 64 << 10,
        ..Limits::with_time(Duration::from_secs(20))
    };
    assert!(matches!(
        Cbs::default().solve(Problem::new(&map.grid, &scen.starts, &scen.goals), &tiny),
        Err(SolveError::MemoryLimit { .. })
    ));
    // The node cap, on rm-1.4 (four agents crossing; every planner needs
    // more than 10 expansions).
    let map = Map::load("rm-1.4").unwrap();
    let scen = map.scenario.unwrap();
    let few = Limits {
        max_nodes: Some(10),
        ..Limits::default()
    };
    for planner in planners() {
        assert_eq!(
            planner.solve(Problem::new(&map.grid, &scen.starts, &scen.goals), &few),
            Err(SolveError::NodeLimit { expanded: 10 }),
            "{}",
            planner.name()
        );
    }
}

#[test]
fn unreachable_goals_and_makespan_caps() {
    // A wall column cuts the grid in two: immediately NoSolution.
    let grid = Grid::from_rows(&[".@.", ".@."]).unwrap();
    let (s, g) = ([Cell::new(0, 0)], [Cell::new(1, 2)]);
    for planner in planners() {
        assert_eq!(
            planner.solve(Problem::new(&grid, &s, &g), &Limits::default()),
            Err(SolveError::NoSolution),
            "{}",
            planner.name()
        );
    }
    // rm-1.1 needs makespan 10 under the env rules: a cap of 9 proves that
    // no shorter plan exists; a cap of 10 finds it.
    let map = Map::load("rm-1.1").unwrap();
    let scen = map.scenario.unwrap();
    let cap = |c| Limits {
        max_makespan: Some(c),
        ..Limits::default()
    };
    let lacam = Lacam {
        within_cap: true,
        ..Lacam::default()
    };
    for planner in [
        &MaAstar::with_heuristic(Heuristic::MaxManhattan) as &dyn Planner,
        &MaAstar::default(),
        &Cbs::default(),
        &lacam,
    ] {
        assert_eq!(
            planner.solve(Problem::new(&map.grid, &scen.starts, &scen.goals), &cap(9)),
            Err(SolveError::NoSolutionWithin { max_makespan: 9 }),
            "{}",
            planner.name()
        );
        let sol = planner
            .solve(Problem::new(&map.grid, &scen.starts, &scen.goals), &cap(10))
            .unwrap();
        assert_eq!(sol.plan.makespan(), 10);
    }
    // Agents that must swap in a dead-end corridor: unsolvable. MA-A*
    // exhausts the joint states; CBS ends thanks to the cap.
    let corridor = Grid::from_rows(&["..."]).unwrap();
    let (s, g) = (
        [Cell::new(0, 0), Cell::new(0, 1)],
        [Cell::new(0, 1), Cell::new(0, 0)],
    );
    assert_eq!(
        MaAstar::default().solve(Problem::new(&corridor, &s, &g), &Limits::default()),
        Err(SolveError::NoSolution)
    );
    assert_eq!(
        Cbs::default().solve(Problem::new(&corridor, &s, &g), &cap(8)),
        Err(SolveError::NoSolutionWithin { max_makespan: 8 })
    );
    // Without a cap CBS runs into the time limit instead of hanging.
    let quick = Limits::with_time(Duration::from_millis(100));
    assert!(matches!(
        Cbs::default().solve(Problem::new(&corridor, &s, &g), &quick),
        Err(SolveError::TimeLimit { .. }) | Err(SolveError::MemoryLimit { .. })
    ));
}

#[test]
fn malformed_instances_are_typed_errors() {
    let grid = Grid::from_rows(&["...", ".@."]).unwrap();
    let a = Cell::new(0, 0);
    let b = Cell::new(0, 2);
    for planner in planners() {
        let solve =
            |s: &[Cell], g: &[Cell]| planner.solve(Problem::new(&grid, s, g), &Limits::default());
        assert_eq!(
            solve(&[a], &[b, a]),
            Err(SolveError::Instance(InstanceError::LengthMismatch {
                starts: 1,
                goals: 2
            }))
        );
        assert_eq!(
            solve(&[a, a], &[b, Cell::new(1, 0)]),
            Err(SolveError::Instance(InstanceError::SharedCell {
                first: 0,
                second: 1,
                which: "start",
                cell: a
            }))
        );
        assert_eq!(
            solve(&[a], &[Cell::new(1, 1)]),
            Err(SolveError::Instance(InstanceError::BadCell {
                agent: 0,
                which: "goal",
                cell: Cell::new(1, 1)
            }))
        );
        assert!(matches!(
            solve(&[Cell::new(5, 5)], &[a]),
            Err(SolveError::Instance(InstanceError::BadCell {
                which: "start",
                ..
            }))
        ));
    }
}

#[test]
fn trivial_instances() {
    let grid = Grid::from_rows(&["...", "..."]).unwrap();
    for planner in planners() {
        let sol = planner
            .solve(Problem::new(&grid, &[], &[]), &Limits::default())
            .unwrap();
        assert_eq!((sol.plan.agents(), sol.plan.makespan()), (0, 0));
        let s = [Cell::new(0, 0), Cell::new(1, 2)];
        let sol = planner
            .solve(Problem::new(&grid, &s, &s), &Limits::default())
            .unwrap();
        assert_eq!(sol.plan.paths, vec![vec![s[0]], vec![s[1]]]);
        assert_eq!(sol.plan.sum_of_costs(), 0);
    }
}

#[test]
fn planners_are_send_sync_and_callable_through_the_trait_from_threads() {
    fn assert_send_sync<T: Send + Sync + ?Sized>() {}
    assert_send_sync::<dyn Planner>();
    assert_send_sync::<MaAstar>();
    assert_send_sync::<Cbs>();
    let map = Map::load("rm-2.1").unwrap();
    let planners: Vec<Box<dyn Planner>> = ["cbs", "ma-astar"]
        .iter()
        .map(|n| planner_by_name(n).unwrap())
        .collect();
    std::thread::scope(|scope| {
        for planner in &planners {
            for episode in 0..2 {
                let map = &map;
                scope.spawn(move || {
                    let scen = episode_instance(map, 4, Starts::Random, 42, episode).unwrap();
                    let limits = Limits::with_time(Duration::from_secs(20));
                    let sol = planner
                        .solve(Problem::new(&map.grid, &scen.starts, &scen.goals), &limits)
                        .unwrap();
                    validate_with(
                        &map.grid,
                        &scen.starts,
                        &scen.goals,
                        &sol.plan,
                        ConflictModel::default(),
                    )
                    .unwrap();
                });
            }
        }
    });
}
