//! OD-A* on the reference models: plans replay exactly in the env with the
//! optimal makespan, including the dead-end orderings of rm-2.1b that
//! CBS and LaCAM without PIBT's swap operation do not find within seconds;
//! the makespan cap and the portfolio around it.

use buridan_mapf::Problem;
use std::sync::Arc;
use std::time::Duration;

use buridan_env::{episode_instance, Map, Starts};
use buridan_mapf::{
    planner_by_name, replay_exact, Heuristic, Lacam, Limits, MaAstar, OdAstar, Planner, Portfolio,
    SolveError,
};

/// rm-2.1b, seed-42 evaluation episode 1: agents 1 and 2 are bound for one
/// dead-end aisle and must enter it deepest goal first (README, "Planners").
fn dead_end_episode() -> (Arc<Map>, Vec<buridan_env::Cell>, Vec<buridan_env::Cell>) {
    let map = Arc::new(Map::load("rm-2.1b").unwrap());
    let inst = episode_instance(&map, 4, Starts::Random, 42, 1).unwrap();
    (map, inst.starts, inst.goals)
}

#[test]
fn solves_a_dead_end_ordering_with_the_optimal_makespan() {
    let (map, s, g) = dead_end_episode();
    let limits = Limits::with_time(Duration::from_secs(30));
    let od = OdAstar::default()
        .solve(Problem::new(&map.grid, &s, &g), &limits)
        .unwrap();
    let replayed = replay_exact(&map, &s, &g, &od.plan, 100).unwrap();
    assert!(replayed.success);
    let reference = MaAstar::with_heuristic(Heuristic::MaxDistance)
        .solve(Problem::new(&map.grid, &s, &g), &limits)
        .unwrap();
    assert_eq!(od.plan.makespan(), reference.plan.makespan());
    assert_eq!(od.plan.makespan(), 33);
}

#[test]
fn a_makespan_cap_below_the_optimum_is_proven_unreachable() {
    // rm-1.1's fixed scenario: optimal makespan 10 under the env's rules.
    let map = Map::load("rm-1.1").unwrap();
    let scen = map.scenario.unwrap();
    let (s, g) = (&scen.starts, &scen.goals);
    let capped = |c| Limits {
        max_makespan: Some(c),
        ..Limits::with_time(Duration::from_secs(30))
    };
    assert_eq!(
        OdAstar::default().solve(Problem::new(&map.grid, s, g), &capped(9)),
        Err(SolveError::NoSolutionWithin { max_makespan: 9 })
    );
    let sol = OdAstar::default()
        .solve(Problem::new(&map.grid, s, g), &capped(10))
        .unwrap();
    assert_eq!(sol.plan.makespan(), 10);
}

#[test]
fn every_fixed_scenario_replays_exactly() {
    for id in [
        "rm-1.1", "rm-1.2", "rm-1.3", "rm-1.4", "rm-2.1", "rm-2.1b", "rm-2.2", "rm-3.1",
    ] {
        let map = Arc::new(Map::load(id).unwrap());
        let scen = map.scenario.clone().unwrap();
        let (s, g) = (&scen.starts, &scen.goals);
        let sol = OdAstar::default()
            .solve(
                Problem::new(&map.grid, s, g),
                &Limits::with_time(Duration::from_secs(30)),
            )
            .unwrap_or_else(|e| panic!("{id}: {e}"));
        replay_exact(&map, s, g, &sol.plan, 1000).unwrap_or_else(|e| panic!("{id}: {e}"));
    }
}

#[test]
fn the_portfolio_passes_on_what_lacam_does_not_finish() {
    let (map, s, g) = dead_end_episode();
    // LaCAM alone, held to a node budget it cannot solve the ordering in.
    let tight = Limits {
        max_nodes: Some(100_000),
        ..Limits::with_time(Duration::from_secs(30))
    };
    // (LaCAM without PIBT's swap operation: with it, it plans this one.)
    let no_swap = Lacam {
        swap: false,
        ..Lacam::default()
    };
    assert!(matches!(
        no_swap.solve(Problem::new(&map.grid, &s, &g), &tight),
        Err(SolveError::NodeLimit { .. })
    ));
    let both = Portfolio::new(vec![Box::new(no_swap), Box::new(OdAstar::default())]);
    let sol = both.solve(Problem::new(&map.grid, &s, &g), &tight).unwrap();
    replay_exact(&map, &s, &g, &sol.plan, 100).unwrap();
    assert_eq!(sol.plan.makespan(), 33);
    let lacam = planner_by_name("lacam").unwrap();
    let sol = lacam
        .solve(Problem::new(&map.grid, &s, &g), &tight)
        .unwrap();
    assert!(replay_exact(&map, &s, &g, &sol.plan, 100).unwrap().success);
}

#[test]
fn empty_and_single_agent_instances_are_planned() {
    let grid = buridan_env::Grid::from_rows(&["....", ".@..", "...."]).unwrap();
    let none = OdAstar::default()
        .solve(Problem::new(&grid, &[], &[]), &Limits::default())
        .unwrap();
    assert_eq!(none.plan.agents(), 0);
    let c = buridan_env::Cell::new;
    let one = OdAstar::default()
        .solve(
            Problem::new(&grid, &[c(0, 0)], &[c(2, 3)]),
            &Limits::default(),
        )
        .unwrap();
    assert_eq!(one.plan.makespan(), 5);
}
