//! Both planners on the fixed scenarios of all 17 reference models: plan
//! found, plan valid, replay in the environment exact.

use std::sync::Arc;
use std::time::Duration;

use buridan_env::{Map, REFERENCE_MODELS};
use buridan_mapf::{
    replay, validate, validate_with, Cbs, Heuristic, Limits, MaAstar, Planner, Rules, Solution,
};

fn solve_fixed(planner: &dyn Planner, id: &str, limits: &Limits) -> (Arc<Map>, Solution) {
    let map = Arc::new(Map::load(id).unwrap());
    let scen = map.scenario.clone().unwrap();
    let sol = planner
        .solve(&map.grid, &scen.starts, &scen.goals, limits)
        .unwrap_or_else(|e| panic!("{} on {id}: {e}", planner.name()));
    (map, sol)
}

/// Solves, validates under both rule sets and replays exactly.
fn check_fixed(planner: &dyn Planner, id: &str, limits: &Limits) -> Solution {
    let (map, sol) = solve_fixed(planner, id, limits);
    let scen = map.scenario.clone().unwrap();
    let (s, g) = (&scen.starts, &scen.goals);
    validate(&map.grid, s, g, &sol.plan).unwrap_or_else(|e| panic!("{id}: {e}"));
    validate_with(&map.grid, s, g, &sol.plan, Rules::ENV_EXECUTABLE)
        .unwrap_or_else(|e| panic!("{id}: {e}"));
    let r = replay(&map, s, g, &sol.plan, 1000).unwrap();
    assert!(
        r.is_exact(sol.plan.makespan()),
        "{} on {id}: replay {r:?}, makespan {}",
        planner.name(),
        sol.plan.makespan()
    );
    assert!(r.blocked_following.is_empty());
    assert_eq!(r.blocked_moves, 0);
    assert_eq!(r.final_positions, *g);
    sol
}

#[test]
fn cbs_solves_every_fixed_scenario() {
    let limits = Limits::with_time(Duration::from_secs(10));
    for model in REFERENCE_MODELS {
        let sol = check_fixed(&Cbs::default(), model.id, &limits);
        eprintln!(
            "cbs {:8} makespan {:3} soc {:3} hl-expanded {:6} ll-expanded {:8} {:?}",
            model.id,
            sol.plan.makespan(),
            sol.plan.sum_of_costs(),
            sol.stats.expanded,
            sol.stats.low_level_expanded,
            sol.stats.wall_time
        );
    }
}

#[test]
fn ma_astar_solves_every_fixed_scenario() {
    let limits = Limits::with_time(Duration::from_secs(10));
    for model in REFERENCE_MODELS {
        let sol = check_fixed(&MaAstar::default(), model.id, &limits);
        eprintln!(
            "ma-a* {:8} makespan {:3} soc {:3} expanded {:8} generated {:10} {:?}",
            model.id,
            sol.plan.makespan(),
            sol.plan.sum_of_costs(),
            sol.stats.expanded,
            sol.stats.generated,
            sol.stats.wall_time
        );
    }
}

#[test]
#[ignore]
fn survey() {
    let limits = Limits::with_time(Duration::from_secs(20));
    for model in REFERENCE_MODELS {
        let map = Map::load(model.id).unwrap();
        let scen = map.scenario.clone().unwrap();
        for p in [
            &Cbs::default() as &dyn Planner,
            &Cbs::improved(),
            &MaAstar::default(),
            &MaAstar::with_heuristic(Heuristic::MaxDistance),
        ] {
            match p.solve(&map.grid, &scen.starts, &scen.goals, &limits) {
                Ok(sol) => eprintln!(
                    "{:24} {:8} n={} makespan {:3} soc {:3} exp {:8} gen {:10} ll {:9} {:?}",
                    p.name(),
                    model.id,
                    scen.starts.len(),
                    sol.plan.makespan(),
                    sol.plan.sum_of_costs(),
                    sol.stats.expanded,
                    sol.stats.generated,
                    sol.stats.low_level_expanded,
                    sol.stats.wall_time
                ),
                Err(e) => eprintln!("{:24} {:8} n={} {e}", p.name(), model.id, scen.starts.len()),
            }
        }
    }
}
