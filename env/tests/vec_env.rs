//! VecEnv: auto-reset, final observations, episode indices, threading.

mod common;

use std::sync::Arc;

use buridan_env::{EnvConfig, EnvError, GridEnv, Map, ObsKind, VecEnv};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn local_obs_of(env: &GridEnv) -> (Vec<f32>, Vec<u8>) {
    let d = env.local_obs_dim();
    let mut obs = vec![0.0; d * env.agents()];
    let mut masks = vec![0; 5 * env.agents()];
    for i in 0..env.agents() {
        env.write_local_obs(i, &mut obs[i * d..(i + 1) * d])
            .unwrap();
        env.write_action_mask(i, &mut masks[i * 5..(i + 1) * 5])
            .unwrap();
    }
    (obs, masks)
}

fn central_obs_of(env: &GridEnv) -> (Vec<f32>, Vec<u8>) {
    let mut obs = vec![0.0; env.central_obs_dim()];
    let mut masks = vec![0; 5 * env.agents()];
    env.write_central_obs(&mut obs).unwrap();
    env.write_joint_mask(&mut masks).unwrap();
    (obs, masks)
}

fn obs_of(env: &GridEnv, kind: ObsKind) -> (Vec<f32>, Vec<u8>) {
    match kind {
        ObsKind::Local => local_obs_of(env),
        ObsKind::Central => central_obs_of(env),
    }
}

/// Steps a VecEnv and, beside it, plain GridEnvs playing the episodes the
/// VecEnv promises (env e: episodes e, e+N, ...), and compares everything.
fn mirror(kind: ObsKind, threads: usize) {
    let map = Arc::new(Map::load("rm-1.4").unwrap());
    let cfg = EnvConfig {
        agents: 3,
        t_max: 7,
        seed: 9,
        ..EnvConfig::default()
    };
    let (num_envs, n) = (3usize, 3usize);
    let mut venv = VecEnv::new(map.clone(), cfg.clone(), num_envs, kind, threads).unwrap();
    let mut plain: Vec<GridEnv> = (0..num_envs)
        .map(|e| GridEnv::with_episode(map.clone(), cfg.clone(), e as u64).unwrap())
        .collect();
    let rows = if kind == ObsKind::Local { n } else { 1 };
    let (od, md) = (venv.obs_dim(), venv.mask_dim());
    assert_eq!(md, if kind == ObsKind::Local { 5 } else { 5 * n });
    // Initial observations: the first episode of every env.
    for (e, env) in plain.iter().enumerate() {
        let (o, m) = obs_of(env, kind);
        assert_eq!(&venv.obs()[e * rows * od..(e + 1) * rows * od], &o[..]);
        assert_eq!(&venv.masks()[e * rows * md..(e + 1) * rows * md], &m[..]);
    }
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut expected_episodes = Vec::new();
    let mut ends = 0;
    for _ in 0..40 {
        let actions: Vec<u8> = (0..num_envs * n).map(|_| rng.random_range(0..5)).collect();
        venv.step(&actions).unwrap();
        for (e, env) in plain.iter_mut().enumerate() {
            let mut rewards = vec![0.0; n];
            let out = env
                .step(&actions[e * n..(e + 1) * n], &mut rewards)
                .unwrap();
            assert_eq!(&venv.rewards()[e * n..(e + 1) * n], &rewards[..]);
            assert_eq!(venv.terminated()[e], u8::from(out.terminated));
            assert_eq!(venv.truncated()[e], u8::from(out.truncated));
            let range = e * rows * od..(e + 1) * rows * od;
            if out.done() {
                ends += 1;
                let (last, _) = obs_of(env, kind);
                assert_eq!(
                    &venv.final_obs()[range.clone()],
                    &last[..],
                    "final obs of env {e}"
                );
                expected_episodes.push(env.stats());
                let next = env.episode() + num_envs as u64;
                *env = GridEnv::with_episode(map.clone(), cfg.clone(), next).unwrap();
            }
            let (o, m) = obs_of(env, kind);
            assert_eq!(&venv.obs()[range], &o[..], "obs of env {e}");
            assert_eq!(&venv.masks()[e * rows * md..(e + 1) * rows * md], &m[..]);
            assert_eq!(venv.envs()[e].episode(), env.episode());
            assert_eq!(venv.envs()[e].episode() % num_envs as u64, e as u64);
        }
    }
    assert!(ends >= 3 * 5, "t_max 7 over 40 steps: {ends} episode ends");
    assert_eq!(venv.drain_episodes(), expected_episodes);
    assert!(venv.drain_episodes().is_empty());
}

#[test]
fn local_vec_env_matches_plain_envs_with_auto_reset() {
    mirror(ObsKind::Local, 1);
}

#[test]
fn central_vec_env_matches_plain_envs_with_auto_reset() {
    mirror(ObsKind::Central, 1);
}

#[test]
fn two_threads_match_plain_envs_too() {
    mirror(ObsKind::Local, 2);
    mirror(ObsKind::Central, 2);
}

/// Observations, final observations, masks, rewards, terminated, truncated.
type Snapshot = (Vec<f32>, Vec<f32>, Vec<u8>, Vec<f32>, Vec<u8>, Vec<u8>);

/// Everything a VecEnv exposes after each of 50 random steps.
fn record(threads: usize, kind: ObsKind) -> Vec<Snapshot> {
    let map = Arc::new(Map::load("rm-2.1").unwrap());
    let cfg = EnvConfig {
        t_max: 20,
        seed: 3,
        ..EnvConfig::default()
    };
    let mut venv = VecEnv::new(map, cfg, 8, kind, threads).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let mut out = Vec::new();
    for _ in 0..50 {
        let actions: Vec<u8> = (0..8 * 4).map(|_| rng.random_range(0..5)).collect();
        venv.step(&actions).unwrap();
        out.push((
            venv.obs().to_vec(),
            venv.final_obs().to_vec(),
            venv.masks().to_vec(),
            venv.rewards().to_vec(),
            venv.terminated().to_vec(),
            venv.truncated().to_vec(),
        ));
    }
    let episodes = venv.drain_episodes();
    assert_eq!(episodes.len(), 8 * 2, "t_max 20, 50 steps");
    let mut indices: Vec<u64> = episodes.iter().map(|e| e.episode).collect();
    indices.sort();
    assert_eq!(indices, (0..16).collect::<Vec<_>>());
    out
}

#[test]
fn threads_2_gives_identical_results_to_threads_1() {
    for kind in [ObsKind::Local, ObsKind::Central] {
        assert!(record(1, kind) == record(2, kind), "{kind:?}");
    }
}

#[test]
fn vec_env_rejects_bad_actions_before_anything_moves() {
    let map = Arc::new(Map::load("rm-2.1").unwrap());
    let mut venv = VecEnv::new(map, EnvConfig::default(), 2, ObsKind::Local, 1).unwrap();
    let before = venv.obs().to_vec();
    let positions: Vec<_> = venv.envs().iter().map(|e| e.positions()).collect();
    let mut actions = vec![1u8; 8];
    actions[6] = 5;
    assert_eq!(
        venv.step(&actions),
        Err(EnvError::InvalidAction {
            agent: 2,
            action: 5
        })
    );
    assert_eq!(
        venv.step(&[0; 7]),
        Err(EnvError::WrongLength {
            what: "actions",
            expected: 8,
            got: 7
        })
    );
    assert_eq!(venv.obs(), &before[..]);
    let after: Vec<_> = venv.envs().iter().map(|e| e.positions()).collect();
    assert_eq!(after, positions);
    assert!(venv.envs().iter().all(|e| e.t() == 0));
}

#[test]
fn vec_env_shapes_and_visits() {
    let map = Arc::new(Map::load("rm-2.1").unwrap());
    let venv = VecEnv::new(map.clone(), EnvConfig::default(), 3, ObsKind::Local, 1).unwrap();
    assert_eq!(
        (
            venv.num_envs(),
            venv.agents(),
            venv.obs_dim(),
            venv.mask_dim()
        ),
        (3, 4, 129, 5)
    );
    assert_eq!(venv.obs().len(), 3 * 4 * 129);
    assert_eq!(venv.masks().len(), 3 * 4 * 5);
    assert_eq!(venv.rewards().len(), 12);
    assert_eq!(venv.kind(), ObsKind::Local);
    // Visits: the starts of the first episodes, 4 per env.
    assert_eq!(venv.visits().iter().sum::<u64>(), 12);
    let venv = VecEnv::new(map.clone(), EnvConfig::default(), 3, ObsKind::Central, 1).unwrap();
    assert_eq!((venv.obs_dim(), venv.mask_dim()), (9 * 200, 20));
    assert_eq!(venv.obs().len(), 3 * 9 * 200);
    assert!(matches!(
        VecEnv::new(map, EnvConfig::default(), 0, ObsKind::Local, 1),
        Err(EnvError::InvalidConfig(_))
    ));
}
