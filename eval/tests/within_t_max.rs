//! The planner controllers plan within the episode's T_max: a first plan
//! that is too long is refined until it fits, and where no plan fits the
//! episode gives up with that reason.

use std::sync::Arc;
use std::time::Duration;

use buridan_env::{Cell, Map, Rules};
use buridan_eval::by_name::controller_factory;
use buridan_eval::instances::Instance;
use buridan_eval::planner::PlannerController;
use buridan_eval::{evaluate_instances, Controller, EvalReport, EvalSpec};
use buridan_mapf::{planner_for_rules, Limits};
use buridan_policy::ActMode;

/// rm-1.1 (a corridor of 9 cells with one side pocket), seed-42 episode 36
/// with 2 agents: LaCAM's first plan takes 13 steps, the optimum 8.
fn first_plan_too_long() -> Instance {
    instance(&[(1, 8), (1, 4)], &[(1, 0), (1, 2)])
}

/// rm-1.1, seed-42 episode 10 with 3 agents: every agent is at most 5
/// steps from its goal, but the three need 8 steps together.
fn needs_eight_steps() -> Instance {
    instance(&[(1, 5), (1, 7), (1, 3)], &[(1, 0), (1, 2), (1, 1)])
}

fn instance(starts: &[(usize, usize)], goals: &[(usize, usize)]) -> Instance {
    let cells = |cs: &[(usize, usize)]| cs.iter().map(|&(r, c)| Cell::new(r, c)).collect();
    Instance {
        name: "rm-1.1".into(),
        path: "rm-1.1".into(),
        starts: cells(starts),
        goals: cells(goals),
    }
}

fn limits() -> Limits {
    Limits::with_time(Duration::from_secs(5))
}

fn run(
    instance: &Instance,
    t_max: u32,
    make: &(dyn Fn() -> Box<dyn Controller> + Sync),
) -> EvalReport {
    let map = Arc::new(Map::load("rm-1.1").unwrap());
    let spec = EvalSpec {
        agents: instance.starts.len(),
        t_max,
        ..EvalSpec::default()
    };
    evaluate_instances(&map, &spec, std::slice::from_ref(instance), make, &|_| {}).unwrap()
}

fn by_name(name: &str, agents: usize) -> impl Fn() -> Box<dyn Controller> + Sync {
    controller_factory(name, agents, 42, limits(), ActMode::Greedy, Rules::Thesis).unwrap()
}

#[test]
fn lacam_refines_a_first_plan_longer_than_t_max_until_it_fits() {
    let inst = first_plan_too_long();
    // LaCAM returning its first plan: 13 steps, truncated at T_max = 10.
    let first = planner_for_rules("lacam", Rules::Thesis).unwrap();
    let first: Arc<dyn buridan_mapf::Planner> = first.into();
    let plain = move || -> Box<dyn Controller> {
        Box::new(PlannerController::new(first.clone(), limits()))
    };
    let report = run(&inst, 10, &plain);
    let r = &report.records[0];
    assert!(!r.success && r.plan_makespan == Some(13), "{r:?}");
    // The `lacam` and `lacam-star` controllers plan within T_max.
    for name in ["lacam", "lacam-star"] {
        let report = run(&inst, 10, &by_name(name, 2));
        let r = &report.records[0];
        assert!(r.success, "{name}: {r:?}");
        assert!(r.plan_makespan.unwrap() <= 10, "{name}: {r:?}");
        assert_eq!(Some(r.timesteps), r.plan_makespan, "{name}: {r:?}");
    }
}

#[test]
fn no_plan_within_t_max_gives_up_with_the_proof() {
    let inst = needs_eight_steps();
    for name in [
        "lacam",
        "lacam-star",
        "lacam-star-makespan",
        "od-astar",
        "cbs",
    ] {
        let report = run(&inst, 7, &by_name(name, 3));
        let r = &report.records[0];
        assert!(!r.success, "{name}: {r:?}");
        assert_eq!(
            r.gave_up.as_deref(),
            Some("no solution within 7 steps"),
            "{name}: {r:?}"
        );
        assert_eq!(report.summary.planned_rate, 0.0, "{name}");
        // With one step more every one of them plans it.
        let report = run(&inst, 8, &by_name(name, 3));
        assert!(report.records[0].success, "{name}: {:?}", report.records[0]);
    }
}
