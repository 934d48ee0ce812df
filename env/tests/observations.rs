//! SPEC §3: local windows, masks, central codes and planes, checked by hand.

#![allow(clippy::needless_range_loop)] // index loops mirror the rules as written

mod common;

use std::sync::Arc;

use buridan_env::{
    central_obs_dim, local_obs_dim, EnvConfig, GridEnv, Map, ObsFeatures, ObsKind, Starts,
};
use common::map_from_rows;

/// A 5x6 grid with walls at (0,2) and (2,5) and four agents:
///
/// ```text
///      col 0 1 2 3 4 5
/// row 0    . g1 @ A2 . .
/// row 1    . A0 . .  . .      A0 stands on g3
/// row 2    . .  A1 . . @      A1 stands on g2
/// row 3    . g0 A3 . . .
/// row 4    . .  . .  . .
/// ```
fn scene(sensor_range: usize) -> GridEnv {
    let map = map_from_rows(
        &["..@...", "......", ".....@", "......", "......"],
        &[(1, 1), (2, 2), (0, 3), (3, 2)],
        &[(3, 1), (0, 1), (2, 2), (1, 1)],
    );
    let cfg = EnvConfig {
        sensor_range,
        ..common::fixed_cfg(4, 100)
    };
    GridEnv::new(map, cfg).unwrap()
}

fn codes(env: &GridEnv, agent: usize) -> Vec<u8> {
    let side = 2 * env.config().sensor_range + 1;
    let mut out = vec![9; side * side];
    env.write_local_codes(agent, &mut out).unwrap();
    out
}

fn mask(env: &GridEnv, agent: usize) -> [u8; 5] {
    let mut out = [9; 5];
    env.write_action_mask(agent, &mut out).unwrap();
    out
}

#[test]
fn local_window_codes_by_hand() {
    let env = scene(2);
    // Agent 0 at (1,1): window rows -1..=3, cols -1..=3.
    #[rustfmt::skip]
    let expected0 = [
        1, 1, 1, 1, 1, // row -1: outside
        1, 0, 4, 1, 2, // row 0: outside, empty, goal of 1, wall, agent 2
        1, 0, 4, 0, 0, // row 1: centre = agent 0 itself on agent 3's goal -> 4
        1, 0, 0, 2, 0, // row 2: agent 1 (standing on agent 2's goal: agent beats goal)
        1, 0, 3, 2, 0, // row 3: own goal, agent 3
    ];
    assert_eq!(codes(&env, 0), expected0);
    // Agent 2 at (0,3): window rows -2..=2, cols 1..=5.
    #[rustfmt::skip]
    let expected2 = [
        1, 1, 1, 1, 1, // row -2
        1, 1, 1, 1, 1, // row -1
        4, 1, 0, 0, 0, // row 0: goal of 1, wall, centre (self, no goal), empty, empty
        2, 0, 0, 0, 0, // row 1: agent 0 (on agent 3's goal)
        0, 2, 0, 0, 1, // row 2: agent 1 on agent 2's own goal -> 2, wall at (2,5)
    ];
    assert_eq!(codes(&env, 2), expected2);
    // Agent 1 at (2,2) stands on agent 2's goal: its centre is 4.
    assert_eq!(codes(&env, 1)[12], 4);
}

#[test]
fn centre_is_3_on_the_own_goal_and_0_elsewhere() {
    let map = map_from_rows(&["...", "...", "..."], &[(1, 1)], &[(1, 1)]);
    let env = GridEnv::new(map, common::fixed_cfg(1, 10)).unwrap();
    #[rustfmt::skip]
    let expected = [
        1, 1, 1, 1, 1,
        1, 0, 0, 0, 1,
        1, 0, 3, 0, 1,
        1, 0, 0, 0, 1,
        1, 1, 1, 1, 1,
    ];
    assert_eq!(codes(&env, 0), expected);
    let map = map_from_rows(&["...", "...", "..."], &[(1, 1)], &[(0, 0)]);
    let env = GridEnv::new(map, common::fixed_cfg(1, 10)).unwrap();
    let c = codes(&env, 0);
    assert_eq!((c[12], c[6]), (0, 3));
}

#[test]
fn smaller_sensor_ranges_cut_the_same_window() {
    let env = scene(1);
    assert_eq!(codes(&env, 0), [0, 4, 1, 0, 4, 0, 0, 0, 2]);
    let env = scene(0);
    assert_eq!(codes(&env, 0), [4]);
    assert_eq!(codes(&env, 2), [0]);
    // Large range: everything beyond the grid is 1.
    let env = scene(6);
    let c = codes(&env, 0);
    assert_eq!(c.len(), 169);
    assert_eq!(c.iter().filter(|&&x| x == 1).count(), 169 - 30 + 2);
}

#[test]
fn masks_by_hand() {
    let env = scene(2);
    assert_eq!(mask(&env, 0), [1, 1, 1, 1, 1]); // up onto another's goal is legal
    assert_eq!(mask(&env, 1), [1, 1, 1, 0, 1]); // down: agent 3
    assert_eq!(mask(&env, 2), [1, 0, 1, 1, 0]); // up: outside, left: wall
    assert_eq!(mask(&env, 3), [1, 0, 1, 1, 1]); // up: agent 1, left onto goal 0 ok
    let mut joint = [9; 20];
    env.write_joint_mask(&mut joint).unwrap();
    assert_eq!(
        joint,
        [1, 1, 1, 1, 1, 1, 1, 1, 0, 1, 1, 0, 1, 1, 0, 1, 0, 1, 1, 1]
    );
}

#[test]
fn mask_matches_window_codes_for_every_agent_and_range() {
    for r in 1..=3 {
        let env = scene(r);
        let side = 2 * r + 1;
        let centre = r * side + r;
        for agent in 0..4 {
            let c = codes(&env, agent);
            let m = mask(&env, agent);
            assert_eq!(m[0], 1);
            for (a, k) in [
                (1, centre - side),
                (2, centre + 1),
                (3, centre + side),
                (4, centre - 1),
            ] {
                assert_eq!(
                    m[a] == 1,
                    matches!(c[k], 0 | 3 | 4),
                    "r {r} agent {agent} action {a}"
                );
            }
        }
    }
}

#[test]
fn local_obs_floats_are_one_hot_cells_then_four_position_floats() {
    let env = scene(2);
    assert_eq!(env.local_obs_dim(), 129);
    assert_eq!(local_obs_dim(1), 49);
    let mut obs = vec![f32::NAN; 129];
    env.write_local_obs(0, &mut obs).unwrap();
    let c = codes(&env, 0);
    for k in 0..25 {
        let cell = &obs[5 * k..5 * k + 5];
        for code in 0..5 {
            let want = if code == c[k] as usize { 1.0 } else { 0.0 };
            assert_eq!(cell[code], want, "cell {k} code {code}");
        }
    }
    // Agent 0 at (1,1), goal (3,1); grid 5x6 -> scale rows by 4, columns by 5.
    assert_eq!(&obs[125..], &[0.25, 0.2, 0.5, 0.0]);
    // Agent 2 at (0,3), goal (2,2).
    env.write_local_obs(2, &mut obs).unwrap();
    assert_eq!(&obs[125..], &[0.0, 0.6, 0.5, -0.2]);
    // Spot checks of the one-hot layout: cell 9 (window row 1, col 4 = grid (0,3)) is agent 2 for agent 0.
    env.write_local_obs(0, &mut obs).unwrap();
    assert_eq!(&obs[45..50], &[0.0, 0.0, 1.0, 0.0, 0.0]);
    assert_eq!(&obs[60..65], &[0.0, 0.0, 0.0, 0.0, 1.0]); // centre (cell 12): 4
    assert_eq!(&obs[110..115], &[0.0, 0.0, 0.0, 1.0, 0.0]); // cell 22: own goal
}

#[test]
fn local_obs_follows_the_agent_after_a_step() {
    let mut env = scene(1);
    // Agent 0 moves down to (2,1); the others stay.
    common::step(&mut env, &[3, 0, 0, 0]);
    assert_eq!(env.position(0), common::c(2, 1));
    // Window rows 1..=3, cols 0..=2: (1,1) is now agent 3's goal, (2,2) agent 1, (3,1) own goal, (3,2) agent 3.
    assert_eq!(codes(&env, 0), [0, 4, 0, 0, 0, 2, 0, 3, 2]);
}

#[test]
fn central_codes_by_hand() {
    let env = scene(2);
    let mut out = vec![99u16; 30];
    env.write_central_codes(&mut out).unwrap();
    #[rustfmt::skip]
    let expected: [u16; 30] = [
        0, 5, 1, 6, 0, 0, // goal of 1 (3+2), wall, agent 2 (2+4)
        0, 2, 0, 0, 0, 0, // agent 0 over goal of 3
        0, 0, 4, 0, 0, 1, // agent 1 over goal of 2, wall
        0, 3, 8, 0, 0, 0, // goal of 0, agent 3
        0, 0, 0, 0, 0, 0,
    ];
    assert_eq!(out, expected);
}

#[test]
fn central_planes_by_hand() {
    let env = scene(2);
    assert_eq!(env.central_obs_dim(), 9 * 30);
    assert_eq!(central_obs_dim(5, 6, 4), 270);
    let mut out = vec![f32::NAN; 270];
    env.write_central_obs(&mut out).unwrap();
    let plane = |p: usize| &out[p * 30..(p + 1) * 30];
    let ones = |p: usize| -> Vec<usize> {
        plane(p)
            .iter()
            .enumerate()
            .filter(|(_, &v)| v == 1.0)
            .map(|(k, _)| k)
            .collect()
    };
    assert!(out.iter().all(|&v| v == 0.0 || v == 1.0));
    assert_eq!(ones(0), [2, 17]); // walls (0,2), (2,5)
    assert_eq!(ones(1), [7]); // agent 0 at (1,1)
    assert_eq!(ones(2), [14]); // agent 1 at (2,2)
    assert_eq!(ones(3), [3]); // agent 2 at (0,3)
    assert_eq!(ones(4), [20]); // agent 3 at (3,2)
    assert_eq!(ones(5), [19]); // goal 0 at (3,1)
    assert_eq!(ones(6), [1]); // goal 1 at (0,1)
    assert_eq!(ones(7), [14]); // goal 2 at (2,2), under agent 1: planes do not hide it
    assert_eq!(ones(8), [7]); // goal 3 at (1,1)
}

#[test]
fn central_observation_with_features_carries_every_local_observation() {
    let plain = scene(2);
    let features = ObsFeatures {
        path: true,
        intent: true,
        ..ObsFeatures::default()
    };
    let cfg = EnvConfig {
        features,
        ..plain.config().clone()
    };
    let env = GridEnv::new(plain.map().clone(), cfg.clone()).unwrap();
    let local = env.local_obs_dim();
    assert_eq!(env.central_obs_dim(), 270 + 4 * local);
    assert_eq!(
        ObsKind::Central.obs_dim(env.map(), &cfg),
        env.central_obs_dim()
    );
    let mut out = vec![f32::NAN; env.central_obs_dim()];
    env.write_central_obs(&mut out).unwrap();
    // The planes as without features, then agent i's own local row.
    let mut planes = vec![f32::NAN; 270];
    plain.write_central_obs(&mut planes).unwrap();
    assert_eq!(&out[..270], &planes[..]);
    for i in 0..4 {
        let mut row = vec![f32::NAN; local];
        env.write_local_obs(i, &mut row).unwrap();
        assert_eq!(
            &out[270 + i * local..270 + (i + 1) * local],
            &row[..],
            "agent {i}"
        );
    }
    // A buffer sized for the planes alone is refused.
    assert!(env.write_central_obs(&mut planes).is_err());
}

#[test]
fn bundled_model_observation_sizes() {
    let map = Arc::new(Map::load("rm-2.1").unwrap());
    let env = GridEnv::new(
        map,
        EnvConfig {
            starts: Starts::Fixed,
            ..EnvConfig::default()
        },
    )
    .unwrap();
    assert_eq!(env.local_obs_dim(), 129);
    assert_eq!(env.central_obs_dim(), 9 * 200);
    // Agent 0 of rm-2.1 starts at (5, 0) (scen x=0, y=5) on the left edge,
    // beside a shelf block; agent 2's goal is (6, 0). Window rows 3..=7, cols -2..=2.
    #[rustfmt::skip]
    let expected = [
        1, 1, 0, 0, 0, // row 3: open aisle
        1, 1, 0, 0, 1, // row 4: shelf from col 2
        1, 1, 0, 0, 1, // row 5: centre (5,0)
        1, 1, 4, 0, 0, // row 6: agent 2's goal at (6,0)
        1, 1, 0, 0, 1, // row 7
    ];
    assert_eq!(codes(&env, 0), expected);
    assert_eq!(mask(&env, 0), [1, 1, 1, 1, 0]);
}
