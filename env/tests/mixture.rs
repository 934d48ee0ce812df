//! Layout mixtures: weighted, seeded layout draws per episode; every
//! episode a valid episode of its layout; a batch of mixtures matches plain
//! envs playing the same episodes.

use std::sync::Arc;

use buridan_env::{
    episode_instance, EnvConfig, EnvError, GridEnv, LayoutMixture, Map, ObsKind, VecEnv,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn layouts(weighted: &[(&str, f64)]) -> Vec<(Arc<Map>, f64)> {
    weighted
        .iter()
        .map(|&(name, w)| (Arc::new(Map::load(name).unwrap()), w))
        .collect()
}

fn local_obs(env: &GridEnv) -> Vec<f32> {
    let d = env.local_obs_dim();
    let mut obs = vec![0.0; d * env.agents()];
    for i in 0..env.agents() {
        env.write_local_obs(i, &mut obs[i * d..(i + 1) * d])
            .unwrap();
    }
    obs
}

#[test]
fn layouts_are_drawn_with_their_weights() {
    let mix = LayoutMixture::new(
        &layouts(&[("rm-2.1", 1.0), ("rm-2.2", 2.0), ("rm-3.1", 3.0)]),
        EnvConfig {
            seed: 11,
            ..EnvConfig::default()
        },
        0,
    )
    .unwrap();
    let draws = 12_000;
    let mut counts = [0usize; 3];
    for k in 0..draws {
        counts[mix.layout_of(k)] += 1;
    }
    for (count, share) in counts.iter().zip([1.0 / 6.0, 2.0 / 6.0, 3.0 / 6.0]) {
        let got = *count as f64 / draws as f64;
        // The standard error is under 0.005: 0.02 is four of them.
        assert!((got - share).abs() < 0.02, "{counts:?}");
    }
    // A pure function of (seed, episode): the same answer every time…
    assert!((0..100).all(|k| mix.layout_of(k) == mix.layout_of(k)));
    // …and another seed draws another sequence.
    let other = LayoutMixture::new(
        &layouts(&[("rm-2.1", 1.0), ("rm-2.2", 2.0), ("rm-3.1", 3.0)]),
        EnvConfig {
            seed: 12,
            ..EnvConfig::default()
        },
        0,
    )
    .unwrap();
    assert!((0..100).any(|k| mix.layout_of(k) != other.layout_of(k)));
}

/// Steps a batch of mixtures with random actions and short episodes, and
/// checks every reset against a plain env of the drawn layout playing the
/// same episode.
#[test]
fn every_episode_is_a_valid_episode_of_its_drawn_layout() {
    let ls = layouts(&[("rm-2.2", 1.0), ("rm-3.1", 1.0), ("rm-2.1b", 2.0)]);
    let cfg = EnvConfig {
        t_max: 6,
        seed: 5,
        ..EnvConfig::default()
    };
    let (num_envs, n) = (16usize, cfg.agents);
    let mut venv = VecEnv::with_layouts(&ls, cfg.clone(), num_envs, ObsKind::Local, 1).unwrap();
    let d = venv.obs_dim();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut actions = vec![0u8; num_envs * n];
    let mut checked = [0usize; 3];
    for step in 0..600 {
        for (e, slot) in venv.envs().iter().enumerate() {
            let env = slot.env();
            if env.t() != 0 {
                continue;
            }
            let (l, k) = (slot.layout(), env.episode());
            assert_eq!(l, slot.layout_of(k));
            assert!(Arc::ptr_eq(env.map(), &ls[l].0), "layout {l}");
            let grid = &ls[l].0.grid;
            let scen = episode_instance(&ls[l].0, n, cfg.starts, cfg.seed, k).unwrap();
            assert_eq!(env.positions(), scen.starts);
            assert_eq!(env.goals(), scen.goals);
            for c in env.positions().iter().chain(&env.goals()) {
                assert!(
                    grid.contains(*c) && !grid.is_wall(*c),
                    "{c:?} on layout {l}"
                );
            }
            let plain = GridEnv::with_episode(ls[l].0.clone(), cfg.clone(), k).unwrap();
            assert_eq!(
                &venv.obs()[e * n * d..(e + 1) * n * d],
                &local_obs(&plain)[..],
                "env {e} episode {k} at step {step}"
            );
            checked[l] += 1;
        }
        actions.iter_mut().for_each(|a| *a = rng.random_range(0..5));
        venv.step(&actions).unwrap();
    }
    // 16 envs × 100 episodes each, drawn 1 : 1 : 2.
    assert!(checked.iter().sum::<usize>() >= 1600, "{checked:?}");
    assert!(
        checked[2] > checked[0] && checked[2] > checked[1],
        "{checked:?}"
    );
    let episodes = venv.drain_episodes();
    assert!(episodes.len() >= 1500);
    let mix = &venv.envs()[0];
    for ep in &episodes {
        assert_eq!(ep.layout as usize, mix.layout_of(ep.episode));
    }
}

#[test]
fn a_batch_of_mixtures_is_reproducible() {
    let run = || {
        let ls = layouts(&[("rm-2.1", 1.0), ("rm-3.1", 1.0)]);
        let cfg = EnvConfig {
            t_max: 10,
            seed: 8,
            ..EnvConfig::default()
        };
        let mut venv = VecEnv::with_layouts(&ls, cfg, 4, ObsKind::Local, 2).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut actions = vec![0u8; 16];
        for _ in 0..200 {
            actions.iter_mut().for_each(|a| *a = rng.random_range(0..5));
            venv.step(&actions).unwrap();
        }
        (venv.drain_episodes(), venv.obs().to_vec())
    };
    let (a, b) = (run(), run());
    assert!(a.0.len() >= 80);
    assert_eq!(a, b);
    assert!(a.0.iter().any(|e| e.layout == 0) && a.0.iter().any(|e| e.layout == 1));
}

#[test]
fn one_layout_plays_the_single_map_episodes() {
    let ls = layouts(&[("rm-2.1", 1.0)]);
    let cfg = EnvConfig {
        t_max: 5,
        ..EnvConfig::default()
    };
    let mut mixed = VecEnv::with_layouts(&ls, cfg.clone(), 3, ObsKind::Local, 1).unwrap();
    let mut plain = VecEnv::new(ls[0].0.clone(), cfg, 3, ObsKind::Local, 1).unwrap();
    let actions = [2u8, 4, 1, 3].repeat(3);
    for _ in 0..20 {
        mixed.step(&actions).unwrap();
        plain.step(&actions).unwrap();
        assert_eq!(mixed.obs(), plain.obs());
        assert_eq!(mixed.rewards(), plain.rewards());
    }
    assert_eq!(mixed.drain_episodes(), plain.drain_episodes());
}

#[test]
fn bad_mixtures_are_refused() {
    let cfg = EnvConfig::default();
    let invalid = |r: Result<LayoutMixture, EnvError>| match r {
        Err(EnvError::InvalidConfig(why)) => why,
        other => panic!("expected InvalidConfig, got {other:?}"),
    };
    assert!(invalid(LayoutMixture::new(&[], cfg.clone(), 0)).contains("at least one"));
    for w in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let why = invalid(LayoutMixture::new(
            &layouts(&[("rm-2.1", 1.0), ("rm-2.2", w)]),
            cfg.clone(),
            0,
        ));
        assert!(why.contains("rm-2.2") && why.contains("weight"), "{why}");
    }
    // 6 agents need 12 free cells; rm-1.1 has fewer.
    let crowded = EnvConfig {
        agents: 6,
        ..EnvConfig::default()
    };
    assert!(matches!(
        LayoutMixture::new(&layouts(&[("rm-2.1", 1.0), ("rm-1.1", 1.0)]), crowded, 0),
        Err(EnvError::TooFewFreeCells { .. })
    ));
    // Central observations of differently sized layouts cannot share a batch…
    let sizes = layouts(&[("rm-2.2", 1.0), ("rm-3.1", 1.0)]);
    let Err(EnvError::InvalidConfig(why)) =
        VecEnv::with_layouts(&sizes, cfg.clone(), 2, ObsKind::Central, 1)
    else {
        panic!("central observations of two sizes were accepted");
    };
    assert!(why.contains("different sizes"), "{why}");
    // …equally sized ones can, and local ones always.
    let same = layouts(&[("rm-2.1", 1.0), ("rm-2.1b", 1.0)]);
    VecEnv::with_layouts(&same, cfg.clone(), 2, ObsKind::Central, 1).unwrap();
    VecEnv::with_layouts(&sizes, cfg, 2, ObsKind::Local, 1).unwrap();
}
