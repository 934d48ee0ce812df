//! Learning test: PPO, CTDE, reference model 1.1 with its fixed scenario and
//! 2 agents reaches episode reward 3 (both agents home; the maximum) with a
//! mean episode length of at most 12 (optimum 10 under the thesis rules)
//! within 200k env steps — SPEC §6: "all modes reach reward 3 with mean
//! length ≈ 11–12 within 200k (PPO)".
//!
//! Training stops once the last 100 training episodes (actions sampled, as
//! RLlib reports them) all reach reward 3 with mean length ≤ 13.5; the
//! trained policy executed greedily must then solve the scenario in ≤ 12
//! steps. (Sampling noise adds about two steps: measured runs reach sampled
//! lengths of 12–13.5 and greedy length 11 by 200k.)
//!
//! Hyperparameters: the dissertation's comparison config except the clip
//! ε = 0.2 (inside its search space {0.05, 0.1, 0.2, 0.3}); ε = 0.05 reaches
//! reward 3 only at ≈ 100k steps.

use std::sync::Arc;

use buridan_env::{Map, Starts};
use buridan_learner::train::rollout::rollout;
use buridan_learner::train::{
    env_config, final_checkpoint, train, Algorithm, MetricsRow, NoProgress, PpoConfig, RunConfig,
    Task, TrainConfig,
};
use buridan_policy::{ActMode, Mode, Policy};

#[test]
fn ppo_ctde_solves_rm_1_1_within_200k_steps() {
    buridan_policy::threads::pin_threads(1);
    let dir = tempfile::tempdir().unwrap();
    let cfg = TrainConfig {
        algorithm: Algorithm::Ppo(PpoConfig {
            clip: 0.2,
            ..PpoConfig::default()
        }),
        mode: Mode::Ctde,
        task: Task::Grid("rm-1.1".into()),
        agents: 2,
        starts: Starts::Fixed,
        run: RunConfig {
            steps: 200_000,
            seed: 1,
            checkpoint_every: 0,
            stop_return: Some(3.0),
            stop_len: Some(13.5),
            ..RunConfig::default()
        },
        ..TrainConfig::default()
    };
    let s = train(&cfg, dir.path(), &mut NoProgress).unwrap();
    eprintln!(
        "rm-1.1 PPO CTDE: {} env steps, {:.1} s, return {:.3}, success {:.2}, sampled length {:.2}",
        s.env_steps, s.wall_seconds, s.episode_return_mean, s.success_rate, s.episode_len_mean
    );
    assert!(s.env_steps <= 200_000);
    assert!(s.stopped_early, "no reward 3 within 200k steps: {s:?}");
    assert!(s.episode_return_mean >= 3.0 - 1e-6, "{s:?}");

    // Time to target: the first update of metrics.csv whose full 100-episode
    // window reaches each level, and held to the end (the run ends at 100 %).
    let rows: Vec<MetricsRow> = csv::Reader::from_path(dir.path().join("metrics.csv"))
        .unwrap()
        .deserialize()
        .map(Result::unwrap)
        .collect();
    assert_eq!(s.time_to_target.len(), 2, "{s:?}");
    for t in &s.time_to_target {
        let first = t.first.expect("the run ends at 100 % success");
        let expected = rows
            .iter()
            .find(|r| r.episodes >= 100 && r.success_rate >= t.success)
            .unwrap();
        assert_eq!(
            (first.update, first.env_steps),
            (expected.update, expected.env_steps)
        );
        assert!((first.wall_seconds - expected.wall_seconds).abs() < 1e-9);
        let held = t.held.expect("held at the end");
        let last_below = rows
            .iter()
            .rposition(|r| r.episodes < 100 || r.success_rate < t.success);
        let held_row = &rows[last_below.map_or(0, |i| i + 1)];
        assert_eq!(held.update, held_row.update);
        assert!(first.update <= held.update && held.env_steps <= s.env_steps);
    }

    let policy = Policy::load(&final_checkpoint(dir.path())).unwrap();
    let map = Arc::new(Map::load("rm-1.1").unwrap());
    let eps = rollout(&policy, map, env_config(&cfg, 0), 4, 4, ActMode::Greedy, 0).unwrap();
    let mean_len = eps.iter().map(|e| e.length as f64).sum::<f64>() / eps.len() as f64;
    eprintln!(
        "greedy: lengths {:?}",
        eps.iter().map(|e| e.length).collect::<Vec<_>>()
    );
    assert!(
        eps.iter()
            .all(|e| e.success && (e.reward - 3.0).abs() < 1e-6),
        "{eps:?}"
    );
    assert!(mean_len <= 12.0, "greedy mean length {mean_len}");
}
