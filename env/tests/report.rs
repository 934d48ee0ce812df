//! Closed-loop reports (`GridEnv::report`): reporting the positions and
//! goals a stepped env reaches reproduces its state and observations.

use std::sync::Arc;

use buridan_env::{Cell, EnvConfig, EnvError, GridEnv, Map, ObsFeatures, Rules, NUM_ACTIONS};
use proptest::prelude::*;

fn config(rules: Rules, lifelong: bool, agents: usize) -> EnvConfig {
    EnvConfig {
        agents,
        rules,
        lifelong,
        t_max: 60,
        features: ObsFeatures::from_names(ObsFeatures::NAMES).unwrap(),
        ..EnvConfig::default()
    }
}

fn observations(env: &GridEnv) -> Vec<Vec<f32>> {
    (0..env.agents())
        .map(|i| {
            let mut obs = vec![0.0; env.local_obs_dim()];
            env.write_local_obs(i, &mut obs).unwrap();
            obs
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    #[test]
    fn reports_of_a_stepped_env_reproduce_its_observations(
        map in prop::sample::select(vec!["rm-2.1", "rm-2.2", "maze/11x11/seed=1"]),
        pogema in any::<bool>(),
        lifelong in any::<bool>(),
        episode in 0u64..1000,
        actions in prop::collection::vec(0u8..NUM_ACTIONS as u8, 60 * 6),
    ) {
        let map = Arc::new(Map::load(map).unwrap());
        let rules = if pogema { Rules::Pogema } else { Rules::Thesis };
        let cfg = config(rules, lifelong, 6);
        let mut stepped = GridEnv::with_episode(map.clone(), cfg.clone(), episode).unwrap();
        let mut reported = stepped.clone();
        let mut rewards = [0.0; 6];
        for (t, step) in actions.chunks(6).enumerate() {
            let out = stepped.step(step, &mut rewards).unwrap();
            let mut reported_rewards = [0.0; 6];
            reported.report(&stepped.positions(), &stepped.goals(), &mut reported_rewards).unwrap();
            if !out.truncated {
                // A session never ends, so it gives no truncation penalty.
                prop_assert_eq!(reported_rewards, rewards, "step {}", t);
            }
            prop_assert_eq!(reported.t(), stepped.t());
            prop_assert_eq!(observations(&reported), observations(&stepped), "step {}", t);
            for i in 0..6 {
                prop_assert_eq!(reported.steps_off_goal(i), stepped.steps_off_goal(i));
                prop_assert_eq!(reported.cost(i), stepped.cost(i));
            }
            prop_assert_eq!(reported.monitor().deadlocked(), stepped.monitor().deadlocked());
            if out.done() {
                break;
            }
        }
    }
}

#[test]
fn bad_reports_are_refused_and_change_nothing() {
    let map = Arc::new(Map::load("rm-2.1").unwrap());
    let mut env = GridEnv::with_episode(map, config(Rules::Thesis, false, 4), 3).unwrap();
    let (positions, goals) = (env.positions(), env.goals());
    let before = observations(&env);
    let with = |i: usize, cell: Cell, list: &[Cell]| {
        let mut list = list.to_vec();
        list[i] = cell;
        list
    };
    let wall = (0..10 * 20)
        .map(|k| Cell::new(k / 20, k % 20))
        .find(|&c| env.map().grid.is_wall(c))
        .unwrap();
    let cases: Vec<(Vec<Cell>, Vec<Cell>, &str)> = vec![
        (
            positions[..3].to_vec(),
            goals.clone(),
            "expected 4 positions, got 3",
        ),
        (
            with(0, Cell::new(40, 0), &positions),
            goals.clone(),
            "agent 0: position (40, 0) is outside the grid",
        ),
        (with(0, wall, &positions), goals.clone(), "is a wall"),
        (
            with(1, positions[0], &positions),
            goals.clone(),
            "agents 0 and 1 share the position cell",
        ),
        (
            positions.clone(),
            with(2, goals[1], &goals),
            "agents 1 and 2 share the goal cell",
        ),
        (positions.clone(), with(2, wall, &goals), "agent 2: goal"),
    ];
    for (p, g, message) in cases {
        let err = env.report(&p, &g, &mut [0.0; 4]).unwrap_err();
        assert!(
            err.to_string().contains(message),
            "{err} (expected {message})"
        );
    }
    // A jump: the first free cell two or more steps away.
    let far = env
        .map()
        .grid
        .free_cells()
        .iter()
        .copied()
        .find(|&c| c.manhattan(positions[0]) >= 2 && !positions.contains(&c))
        .unwrap();
    let err = env
        .report(&with(0, far, &positions), &goals, &mut [0.0; 4])
        .unwrap_err();
    assert!(matches!(err, EnvError::Jump { agent: 0, .. }), "{err}");
    assert_eq!(
        (env.t(), env.positions(), env.goals()),
        (0, positions, goals)
    );
    assert_eq!(observations(&env), before);
}

#[test]
fn goals_may_change_and_trade_places() {
    let map = Arc::new(Map::load("rm-2.1").unwrap());
    let mut env = GridEnv::with_episode(map, config(Rules::Thesis, false, 4), 5).unwrap();
    let (positions, goals) = (env.positions(), env.goals());
    let traded = vec![goals[1], goals[0], goals[2], goals[3]];
    env.report(&positions, &traded, &mut [0.0; 4]).unwrap();
    assert_eq!(env.goals(), traded);
    let grid = &env.map().grid;
    assert_eq!(
        env.goal_distance(0),
        grid.distances_to(goals[1])[grid.index(positions[0])]
    );
    let free = env
        .map()
        .grid
        .free_cells()
        .iter()
        .copied()
        .find(|c| !traded.contains(c) && !positions.contains(c))
        .unwrap();
    let moved = vec![traded[0], traded[1], traded[2], free];
    env.report(&positions, &moved, &mut [0.0; 4]).unwrap();
    assert_eq!(env.goal(3), free);
    assert_eq!(env.t(), 2);
}
