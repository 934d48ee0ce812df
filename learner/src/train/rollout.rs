//! Playing a policy in fresh envs (greedy or sampled), for quick checks of
//! trained policies. The full evaluation protocol lives in `buridan-eval`.

use std::sync::Arc;

use anyhow::Result;
use buridan_env::{EnvConfig, EpisodeStats, Map, ObsKind, VecEnv};
use buridan_policy::{ActMode, Inference, Policy};

/// Plays `episodes` episodes of `policy` on `num_envs` parallel envs of
/// `map` (episode indices 0, 1, … of `env`'s seed), choosing actions with
/// `mode`; returns the statistics of the first `episodes` episodes that end.
///
/// ```
/// use buridan_env::{EnvConfig, Map, Starts};
/// use buridan_learner::train::rollout::rollout;
/// use buridan_policy::{ActMode, ModelSpec, Mode, Policy};
/// let map = std::sync::Arc::new(Map::load("rm-1.1").unwrap());
/// let env = EnvConfig { agents: 2, starts: Starts::Fixed, t_max: 20, ..EnvConfig::default() };
/// let policy = Policy::new(ModelSpec::new(Mode::Ctde, 2, 129), 0).unwrap();
/// let eps = rollout(&policy, map, env, 3, 2, ActMode::Sample, 0).unwrap();
/// assert_eq!(eps.len(), 3);
/// ```
pub fn rollout(
    policy: &Policy,
    map: Arc<Map>,
    env: EnvConfig,
    episodes: usize,
    num_envs: usize,
    mode: ActMode,
    seed: u64,
) -> Result<Vec<EpisodeStats>> {
    let kind = policy.spec().mode.obs_kind();
    let n = env.agents;
    let mut venv = VecEnv::new(map, env, num_envs.max(1), kind, 1)?;
    let rows_per_env = match kind {
        ObsKind::Local => n,
        ObsKind::Central => 1,
    };
    let rows = venv.num_envs() * rows_per_env;
    let heads = policy.spec().heads;
    let mut inf = Inference::new(policy.clone(), rows, seed);
    let mut actions = vec![0u8; rows * heads];
    let mut logp = vec![0f32; rows];
    let mut row_rewards = vec![0f32; rows];
    let mut row_done = vec![0u8; rows];
    let mut out = Vec::with_capacity(episodes);
    while out.len() < episodes {
        inf.act(venv.obs(), venv.masks(), mode, &mut actions, &mut logp)?;
        venv.step(&actions)?;
        if inf.state().is_some() {
            let rewards = venv.rewards();
            for e in 0..venv.num_envs() {
                let done = u8::from(venv.terminated()[e] != 0 || venv.truncated()[e] != 0);
                for j in 0..rows_per_env {
                    let r = e * rows_per_env + j;
                    row_done[r] = done;
                    row_rewards[r] = match kind {
                        ObsKind::Local => rewards[r],
                        ObsKind::Central => rewards[e * n..(e + 1) * n].iter().sum(),
                    };
                }
            }
            if let Some(st) = inf.state_mut() {
                st.observe(&actions, &row_rewards, &row_done);
            }
        }
        out.extend(venv.drain_episodes());
    }
    out.truncate(episodes);
    Ok(out)
}
