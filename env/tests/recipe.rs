//! The recipe's additions to the env: the path feature (shortest-path
//! directions around walls, by hand) and potential-based shaping (its sum
//! over an episode, the unshaped return, the discounted form).

mod common;

use buridan_env::{local_obs_dim, EnvConfig, GridEnv, ObsFeatures, Shaping, PATH_FEATURE_DIM};
use common::{fixed_cfg, map_from_rows, step};

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

fn path_tail(env: &GridEnv) -> Vec<f32> {
    let mut obs = vec![f32::NAN; env.local_obs_dim()];
    env.write_local_obs(0, &mut obs).unwrap();
    obs[obs.len() - PATH_FEATURE_DIM..].to_vec()
}

#[test]
fn path_feature_points_around_the_wall_not_at_the_goal() {
    let path = ObsFeatures { path: true };
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
