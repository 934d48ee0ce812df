//! Optimality against brute force on tiny instances: CBS's sum of costs
//! equals the optimal SoC, MA-A* with an admissible heuristic the optimal
//! makespan, under both rule sets; OD-A* (env rules only) the optimal
//! makespan; unsolvable instances end with a typed error.

mod common;

use buridan_mapf::Problem;
use std::time::Duration;

use buridan_env::{Cell, Grid, Map};
use buridan_mapf::{
    validate_with, Cbs, ConflictModel, Heuristic, Limits, MaAstar, OdAstar, Planner, SolveError,
};
use common::{optimal_makespan, optimal_soc, random_instance, Rng};

fn limits() -> Limits {
    Limits::with_time(Duration::from_secs(100))
}

#[derive(Default)]
struct Tally {
    solvable: usize,
    unsolvable: usize,
}

fn check_instance(
    grid: &Grid,
    starts: &[Cell],
    goals: &[Cell],
    rules: ConflictModel,
    tally: &mut Tally,
) {
    let follow = rules.forbid_following;
    let best_makespan = optimal_makespan(grid, starts, goals, follow);
    let best_soc = optimal_soc(grid, starts, goals, follow);
    assert_eq!(best_makespan.is_some(), best_soc.is_some());
    let ctx = format!("{grid:?} starts {starts:?} goals {goals:?} {rules:?}");
    let cbs_variants = [
        Cbs {
            rules,
            ..Cbs::default()
        },
        Cbs {
            rules,
            ..Cbs::improved()
        },
    ];
    let astar = |heuristic| MaAstar { heuristic, rules };
    match (best_makespan, best_soc) {
        (Some(makespan), Some(soc)) => {
            tally.solvable += 1;
            for cbs in cbs_variants {
                let sol = cbs
                    .solve(Problem::new(grid, starts, goals), &limits())
                    .unwrap_or_else(|e| panic!("{}: {e} on {ctx}", cbs.name()));
                validate_with(grid, starts, goals, &sol.plan, rules)
                    .unwrap_or_else(|e| panic!("{e} on {ctx}"));
                assert_eq!(sol.plan.sum_of_costs(), soc, "{} SoC on {ctx}", cbs.name());
                assert!(sol.plan.makespan() >= makespan);
            }
            for h in [Heuristic::MaxManhattan, Heuristic::MaxDistance] {
                let sol = astar(h)
                    .solve(Problem::new(grid, starts, goals), &limits())
                    .unwrap();
                validate_with(grid, starts, goals, &sol.plan, rules)
                    .unwrap_or_else(|e| panic!("{e} on {ctx}"));
                assert_eq!(sol.plan.makespan(), makespan, "{h:?} makespan on {ctx}");
                assert!(sol.plan.sum_of_costs() >= soc);
            }
            if rules == ConflictModel::ENV_EXECUTABLE {
                let sol = OdAstar::default()
                    .solve(Problem::new(grid, starts, goals), &limits())
                    .unwrap();
                validate_with(grid, starts, goals, &sol.plan, rules)
                    .unwrap_or_else(|e| panic!("od-astar: {e} on {ctx}"));
                assert_eq!(sol.plan.makespan(), makespan, "od-astar makespan on {ctx}");
                let soc_plan = OdAstar::sum_of_loss()
                    .solve(Problem::new(grid, starts, goals), &limits())
                    .unwrap();
                validate_with(grid, starts, goals, &soc_plan.plan, rules)
                    .unwrap_or_else(|e| panic!("od-astar-soc: {e} on {ctx}"));
                assert!(
                    soc_plan.plan.makespan() >= makespan,
                    "od-astar-soc on {ctx}"
                );
            }
            // SPEC's inadmissible Σ Manhattan: valid, never better than optimal.
            let sol = astar(Heuristic::SumManhattan)
                .solve(Problem::new(grid, starts, goals), &limits())
                .unwrap();
            validate_with(grid, starts, goals, &sol.plan, rules)
                .unwrap_or_else(|e| panic!("{e} on {ctx}"));
            assert!(sol.plan.makespan() >= makespan && sol.plan.sum_of_costs() >= soc);
        }
        _ => {
            tally.unsolvable += 1;
            // MA-A* exhausts the finite joint state space.
            for h in [
                Heuristic::SumManhattan,
                Heuristic::MaxManhattan,
                Heuristic::MaxDistance,
            ] {
                assert_eq!(
                    astar(h).solve(Problem::new(grid, starts, goals), &limits()),
                    Err(SolveError::NoSolution),
                    "{ctx}"
                );
            }
            if rules == ConflictModel::ENV_EXECUTABLE {
                for od in [OdAstar::default(), OdAstar::sum_of_loss()] {
                    assert_eq!(
                        od.solve(Problem::new(grid, starts, goals), &limits()),
                        Err(SolveError::NoSolution),
                        "{} on {ctx}",
                        od.name()
                    );
                }
            }
            // CBS ends only with a makespan cap (or at a limit).
            let capped = Limits {
                max_makespan: Some(6),
                ..limits()
            };
            for cbs in cbs_variants {
                let res = cbs.solve(Problem::new(grid, starts, goals), &capped);
                assert!(
                    matches!(
                        res,
                        Err(SolveError::NoSolutionWithin { max_makespan: 6 })
                            | Err(SolveError::NoSolution)
                    ),
                    "{}: {res:?} on {ctx}",
                    cbs.name()
                );
            }
        }
    }
}

/// 100 random instances (2–3 agents on 2×3 … 4×4 grids with ~20 % walls),
/// each under both rule sets. A handful of them need 10k–50k constraint-tree
/// nodes for plain CBS (seconds in the dev profile), hence the generous
/// time limit.
#[test]
fn planners_match_brute_force_on_random_tiny_instances() {
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let mut tally = Tally::default();
    let mut instances = 0;
    while instances < 100 {
        let (h, w) = [(2, 3), (3, 3), (2, 4), (3, 4), (4, 4)][rng.below(5)];
        let n = 2 + rng.below(2);
        let Some((grid, starts, goals)) = random_instance(&mut rng, h, w, 20, n) else {
            continue;
        };
        instances += 1;
        for rules in [ConflictModel::ENV_EXECUTABLE, ConflictModel::SIMULTANEOUS] {
            check_instance(&grid, &starts, &goals, rules, &mut tally);
        }
    }
    eprintln!(
        "solvable {} unsolvable {}",
        tally.solvable, tally.unsolvable
    );
    assert!(
        tally.solvable >= 150,
        "too few solvable cases: {}",
        tally.solvable
    );
    assert!(
        tally.unsolvable >= 6,
        "too few unsolvable cases: {}",
        tally.unsolvable
    );
}

/// Cases where following matters: a 1×3 corridor and a 2×2 rotation.
#[test]
fn following_rule_changes_the_optimum_as_brute_force_says() {
    let mut tally = Tally::default();
    // Agent 0 directly behind agent 1 in a corridor, both moving right:
    // simultaneously both move at t = 0 (makespan 1, SoC 2); with following
    // forbidden agent 0 must wait one step (makespan 2, SoC 3).
    let corridor = Grid::from_rows(&["...."]).unwrap();
    let c = |col| Cell::new(0, col);
    let (s, g) = ([c(0), c(1)], [c(1), c(2)]);
    assert_eq!(optimal_makespan(&corridor, &s, &g, false), Some(1));
    assert_eq!(optimal_soc(&corridor, &s, &g, false), Some(2));
    assert_eq!(optimal_makespan(&corridor, &s, &g, true), Some(2));
    assert_eq!(optimal_soc(&corridor, &s, &g, true), Some(3));
    for rules in [ConflictModel::ENV_EXECUTABLE, ConflictModel::SIMULTANEOUS] {
        check_instance(&corridor, &s, &g, rules, &mut tally);
    }
    // Four agents rotating clockwise in a 2×2 block: one step simultaneously,
    // impossible in the env (someone always follows a higher index).
    let square = Grid::from_rows(&["..", ".."]).unwrap();
    let (a, b, cc, d) = (
        Cell::new(0, 0),
        Cell::new(0, 1),
        Cell::new(1, 1),
        Cell::new(1, 0),
    );
    let (s, g) = ([a, b, cc, d], [b, cc, d, a]);
    assert_eq!(optimal_makespan(&square, &s, &g, false), Some(1));
    assert_eq!(optimal_makespan(&square, &s, &g, true), None);
    for rules in [ConflictModel::ENV_EXECUTABLE, ConflictModel::SIMULTANEOUS] {
        check_instance(&square, &s, &g, rules, &mut tally);
    }
    assert_eq!((tally.solvable, tally.unsolvable), (3, 1));
}

/// The conflict models of the dissertation, by brute force, against the
/// hand-derived values asserted in `reference_models.rs`.
#[test]
fn brute_force_agrees_with_hand_derived_reference_values() {
    for (id, follow, makespan, soc) in [
        ("rm-1.1", true, 10, 18),
        ("rm-1.1", false, 9, 17),
        ("rm-1.2", true, 16, 24),
        ("rm-1.3", true, 7, 11),
    ] {
        let map = Map::load(id).unwrap();
        let scen = map.scenario.unwrap();
        let (s, g) = (&scen.starts, &scen.goals);
        assert_eq!(
            optimal_makespan(&map.grid, s, g, follow),
            Some(makespan),
            "{id} {follow}"
        );
        assert_eq!(
            optimal_soc(&map.grid, s, g, follow),
            Some(soc),
            "{id} {follow}"
        );
    }
}
