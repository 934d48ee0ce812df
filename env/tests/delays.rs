//! Execution delays (`EnvConfig::delay`): each agent fails to carry out
//! its move with the configured probability, seeded, under both rule sets.

use std::sync::Arc;

use buridan_env::{EnvConfig, GridEnv, Map, Rules};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Plays `episodes` episodes of seeded random actions; returns every
/// step's positions, and the moves commanded and delayed.
fn play(cfg: EnvConfig, episodes: u64) -> (Vec<Vec<buridan_env::Cell>>, u32, u32) {
    let map = Arc::new(Map::load("rm-2.1").unwrap());
    let n = cfg.agents;
    let mut env = GridEnv::new(map, cfg).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let (mut trace, mut moves, mut delayed) = (Vec::new(), 0, 0);
    let mut rewards = vec![0.0; n];
    for episode in 0..episodes {
        env.reset_to(episode).unwrap();
        loop {
            let actions: Vec<u8> = (0..n).map(|_| rng.random_range(0..5)).collect();
            moves += actions.iter().filter(|&&a| a != 0).count() as u32;
            let out = env.step(&actions, &mut rewards).unwrap();
            trace.push(env.positions());
            if out.done() {
                delayed += env.delayed_moves();
                break;
            }
        }
    }
    (trace, moves, delayed)
}

fn config(rules: Rules, delay: f32, seed: u64) -> EnvConfig {
    EnvConfig {
        agents: 4,
        seed,
        delay,
        ..EnvConfig::for_rules(rules)
    }
}

#[test]
fn moves_fail_at_the_configured_rate_under_both_rule_sets() {
    for rules in [Rules::Thesis, Rules::Pogema] {
        let (_, moves, delayed) = play(config(rules, 0.25, 3), 40);
        let rate = delayed as f64 / moves as f64;
        assert!(moves > 10_000, "{rules:?}: {moves} moves");
        assert!((rate - 0.25).abs() < 0.02, "{rules:?}: rate {rate}");
        let (_, _, none) = play(config(rules, 0.0, 3), 40);
        assert_eq!(none, 0, "{rules:?}: no delays without the setting");
    }
}

#[test]
fn delays_are_seeded_and_change_what_happens() {
    let (a, ..) = play(config(Rules::Pogema, 0.3, 5), 4);
    let (b, ..) = play(config(Rules::Pogema, 0.3, 5), 4);
    assert_eq!(a, b, "the same seed replays the same delays");
    let (c, ..) = play(config(Rules::Pogema, 0.0, 5), 4);
    assert_ne!(a, c, "delays change the trajectories");
}

#[test]
fn a_delay_outside_zero_to_one_is_refused_naming_it() {
    let map = Arc::new(Map::load("rm-2.1").unwrap());
    for delay in [1.0, -0.1, f32::NAN] {
        let err = GridEnv::new(map.clone(), config(Rules::Thesis, delay, 0))
            .err()
            .unwrap_or_else(|| panic!("delay {delay} accepted"));
        assert!(
            err.to_string()
                .contains("delay must be a probability in [0, 1)"),
            "{err}"
        );
    }
    let cfg: EnvConfig = serde_json::from_str(r#"{"agents": 4}"#).unwrap();
    assert_eq!(cfg.delay, 0.0, "files without the key have no delays");
}
