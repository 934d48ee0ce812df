//! The planners under the env's pogema rules (simultaneous moves): the
//! answers that differ from thesis rules (following, rotation), the
//! validator's verdicts, the planner that cannot plan for pogema, and LaCAM
//! and LaCAM* (with its LNS refinement) on the benchmark's warehouse
//! instances, every plan replayed in the env under pogema rules.

use buridan_mapf::Problem;
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use buridan_env::{Cell, Grid, Map, Rules as RuleSet, Scenario};
use buridan_mapf::{
    planner_by_name, planner_for_rules, replay_exact_with, replay_with, validate_with,
    ConflictModel, Lacam, LacamStar, Limits, Plan, PlanError, Planner, PlannerLookupError,
    SolveError,
};

fn c(row: usize, col: usize) -> Cell {
    Cell::new(row, col)
}

fn limits(secs: u64) -> Limits {
    Limits::with_time(Duration::from_secs(secs))
}

/// The planners that support both rule sets.
const PLANNERS: [&str; 6] = ["pibt", "lacam", "lacam-star", "cbs", "ma-astar", "pp"];

/// A grid as a map, so that plans can be replayed in a `GridEnv` (the
/// instance as its fixed scenario: the env needs one on maps with fewer
/// free cells than two per agent).
fn map_of(rows: &[&str], starts: &[Cell], goals: &[Cell]) -> Arc<Map> {
    Arc::new(Map {
        name: "hand-built".into(),
        grid: Grid::from_rows(rows).unwrap(),
        scenario: Some(Scenario {
            starts: starts.to_vec(),
            goals: goals.to_vec(),
        }),
    })
}

/// Plans with `name` under `rules`, then checks the plan is valid under the
/// rule set's conflict model and replays exactly in an env under it;
/// returns the makespan.
fn plan_and_replay(name: &str, rules: RuleSet, map: &Arc<Map>, s: &[Cell], g: &[Cell]) -> usize {
    let planner = planner_for_rules(name, rules).unwrap();
    assert_eq!(planner.rules(), ConflictModel::from(rules), "{name}");
    let sol = planner
        .solve(Problem::new(&map.grid, s, g), &limits(10))
        .unwrap_or_else(|e| panic!("{name} under {rules}: {e}"));
    validate_with(&map.grid, s, g, &sol.plan, rules.into())
        .unwrap_or_else(|e| panic!("{name} under {rules}: {e}"));
    let r = replay_exact_with(map, s, g, &sol.plan, 128, rules)
        .unwrap_or_else(|e| panic!("{name} under {rules}: {e}"));
    assert_eq!(r.final_positions, g, "{name} under {rules}");
    sol.plan.makespan()
}

/// A following chain in a corridor: both agents step right at once under
/// pogema rules (makespan 1); under thesis rules agent 0 cannot follow the
/// higher-index agent 1 in the same step (makespan 2).
#[test]
fn a_following_chain_takes_one_step_under_pogema_and_two_under_thesis() {
    let (s, g) = ([c(0, 0), c(0, 1)], [c(0, 1), c(0, 2)]);
    let map = map_of(&["...."], &s, &g);
    for name in PLANNERS {
        assert_eq!(
            plan_and_replay(name, RuleSet::Pogema, &map, &s, &g),
            1,
            "{name}"
        );
        assert_eq!(
            plan_and_replay(name, RuleSet::Thesis, &map, &s, &g),
            2,
            "{name}"
        );
    }
}

/// Four agents rotating around a 2×2 block with no free cell: one step
/// under pogema rules; unsolvable under thesis rules (LaCAM proves it).
#[test]
fn a_rotation_is_one_step_under_pogema_and_unsolvable_under_thesis() {
    let ring = [c(0, 0), c(0, 1), c(1, 1), c(1, 0)];
    let goals = [ring[1], ring[2], ring[3], ring[0]];
    let map = map_of(&["..", ".."], &ring, &goals);
    for name in PLANNERS {
        assert_eq!(
            plan_and_replay(name, RuleSet::Pogema, &map, &ring, &goals),
            1,
            "{name}"
        );
    }
    for name in ["lacam", "lacam-star"] {
        let thesis = planner_for_rules(name, RuleSet::Thesis).unwrap();
        assert_eq!(
            thesis.solve(Problem::new(&map.grid, &ring, &goals), &limits(10)),
            Err(SolveError::NoSolution),
            "{name}"
        );
    }
    // The pogema plan does not replay under thesis rules: nobody can move.
    let sol = planner_for_rules("lacam", RuleSet::Pogema)
        .unwrap()
        .solve(Problem::new(&map.grid, &ring, &goals), &limits(10))
        .unwrap();
    let r = replay_with(&map, &ring, &goals, &sol.plan, 100, RuleSet::Thesis).unwrap();
    assert!(!r.is_exact(1) && !r.blocked_following.is_empty(), "{r:?}");
}

/// Under thesis rules the planners are exactly `planner_by_name`'s.
#[test]
fn thesis_planners_are_the_default_ones() {
    for name in PLANNERS.into_iter().chain(["od-astar", "lacam+od-astar"]) {
        let by_name = planner_by_name(name).unwrap();
        let for_thesis = planner_for_rules(name, RuleSet::Thesis).unwrap();
        assert_eq!(by_name.name(), for_thesis.name());
        assert_eq!(for_thesis.rules(), ConflictModel::ENV_EXECUTABLE);
    }
}

/// OD-A* searches the thesis step itself: asked for pogema it says so.
#[test]
fn od_astar_refuses_pogema_rules_with_a_typed_error() {
    for name in ["od-astar", "od-astar-soc", "lacam+od-astar"] {
        let err = planner_for_rules(name, RuleSet::Pogema).err().unwrap();
        assert!(
            matches!(
                &err,
                PlannerLookupError::UnsupportedRules { planner, rules: RuleSet::Pogema, .. }
                    if planner.starts_with("od-astar")
            ),
            "{name}: {err}"
        );
        assert!(err.to_string().contains("pogema"), "{err}");
    }
    let pp_lacam = planner_for_rules("pp+lacam", RuleSet::Pogema).unwrap();
    assert_eq!(pp_lacam.rules(), ConflictModel::SIMULTANEOUS);
}

/// The validator under pogema rules: swaps and vertex conflicts rejected,
/// following and rotations accepted (both rejected under thesis rules).
#[test]
fn validator_under_pogema_rejects_swaps_and_vertex_conflicts_only() {
    let pogema = ConflictModel::from(RuleSet::Pogema);
    let thesis = ConflictModel::from(RuleSet::Thesis);
    let line = Grid::from_rows(&["...."]).unwrap();
    // Swap along one edge.
    let (s, g) = ([c(0, 1), c(0, 2)], [c(0, 2), c(0, 1)]);
    let swap = Plan::new(vec![vec![s[0], g[0]], vec![s[1], g[1]]]);
    assert!(matches!(
        validate_with(&line, &s, &g, &swap, pogema),
        Err(PlanError::SwapConflict {
            first: 0,
            second: 1,
            time: 0,
            ..
        })
    ));
    // Two agents entering one cell.
    let wide = Grid::from_rows(&["...", "..."]).unwrap();
    let (s, g) = ([c(0, 0), c(0, 2)], [c(1, 1), c(0, 0)]);
    let vertex = Plan::new(vec![vec![s[0], c(0, 1), g[0]], vec![s[1], c(0, 1), g[1]]]);
    assert!(matches!(
        validate_with(&wide, &s, &g, &vertex, pogema),
        Err(PlanError::VertexConflict {
            first: 0,
            second: 1,
            time: 1,
            ..
        })
    ));
    // Following a higher-index agent.
    let (s, g) = ([c(0, 0), c(0, 1)], [c(0, 1), c(0, 2)]);
    let follow = Plan::new(vec![vec![s[0], g[0]], vec![s[1], g[1]]]);
    validate_with(&line, &s, &g, &follow, pogema).unwrap();
    assert!(matches!(
        validate_with(&line, &s, &g, &follow, thesis),
        Err(PlanError::FollowingConflict {
            follower: 0,
            leader: 1,
            ..
        })
    ));
    // Rotation around a 2×2 block.
    let square = Grid::from_rows(&["..", ".."]).unwrap();
    let ring = [c(0, 0), c(0, 1), c(1, 1), c(1, 0)];
    let goals = [ring[1], ring[2], ring[3], ring[0]];
    let rotate = Plan::new((0..4).map(|i| vec![ring[i], goals[i]]).collect());
    validate_with(&square, &ring, &goals, &rotate, pogema).unwrap();
    assert!(validate_with(&square, &ring, &goals, &rotate, thesis).is_err());
}

/// The benchmark's warehouse map and its 32-agent instance `seed`
/// (`tests/data/pogema`, copies of `../shared/pogema`).
fn warehouse_32(seed: u32) -> (Arc<Map>, Scenario) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/pogema");
    let map = Arc::new(Map::from_file(&dir.join("warehouse.map")).unwrap());
    let path = dir.join(format!("warehouse-32-{seed}.scen"));
    let text = std::fs::read_to_string(&path).unwrap();
    let scen = buridan_env::map::parse_scen(&path.display().to_string(), &text, &map.grid).unwrap();
    (map, scen)
}

/// LaCAM under pogema rules on four of the benchmark's 32-agent warehouse
/// instances (`tests/data/pogema`, copies of `../shared/pogema`): each is
/// solved within POGEMA's 128 steps and replays exactly in the env under
/// pogema rules, ending with every agent on its goal.
#[test]
fn lacam_solves_pogema_warehouse_instances_and_plans_replay() {
    let lacam = planner_for_rules("lacam", RuleSet::Pogema).unwrap();
    for seed in 0..4 {
        let (map, scen) = warehouse_32(seed);
        let (s, g) = (&scen.starts, &scen.goals);
        assert_eq!(s.len(), 32);
        let sol = lacam
            .solve(Problem::new(&map.grid, s, g), &limits(10))
            .unwrap();
        validate_with(&map.grid, s, g, &sol.plan, ConflictModel::SIMULTANEOUS).unwrap();
        assert!(
            sol.plan.makespan() <= 128,
            "seed {seed}: {}",
            sol.plan.makespan()
        );
        let r = replay_exact_with(&map, s, g, &sol.plan, 128, RuleSet::Pogema).unwrap();
        assert_eq!(&r.final_positions, g, "seed {seed}");
        assert_eq!(r.blocked_moves, 0, "seed {seed}");
    }
}

/// LaCAM* refined by LNS in the second half of its `refine_time` (the
/// default) against LaCAM* refining by its own search alone, on the four
/// 32-agent warehouse instances: every LNS plan valid under simultaneous
/// moves and replayed exactly under pogema rules, none with a larger sum of
/// costs, and the four together shorter.
#[test]
fn lacam_star_refined_by_lns_shortens_warehouse_plans_that_replay() {
    let with_lns = LacamStar {
        lacam: Lacam {
            rules: ConflictModel::SIMULTANEOUS,
            ..Lacam::default()
        },
        refine_time: Some(Duration::from_millis(400)),
        ..LacamStar::default()
    };
    assert!(with_lns.lns);
    let without = LacamStar {
        lns: false,
        ..with_lns
    };
    let (mut total_with, mut total_without) = (0, 0);
    for seed in 0..4 {
        let (map, scen) = warehouse_32(seed);
        let (s, g) = (&scen.starts, &scen.goals);
        let problem = Problem::new(&map.grid, s, g);
        let refined = with_lns.solve(problem, &limits(10)).unwrap().plan;
        let plain = without.solve(problem, &limits(10)).unwrap().plan;
        validate_with(&map.grid, s, g, &refined, ConflictModel::SIMULTANEOUS).unwrap();
        let r = replay_exact_with(&map, s, g, &refined, 128, RuleSet::Pogema).unwrap();
        assert_eq!(&r.final_positions, g, "seed {seed}");
        let (a, b) = (refined.sum_of_costs(), plain.sum_of_costs());
        assert!(a <= b, "seed {seed}: {a} > {b}");
        total_with += a;
        total_without += b;
    }
    assert!(total_with < total_without, "{total_with} ≥ {total_without}");
}
