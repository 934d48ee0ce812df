//! `PlantVecEnv` against the `BatchedEnv` contract: shapes, masks,
//! auto-reset, final observations, episode statistics.

mod common;

use std::sync::Arc;

use buridan_env::{BatchedEnv, ObsKind};
use buridan_plant::{Plant, PlantConfig, PlantEnv, PlantVecEnv};

fn cfg(agents: usize) -> PlantConfig {
    PlantConfig {
        agents,
        seed: 3,
        ..PlantConfig::default()
    }
}

#[test]
fn local_shapes_and_masks() {
    let plant = Arc::new(Plant::load("dissertation").unwrap());
    let venv = PlantVecEnv::new(plant, cfg(3), 2, ObsKind::Local).unwrap();
    assert_eq!(
        (
            venv.num_envs(),
            venv.agents(),
            venv.rows_per_env(),
            venv.rows()
        ),
        (2, 3, 3, 6)
    );
    assert_eq!((venv.obs_dim(), venv.mask_dim()), (11, 3));
    assert_eq!(venv.obs().len(), 6 * 11);
    assert_eq!(venv.masks().len(), 6 * 3);
    assert_eq!(
        (
            venv.rewards().len(),
            venv.terminated().len(),
            venv.truncated().len()
        ),
        (6, 2, 2)
    );
    // Agent ids in the first column, hold always legal.
    let ids: Vec<f32> = venv.obs().chunks(11).map(|row| row[0]).collect();
    assert_eq!(ids, vec![0.0, 1.0, 2.0, 0.0, 1.0, 2.0]);
    assert!(venv.masks().chunks(3).all(|m| m[0] == 1));
}

#[test]
fn central_shapes() {
    let plant = Arc::new(Plant::load("dissertation").unwrap());
    let mut venv = PlantVecEnv::new(plant, cfg(2), 3, ObsKind::Central).unwrap();
    assert_eq!(
        (venv.rows(), venv.obs_dim(), venv.mask_dim()),
        (3, 4 + 6 * 2, 6)
    );
    assert_eq!(venv.masks().len(), 3 * 6);
    venv.step(&[1u8; 6]).unwrap();
    let mut rows = [0.0f32; 3];
    venv.write_row_rewards(&mut rows);
    // A central row's reward is the sum over its agents.
    for (e, row) in rows.iter().enumerate() {
        let sum: f32 = venv.rewards()[e * 2..e * 2 + 2].iter().sum();
        assert!((row - sum).abs() < 1e-6);
    }
}

#[test]
fn extra_action_slots_are_masked_out() {
    let plant = Arc::new(Plant::load("dissertation").unwrap());
    let c = PlantConfig {
        action_slots: 5,
        ..cfg(2)
    };
    let venv = PlantVecEnv::new(plant, c, 1, ObsKind::Local).unwrap();
    assert_eq!(venv.mask_dim(), 5);
    assert!(venv
        .masks()
        .chunks(5)
        .all(|m| m[0] == 1 && m[3] == 0 && m[4] == 0));
}

#[test]
fn bad_actions_are_rejected_before_any_env_moves() {
    let plant = Arc::new(Plant::load("dissertation").unwrap());
    let mut venv = PlantVecEnv::new(plant, cfg(2), 2, ObsKind::Local).unwrap();
    let before = venv.obs().to_vec();
    assert!(venv.step(&[1, 1, 1]).is_err());
    assert!(venv.step(&[1, 1, 1, 4]).is_err());
    assert_eq!(venv.obs(), &before[..]);
    assert_eq!(venv.envs()[0].time(), 0);
}

#[test]
fn auto_reset_final_obs_and_episode_stats() {
    let plant = common::corridor(1, 1, 4, 10);
    let (n, envs) = (2, 3);
    let mut venv = PlantVecEnv::new(plant.clone(), cfg(n), envs, ObsKind::Local).unwrap();
    // Env e plays episode e first: its own start positions.
    let first: Vec<f32> = venv.obs().to_vec();
    let mut single = PlantEnv::with_episode(plant.clone(), cfg(n), 1).unwrap();
    let mut row = [0.0f32; 11];
    single.write_local_obs(0, &mut row).unwrap();
    assert_eq!(&first[n * 11..n * 11 + 11], &row[..]);
    for t in 1..=4 {
        venv.step(&vec![1u8; n * envs]).unwrap();
        let ended = t == 4;
        assert!(venv.truncated().iter().all(|&x| x == u8::from(ended)));
        assert!(venv.terminated().iter().all(|&x| x == 0));
        let mut done = vec![0u8; venv.rows()];
        venv.write_row_done(&mut done);
        assert!(done.iter().all(|&d| d == u8::from(ended)));
    }
    // The final observation is the last state of episode 1 (env 1) ...
    let mut rewards = [0.0f32; 2];
    for _ in 0..4 {
        single.step(&[1, 1], &mut rewards).unwrap();
    }
    single.write_local_obs(0, &mut row).unwrap();
    assert_eq!(&venv.final_obs()[n * 11..n * 11 + 11], &row[..]);
    // ... and the observation to act on is episode 1 + 3 = 4's first.
    let next = PlantEnv::with_episode(plant, cfg(n), 4).unwrap();
    next.write_local_obs(0, &mut row).unwrap();
    assert_eq!(&venv.obs()[n * 11..n * 11 + 11], &row[..]);
    assert_eq!(venv.envs()[1].episode(), 4);

    let stats = venv.drain_episodes();
    assert_eq!(
        stats.iter().map(|s| s.episode).collect::<Vec<_>>(),
        vec![0, 1, 2]
    );
    assert!(stats.iter().all(|s| s.length == 4 && !s.success));
    let kpis = venv.drain_kpis();
    assert_eq!(kpis.len(), 3);
    assert_eq!(kpis[1].reward, stats[1].reward);
    assert_eq!(kpis[1].steps, 4);
    assert!(venv.drain_episodes().is_empty());
}

#[test]
fn same_seed_same_batch() {
    let plant = Arc::new(Plant::load("hall").unwrap());
    let mut a = PlantVecEnv::new(plant.clone(), cfg(4), 2, ObsKind::Local).unwrap();
    let mut b = PlantVecEnv::new(plant.clone(), cfg(4), 2, ObsKind::Local).unwrap();
    for t in 0..50u8 {
        let actions: Vec<u8> = (0..8).map(|i| (t + i) % 3).collect();
        a.step(&actions).unwrap();
        b.step(&actions).unwrap();
    }
    assert_eq!(a.obs(), b.obs());
    let other =
        PlantVecEnv::new(plant, PlantConfig { seed: 4, ..cfg(4) }, 2, ObsKind::Local).unwrap();
    assert_ne!(
        other.obs(),
        PlantVecEnv::new(
            Arc::new(Plant::load("hall").unwrap()),
            cfg(4),
            2,
            ObsKind::Local
        )
        .unwrap()
        .obs()
    );
}

#[test]
fn normalized_observations_stay_near_the_unit_range() {
    let plant = Arc::new(Plant::load("dissertation").unwrap());
    let c = PlantConfig {
        normalize: true,
        ..cfg(4)
    };
    let mut venv = PlantVecEnv::new(plant, c, 2, ObsKind::Local).unwrap();
    for _ in 0..100 {
        venv.step(&[1u8; 8]).unwrap();
        assert!(
            venv.obs().iter().all(|&v| (-1.0..=1.0).contains(&v)),
            "{:?}",
            venv.obs()
        );
    }
}

#[test]
fn a_boxed_batch_is_a_batch() {
    let plant = Arc::new(Plant::load("dissertation").unwrap());
    let boxed: Box<dyn BatchedEnv + Send> =
        Box::new(PlantVecEnv::new(plant, cfg(2), 2, ObsKind::Local).unwrap());
    assert_eq!(boxed.rows(), 4);
}
