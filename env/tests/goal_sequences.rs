//! Lifelong episodes on given goal sequences (`GridEnv::reset_with_sequences`):
//! each agent gets the goals of its own sequence in order, goals may be
//! shared, bad input is refused with its agent, cell and problem, and the
//! other resets keep exclusive goals.

use std::sync::Arc;

use buridan_env::{Cell, EnvConfig, EnvError, Grid, GridEnv, Map, Rules};

/// A 3×5 room with a pillar in the middle.
fn room() -> Arc<Map> {
    let grid = Grid::from_rows(&[".....", "..@..", "....."]).unwrap();
    Arc::new(Map {
        name: "room".into(),
        grid,
        scenario: None,
    })
}

fn lifelong(agents: usize, rules: Rules) -> EnvConfig {
    EnvConfig {
        agents,
        rules,
        lifelong: true,
        t_max: 100,
        ..EnvConfig::default()
    }
}

/// Per agent, its goals in order.
type Sequences = Vec<Vec<Cell>>;

const STAY: u8 = 0;
const UP: u8 = 1;
const RIGHT: u8 = 2;
const DOWN: u8 = 3;
const LEFT: u8 = 4;

#[test]
fn each_agent_follows_its_own_sequence_in_order() {
    for rules in [Rules::Thesis, Rules::Pogema] {
        let mut env = GridEnv::new(room(), lifelong(1, rules)).unwrap();
        let seq = vec![Cell::new(0, 2), Cell::new(0, 4), Cell::new(2, 4)];
        env.reset_with_sequences(7, &[Cell::new(0, 0)], &[seq])
            .unwrap();
        assert_eq!(env.episode(), 7);
        let mut rewards = [0.0];
        let mut goals = vec![env.goals()[0]];
        for action in [RIGHT, RIGHT, RIGHT, RIGHT, DOWN, DOWN] {
            env.step(&[action], &mut rewards).unwrap();
            goals.push(env.goals()[0]);
        }
        assert_eq!(
            goals,
            [(0, 2), (0, 2), (0, 4), (0, 4), (2, 4), (2, 4), (2, 4)].map(|(r, c)| Cell::new(r, c))
        );
        // Three goals reached: the last one kept, the sequence exhausted.
        assert_eq!(env.stats().goals_reached, 3);
        assert_eq!(env.sequence_exhausted(), Some(0));
        assert_eq!(env.goals_given(0), 3);
        // On its last goal it earns nothing more.
        env.step(&[STAY], &mut rewards).unwrap();
        assert_eq!((env.stats().goals_reached, rewards[0]), (3, 0.0));
    }
}

#[test]
fn goals_may_be_shared_and_the_first_there_moves_on() {
    let mut env = GridEnv::new(room(), lifelong(2, Rules::Pogema)).unwrap();
    let starts = [Cell::new(0, 0), Cell::new(0, 4)];
    let shared = Cell::new(0, 2);
    let sequences = vec![
        vec![shared, Cell::new(2, 0), Cell::new(0, 0)],
        vec![shared, Cell::new(2, 4), Cell::new(0, 4)],
    ];
    env.reset_with_sequences(0, &starts, &sequences).unwrap();
    assert!(env.allows_shared_goals());
    assert_eq!(env.goals(), [shared, shared]);
    let mut rewards = [0.0; 2];
    // Agent 0 first onto the shared goal; agent 1 waits beside it.
    env.step(&[RIGHT, LEFT], &mut rewards).unwrap();
    env.step(&[RIGHT, STAY], &mut rewards).unwrap();
    assert_eq!(env.goals(), [Cell::new(2, 0), shared]);
    assert_eq!(rewards, [0.5, 0.0]);
    // Agent 0 leaves down the left side; agent 1 steps on.
    env.step(&[LEFT, STAY], &mut rewards).unwrap();
    env.step(&[DOWN, LEFT], &mut rewards).unwrap();
    assert_eq!(env.goals(), [Cell::new(2, 0), Cell::new(2, 4)]);
    assert_eq!(env.stats().goals_reached, 2);
    // The observation of agent 1 beside the shared goal shows a goal there
    // while agent 0 still heads for it (a count, not an owner).
    let mut env = GridEnv::new(room(), lifelong(2, Rules::Pogema)).unwrap();
    env.reset_with_sequences(0, &starts, &sequences).unwrap();
    let mut obs = vec![0.0; env.local_obs_dim()];
    env.write_local_obs(1, &mut obs).unwrap();
    assert!(obs.iter().any(|&x| x != 0.0));
}

#[test]
fn a_goal_on_the_agents_own_cell_counts_at_the_next_step() {
    // POGEMA may draw an agent's next goal on the cell it stands on.
    let mut env = GridEnv::new(room(), lifelong(1, Rules::Pogema)).unwrap();
    let here = Cell::new(0, 1);
    env.reset_with_sequences(0, &[Cell::new(0, 0)], &[vec![here, here, Cell::new(0, 0)]])
        .unwrap();
    let mut rewards = [0.0];
    env.step(&[RIGHT], &mut rewards).unwrap();
    env.step(&[STAY], &mut rewards).unwrap();
    assert_eq!(env.stats().goals_reached, 2);
    assert_eq!(env.goals(), [Cell::new(0, 0)]);
    assert_eq!(env.sequence_exhausted(), None);
}

#[test]
fn bad_sequences_are_refused_with_agent_cell_and_problem() {
    let mut env = GridEnv::new(room(), lifelong(2, Rules::Pogema)).unwrap();
    let starts = [Cell::new(0, 0), Cell::new(0, 4)];
    let ok = vec![Cell::new(2, 2)];
    let before = (env.positions(), env.goals());
    let cases: Vec<(Vec<Cell>, Sequences, &str)> = vec![
        (
            starts.to_vec(),
            vec![ok.clone(), vec![Cell::new(2, 1), Cell::new(1, 2)]],
            "agent 1: goal 1 of its sequence (1, 2) is a wall",
        ),
        (
            starts.to_vec(),
            vec![vec![Cell::new(0, 1), Cell::new(9, 9)], ok.clone()],
            "agent 0: goal 1 of its sequence (9, 9) is outside the grid",
        ),
        (
            starts.to_vec(),
            vec![vec![Cell::new(1, 2)], ok.clone()],
            "agent 0: goal (1, 2) is a wall",
        ),
        (
            starts.to_vec(),
            vec![ok.clone(), vec![]],
            "agent 1: its goal sequence is empty (it needs at least one goal)",
        ),
        (
            starts.to_vec(),
            vec![ok.clone()],
            "expected 2 goal sequences, got 1",
        ),
        (
            vec![Cell::new(0, 0), Cell::new(0, 0)],
            vec![ok.clone(), ok.clone()],
            "agents 0 and 1 share the start cell (0, 0)",
        ),
    ];
    for (starts, sequences, message) in cases {
        let err = env
            .reset_with_sequences(1, &starts, &sequences)
            .unwrap_err();
        assert_eq!(err.to_string(), message);
        assert_eq!((env.positions(), env.goals()), before, "{message}");
    }
    // Without lifelong mode an agent would keep its first goal: refused.
    let cfg = EnvConfig {
        lifelong: false,
        ..lifelong(2, Rules::Pogema)
    };
    let mut env = GridEnv::new(room(), cfg).unwrap();
    let err = env
        .reset_with_sequences(0, &starts, &[ok.clone(), ok])
        .unwrap_err();
    assert_eq!(err, EnvError::SequencesNeedLifelong);
}

#[test]
fn other_resets_keep_goals_exclusive() {
    let mut env = GridEnv::new(room(), lifelong(2, Rules::Pogema)).unwrap();
    let starts = [Cell::new(0, 0), Cell::new(0, 4)];
    let shared = [Cell::new(2, 2), Cell::new(2, 2)];
    env.reset_with_sequences(0, &starts, &[vec![shared[0]], vec![shared[1]]])
        .unwrap();
    // A plain reset after a sequence reset: shared goals refused again,
    // and lifelong goals are drawn once more.
    let err = env.reset_with(1, &starts, &shared).unwrap_err();
    assert_eq!(err.to_string(), "agents 0 and 1 share the goal cell (2, 2)");
    env.reset_with(1, &starts, &[Cell::new(0, 1), Cell::new(2, 2)])
        .unwrap();
    assert!(!env.allows_shared_goals());
    let mut rewards = [0.0; 2];
    env.step(&[RIGHT, STAY], &mut rewards).unwrap();
    let goals = env.goals();
    assert_ne!(goals[0], Cell::new(0, 1));
    assert_ne!(goals[0], goals[1]);
    assert_eq!(env.sequence_exhausted(), None);
    // A report names shared goals only after a reset that allows them.
    let mut rewards = [0.0; 2];
    let err = env
        .report(&env.positions(), &shared, &mut rewards)
        .unwrap_err();
    assert_eq!(err.to_string(), "agents 0 and 1 share the goal cell (2, 2)");
    env.reset_with_shared_goals(2, &starts, &shared).unwrap();
    env.report(&starts, &[Cell::new(0, 2), Cell::new(0, 2)], &mut rewards)
        .unwrap();
    assert_eq!(env.goals(), [Cell::new(0, 2), Cell::new(0, 2)]);
}

#[test]
fn the_same_sequences_give_the_same_episode() {
    let map = Arc::new(Map::load("rm-2.1").unwrap());
    let free = map.grid.free_cells().to_vec();
    let starts: Vec<Cell> = free[..4].to_vec();
    let sequences: Vec<Vec<Cell>> = (0..4)
        .map(|i| {
            (0..20)
                .map(|k| free[(7 * i + 13 * k + 5) % free.len()])
                .collect()
        })
        .collect();
    let run = || {
        let cfg = EnvConfig {
            delay: 0.2,
            ..lifelong(4, Rules::Pogema)
        };
        let mut env = GridEnv::new(map.clone(), cfg).unwrap();
        env.reset_with_sequences(3, &starts, &sequences).unwrap();
        let mut rewards = [0.0; 4];
        let mut trace = Vec::new();
        for t in 0..60u8 {
            let actions = [t % 5, (t + 1) % 5, (t + 2) % 5, UP];
            env.step(&actions, &mut rewards).unwrap();
            trace.push((env.positions(), env.goals()));
        }
        (trace, env.stats().goals_reached, env.delayed_moves())
    };
    assert_eq!(run(), run());
}
