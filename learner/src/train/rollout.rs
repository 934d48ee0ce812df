//! Playing a policy in fresh envs (greedy or sampled), for quick checks of
//! trained policies. The full evaluation protocol lives in `buridan-eval`.

use std::sync::Arc;

use buridan_actor::CollectError;
use buridan_env::{BatchedEnv, EnvConfig, EpisodeStats, Map, VecEnv, NUM_ACTIONS};
use buridan_mapf::shield::rollout::RolloutShield;
use buridan_policy::{ActMode, Inference, Policy};

/// Plays episodes 0, 1, …, `episodes` − 1 of `env`'s seed with `policy`
/// on `num_envs` parallel envs of `map`, choosing actions with `mode`;
/// returns their statistics in the order they end. Exactly those episodes
/// count, whichever order they end in, so short (solved) episodes are not
/// over-represented when envs run in parallel.
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
) -> Result<Vec<EpisodeStats>, CollectError> {
    rollout_through(policy, map, env, episodes, num_envs, mode, seed, None)
}

/// [`rollout`], through the collision shield `shield` where given, as the
/// evaluation's shielded controllers play a policy
/// (`shield-lanes=16:checkpoint:DIR` with
/// [`RolloutShield::with_one_way_lanes`]`(16)`): each step the policy
/// chooses under the wall mask, the shield makes one joint move of its
/// preferences, and a recurrent policy is fed the executed move as its
/// previous actions.
///
/// ```
/// use buridan_env::{EnvConfig, Map, Starts};
/// use buridan_learner::train::rollout::rollout_through;
/// use buridan_mapf::shield::rollout::RolloutShield;
/// use buridan_policy::{ActMode, ModelSpec, Mode, Policy};
/// let map = std::sync::Arc::new(Map::load("rm-1.1").unwrap());
/// let env = EnvConfig { agents: 2, starts: Starts::Fixed, t_max: 20, ..EnvConfig::default() };
/// let policy = Policy::new(ModelSpec::new(Mode::Ctde, 2, 129), 0).unwrap();
/// let shield = Some(RolloutShield::new(0).with_one_way_lanes(16));
/// let eps = rollout_through(&policy, map, env, 3, 2, ActMode::Greedy, 0, shield).unwrap();
/// assert_eq!(eps.len(), 3);
/// ```
#[allow(clippy::too_many_arguments)]
pub fn rollout_through(
    policy: &Policy,
    map: Arc<Map>,
    env: EnvConfig,
    episodes: usize,
    num_envs: usize,
    mode: ActMode,
    seed: u64,
    mut shield: Option<RolloutShield>,
) -> Result<Vec<EpisodeStats>, CollectError> {
    let kind = policy.spec().mode.obs_kind();
    let mut venv = VecEnv::new(map, env, num_envs.max(1), kind, 1)?;
    let rows = venv.rows();
    let heads = policy.spec().heads;
    let mut inf = Inference::new(policy.on_cpu()?, rows, seed);
    let mut actions = vec![0u8; rows * heads];
    let mut executed = vec![0u8; rows * heads];
    let mut walls = vec![0u8; rows * heads * NUM_ACTIONS];
    let mut logp = vec![0f32; rows];
    let mut row_rewards = vec![0f32; rows];
    let mut row_done = vec![0u8; rows];
    let mut out = Vec::with_capacity(episodes);
    let wanted = episodes as u64;
    while out.len() < episodes {
        let taken = match &mut shield {
            Some(shield) => {
                shield.write_masks(&venv, &mut walls)?;
                let logits = inf.act(venv.obs(), &walls, mode, &mut actions, &mut logp)?;
                shield.joint_move(&venv, &actions, logits, &walls, &mut executed)?;
                &executed
            }
            None => {
                inf.act(venv.obs(), venv.masks(), mode, &mut actions, &mut logp)?;
                &actions
            }
        };
        venv.step(taken)?;
        if let Some(st) = inf.state_mut() {
            venv.write_row_rewards(&mut row_rewards);
            venv.write_row_done(&mut row_done);
            st.observe(taken, &row_rewards, &row_done);
        }
        out.extend(
            venv.drain_episodes()
                .into_iter()
                .filter(|e| e.episode < wanted),
        );
    }
    Ok(out)
}
