//! The recipe's additions to the env: the path feature (shortest-path
//! directions around walls, by hand) and potential-based shaping (its sum
//! over an episode, the unshaped return, the discounted form).

mod common;

use buridan_env::{
    intent_feature_dim, local_obs_dim, order_feature_dim, priority_feature_dim, EnvConfig, GridEnv,
    ObsFeatures, Shaping, PATH_FEATURE_DIM, PRESSURE_FEATURE_DIM,
};
use common::{fixed_cfg, map_from_rows, step};

const SYMMETRY: ObsFeatures = ObsFeatures {
    path: false,
    priority: true,
    pressure: true,
    intent: false,
    order: false,
};

/// A U-shaped corridor: the goal at (0, 2) lies two columns right of the
/// agent at (0, 0), but a wall between them forces the way down and around.
///
/// ```text
///      col 0 1 2
/// row 0    A @ g
/// row 1    . @ .
/// row 2    . . .
/// ```
fn u_corridor(features: ObsFeatures, shaping: Option<Shaping>) -> GridEnv {
    let map = map_from_rows(&[".@.", ".@.", "..."], &[(0, 0)], &[(0, 2)]);
    let cfg = EnvConfig {
        features,
        shaping,
        ..fixed_cfg(1, 20)
    };
    GridEnv::new(map, cfg).unwrap()
}

/// Agent `agent`'s whole local observation.
fn local_obs(env: &GridEnv, agent: usize) -> Vec<f32> {
    let mut obs = vec![f32::NAN; env.local_obs_dim()];
    env.write_local_obs(agent, &mut obs).unwrap();
    obs
}

/// Three agents with fixed starts and goals on terrain `rows`, seeing a
/// 3×3 window.
fn three_agents(
    rows: &[&str],
    starts: &[(usize, usize)],
    goals: &[(usize, usize)],
    t_max: u32,
    features: ObsFeatures,
) -> GridEnv {
    let cfg = EnvConfig {
        features,
        sensor_range: 1,
        ..fixed_cfg(3, t_max)
    };
    GridEnv::new(map_from_rows(rows, starts, goals), cfg).unwrap()
}

fn path_tail(env: &GridEnv) -> Vec<f32> {
    let obs = local_obs(env, 0);
    obs[obs.len() - PATH_FEATURE_DIM..].to_vec()
}

#[test]
fn path_feature_points_around_the_wall_not_at_the_goal() {
    let path = ObsFeatures {
        path: true,
        ..ObsFeatures::default()
    };
    let mut env = u_corridor(path, None);
    assert_eq!(env.local_obs_dim(), local_obs_dim(2) + PATH_FEATURE_DIM);
    // At (0, 0): the goal is to the right, but only "down" shortens the
    // 6-step path (up, right, down, left).
    assert_eq!(path_tail(&env), vec![0.0, 0.0, 1.0, 0.0, 6.0 / 6.0]);
    step(&mut env, &[3]); // (1, 0)
    step(&mut env, &[3]); // (2, 0): right now leads on
    assert_eq!(path_tail(&env), vec![0.0, 1.0, 0.0, 0.0, 4.0 / 6.0]);
    step(&mut env, &[2]);
    step(&mut env, &[2]); // (2, 2): up
    assert_eq!(path_tail(&env), vec![1.0, 0.0, 0.0, 0.0, 2.0 / 6.0]);
}

#[test]
fn without_features_the_observation_is_the_dissertations() {
    let env = u_corridor(ObsFeatures::default(), None);
    assert_eq!(env.local_obs_dim(), local_obs_dim(2));
}

#[test]
fn undiscounted_shaping_sums_to_the_distance_gained_and_leaves_the_return() {
    let shaping = Shaping {
        coeff: 0.1,
        gamma: 1.0,
    };
    let mut shaped = u_corridor(ObsFeatures::default(), Some(shaping));
    let mut plain = u_corridor(ObsFeatures::default(), None);
    // A detour (up is blocked by the border: stay), a step back, then the path.
    let actions = [0u8, 3, 1, 3, 3, 2, 2, 1, 1];
    let (mut shaped_sum, mut plain_sum) = (0.0f32, 0.0f32);
    for &a in &actions {
        let (rs, out_s) = step(&mut shaped, &[a]);
        let (rp, out_p) = step(&mut plain, &[a]);
        assert_eq!(out_s, out_p, "shaping must not change the dynamics");
        shaped_sum += rs[0];
        plain_sum += rp[0];
        if out_s.done() {
            break;
        }
    }
    assert!(shaped.stats().success);
    // Distance 6 at the start, 0 at the goal: 0.1 · 6 on top.
    assert!(
        (shaped_sum - plain_sum - 0.6).abs() < 1e-5,
        "{shaped_sum} vs {plain_sum}"
    );
    // The reported episode return is the unshaped one.
    assert_eq!(shaped.stats().reward, plain.stats().reward);
}

#[test]
fn discounted_shaping_is_gamma_phi_next_minus_phi() {
    let shaping = Shaping {
        coeff: 0.5,
        gamma: 0.9,
    };
    let mut env = u_corridor(ObsFeatures::default(), Some(shaping));
    // Staying at distance 6: 0.5 · (0.9 · −6 − (−6)) = 0.3.
    let (r, _) = step(&mut env, &[0]);
    assert!((r[0] - 0.3).abs() < 1e-6, "{}", r[0]);
    // One step closer (6 → 5): 0.5 · (0.9 · −5 + 6) = 0.75.
    let (r, _) = step(&mut env, &[3]);
    assert!((r[0] - 0.75).abs() < 1e-6, "{}", r[0]);
}

#[test]
fn bad_shaping_is_a_config_error() {
    for shaping in [
        Shaping {
            coeff: -1.0,
            gamma: 0.99,
        },
        Shaping {
            coeff: 0.1,
            gamma: 0.0,
        },
        Shaping {
            coeff: f32::NAN,
            gamma: 0.99,
        },
    ] {
        let err = EnvConfig {
            shaping: Some(shaping),
            ..EnvConfig::default()
        }
        .validate()
        .unwrap_err();
        assert!(err.to_string().contains("shaping"), "{err}");
    }
}

/// An aisle of five cells with a pocket above its middle; agent 0 at the
/// left end wants the right end, agent 1 next to it wants the left end,
/// agent 2 waits in the pocket on its goal.
///
/// ```text
///      col 0 1 2 3 4
/// row 0    @ @ 2 @ @
/// row 1    0 1 . . .
/// ```
fn aisle(features: ObsFeatures) -> GridEnv {
    three_agents(
        &["@@.@@", "....."],
        &[(1, 0), (1, 1), (0, 2)],
        &[(1, 4), (1, 0), (0, 2)],
        10,
        features,
    )
}

/// The symmetry features of `agent`: the 3×3 priority window, the
/// urgency, then the four pressure flags (after the path feature, if on).
fn symmetry_tail(env: &GridEnv, agent: usize) -> (Vec<f32>, f32, Vec<f32>) {
    let obs = local_obs(env, agent);
    let path = if env.config().features.path {
        PATH_FEATURE_DIM
    } else {
        0
    };
    let tail = &obs[local_obs_dim(1) + path..];
    let window = priority_feature_dim(1) - 1;
    (
        tail[..window].to_vec(),
        tail[window],
        tail[window + 1..window + 1 + PRESSURE_FEATURE_DIM].to_vec(),
    )
}

#[test]
fn priority_window_marks_who_outranks_the_observer() {
    let env = aisle(SYMMETRY);
    assert_eq!(
        env.local_obs_dim(),
        local_obs_dim(1) + priority_feature_dim(1) + PRESSURE_FEATURE_DIM
    );
    // At the start nobody has been off its goal: the lower index outranks.
    // Agent 1 at (1, 1) sees agent 0 left (+1) and agent 2 above-right (−1).
    let (window, urgency, _) = symmetry_tail(&env, 1);
    assert_eq!(window, vec![0., 0., -1., 1., 0., 0., 0., 0., 0.]);
    assert_eq!(urgency, 0.0);
    // Agent 0 sees agent 1 right of it, outranked.
    assert_eq!(
        symmetry_tail(&env, 0).0,
        vec![0., 0., 0., 0., 0., -1., 0., 0., 0.]
    );
}

#[test]
fn priority_rises_off_the_goal_and_flips_the_order() {
    // Agent 0 starts on its goal at the left end, agent 1 beside it is off
    // its goal.
    let map = map_from_rows(&["...."], &[(0, 0), (0, 1)], &[(0, 0), (0, 3)]);
    let cfg = EnvConfig {
        features: SYMMETRY,
        sensor_range: 1,
        ..fixed_cfg(2, 10)
    };
    let mut env = GridEnv::new(map, cfg).unwrap();
    // Nobody has waited yet: the lower index outranks.
    assert!(env.outranks(0, 1));
    let (window, urgency, _) = symmetry_tail(&env, 1);
    assert_eq!(window, vec![0., 0., 0., 1., 0., 0., 0., 0., 0.]);
    assert_eq!(urgency, 0.0);
    step(&mut env, &[0, 0]);
    // Agent 1 has now been off its goal for a step, agent 0 not at all.
    assert_eq!((env.steps_off_goal(0), env.steps_off_goal(1)), (0, 1));
    assert!(env.outranks(1, 0));
    let (window, urgency, _) = symmetry_tail(&env, 1);
    assert_eq!(window, vec![0., 0., 0., -1., 0., 0., 0., 0., 0.]);
    assert!(
        (urgency - 0.1).abs() < 1e-6,
        "1 step of T_max 10: {urgency}"
    );
    assert_eq!(symmetry_tail(&env, 0).0[5], 1.0);
}

#[test]
fn pressure_flags_the_neighbours_the_observer_blocks() {
    let env = aisle(SYMMETRY);
    // Agent 0's way to (1, 4) runs through agent 1's cell: agent 1 feels
    // pressure from the left. Agent 1's goal is agent 0's cell: agent 0
    // feels pressure from the right.
    assert_eq!(symmetry_tail(&env, 1).2, vec![0., 0., 0., 1.]);
    assert_eq!(symmetry_tail(&env, 0).2, vec![0., 1., 0., 0.]);
    // Agent 2 in the pocket blocks nobody's shortest path.
    assert_eq!(symmetry_tail(&env, 2).2, vec![0., 0., 0., 0.]);
}

#[test]
fn symmetry_features_leave_the_dynamics_unchanged() {
    let mut plain = aisle(ObsFeatures::default());
    let mut with = aisle(SYMMETRY);
    for actions in [[2u8, 0, 0], [0, 1, 0], [3, 4, 0], [2, 2, 3]] {
        let (ra, oa) = step(&mut plain, &actions);
        let (rb, ob) = step(&mut with, &actions);
        assert_eq!((ra, oa), (rb, ob));
    }
}

/// The intent window of `agent`: 5 floats per window cell.
fn intent_window(env: &GridEnv, agent: usize) -> Vec<Vec<f32>> {
    let obs = local_obs(env, agent);
    obs[obs.len() - intent_feature_dim(1)..]
        .chunks(PATH_FEATURE_DIM)
        .map(<[f32]>::to_vec)
        .collect()
}

#[test]
fn intent_shows_where_each_agent_in_the_window_is_headed() {
    let intent = ObsFeatures {
        intent: true,
        ..ObsFeatures::default()
    };
    let env = aisle(intent);
    assert_eq!(
        env.local_obs_dim(),
        local_obs_dim(1) + intent_feature_dim(1)
    );
    let none = vec![0.0; PATH_FEATURE_DIM];
    // Agent 1 at (1, 1): agent 2 above-right sits on its goal (no way
    // closer, distance 0); agent 0 on its left is 4 steps from (1, 4), and
    // only "right" leads closer. Distances are over height + width = 7.
    let seen = intent_window(&env, 1);
    assert_eq!(seen[2], vec![0.0, 0.0, 0.0, 0.0, 0.0]);
    assert_eq!(seen[3], vec![0.0, 1.0, 0.0, 0.0, 4.0 / 7.0]);
    for k in [0, 1, 4, 5, 6, 7, 8] {
        assert_eq!(seen[k], none, "cell {k}: walls, the observer, empty cells");
    }
    // Agent 0 at (1, 0) sees agent 1 on its right, one step "left" from
    // its goal (1, 0).
    let seen = intent_window(&env, 0);
    assert_eq!(seen[5], vec![0.0, 0.0, 0.0, 1.0, 1.0 / 7.0]);
    assert_eq!(seen.iter().filter(|c| **c != none).count(), 1);
}

#[test]
fn intent_follows_the_other_features_and_moves_with_the_agents() {
    let all = ObsFeatures {
        path: true,
        priority: true,
        pressure: true,
        intent: true,
        order: false,
    };
    let mut env = aisle(all);
    assert_eq!(
        env.local_obs_dim(),
        local_obs_dim(1)
            + PATH_FEATURE_DIM
            + priority_feature_dim(1)
            + PRESSURE_FEATURE_DIM
            + intent_feature_dim(1)
    );
    // The pressure flags still sit right after the priority window.
    assert_eq!(symmetry_tail(&env, 1).2, vec![0., 0., 0., 1.]);
    // Agent 1 steps right to (1, 2): agent 0 is now two cells left of it,
    // out of the 3×3 window; agent 2 straight above, still parked.
    step(&mut env, &[0, 2, 0]);
    let seen = intent_window(&env, 1);
    let none = vec![0.0; PATH_FEATURE_DIM];
    assert_eq!(seen.iter().filter(|c| **c != none).count(), 0);
    // Agent 2 sees agent 1 below it, two steps (left, left) from (1, 0).
    let seen = intent_window(&env, 2);
    assert_eq!(seen[7], vec![0.0, 0.0, 0.0, 1.0, 2.0 / 7.0]);
}

/// A dead-end aisle below a corridor: agent 0's goal is at the aisle's
/// bottom, agent 1's one cell above it, agent 2 crosses the corridor.
///
/// ```text
///      col 0 1 2 3 4
/// row 0    . 0 1 . 2      goals: 0 → (3, 2), 1 → (2, 2), 2 → (0, 0)
/// row 1    @ @ . @ @
/// row 2    @ @ . @ @
/// row 3    @ @ . @ @
/// ```
fn dead_end(features: ObsFeatures) -> GridEnv {
    three_agents(
        &[".....", "@@.@@", "@@.@@", "@@.@@"],
        &[(0, 1), (0, 2), (0, 4)],
        &[(3, 2), (2, 2), (0, 0)],
        20,
        features,
    )
}

/// The order window of `agent`: 2 flags per window cell.
fn order_window(env: &GridEnv, agent: usize) -> Vec<[f32; 2]> {
    let obs = local_obs(env, agent);
    obs[obs.len() - order_feature_dim(1)..]
        .chunks(2)
        .map(|c| [c[0], c[1]])
        .collect()
}

#[test]
fn order_says_whose_goal_lies_deeper_in_a_dead_end() {
    let order = ObsFeatures {
        order: true,
        ..ObsFeatures::default()
    };
    let mut env = dead_end(order);
    assert_eq!(env.local_obs_dim(), local_obs_dim(1) + order_feature_dim(1));
    // Agent 0 at (0, 1) passes agent 1's goal (2, 2) on its way to (3, 2):
    // its own goal is the deeper one, so it enters first — flag 0 on agent
    // 1's cell (right of it), flag 1 off.
    let seen = order_window(&env, 0);
    assert_eq!(seen[5], [1.0, 0.0]);
    assert_eq!(seen.iter().filter(|c| **c != [0.0, 0.0]).count(), 1);
    // Agent 1 sees the same pair from the other side: agent 0 (left of it)
    // goes first; agent 2 (right), bound the other way, neither.
    let seen = order_window(&env, 1);
    assert_eq!(seen[3], [0.0, 1.0]);
    assert_eq!(seen[5], [0.0, 0.0]);
    assert_eq!(seen.iter().filter(|c| **c != [0.0, 0.0]).count(), 1);
    // Agent 1 walks down onto its goal: its own way is empty, so it flags
    // nothing, while agent 0, now above it in the aisle, still must pass
    // it — and agent 0's flag says so.
    step(&mut env, &[0, 3, 0]); // agent 1 to (1, 2)
    step(&mut env, &[0, 3, 0]); // agent 1 to (2, 2): on its goal
    step(&mut env, &[2, 0, 0]); // agent 0 to (0, 2)
    step(&mut env, &[3, 0, 0]); // agent 0 to (1, 2)
    let below = 7;
    assert_eq!(order_window(&env, 0)[below], [1.0, 0.0]);
    let above = 1;
    assert_eq!(order_window(&env, 1)[above], [0.0, 1.0]);
}

#[test]
fn order_comes_last_after_every_other_feature() {
    let all = ObsFeatures {
        path: true,
        priority: true,
        pressure: true,
        intent: true,
        order: true,
    };
    let env = dead_end(all);
    assert_eq!(
        env.local_obs_dim(),
        local_obs_dim(1)
            + PATH_FEATURE_DIM
            + priority_feature_dim(1)
            + PRESSURE_FEATURE_DIM
            + intent_feature_dim(1)
            + order_feature_dim(1)
    );
    assert_eq!(order_window(&env, 0)[5], [1.0, 0.0]);
    // The intent window still ends where the order window starts: agent 1
    // (right of agent 0) is two steps down from its goal.
    let obs = local_obs(&env, 0);
    let intent_end = obs.len() - order_feature_dim(1);
    let intent = &obs[intent_end - intent_feature_dim(1)..intent_end];
    assert_eq!(
        &intent[5 * PATH_FEATURE_DIM..6 * PATH_FEATURE_DIM],
        &[0.0, 0.0, 1.0, 0.0, 2.0 / 9.0]
    );
}
