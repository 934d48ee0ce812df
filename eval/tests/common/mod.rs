//! What several test files share: the committed PPO policy and the seed-42
//! episodes in which it jams.

use std::path::PathBuf;
use std::sync::Arc;

use buridan_env::{EnvConfig, GridEnv, Map};
use buridan_eval::policy::PolicyController;
use buridan_policy::ActMode;

/// The committed PPO-CTDE checkpoint (rm-2.1, 4 agents; README "Learning").
pub fn committed_ppo_checkpoint() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fixtures/ppo-ctde-rm-2.1/checkpoint")
}

/// The committed policy with greedy actions, for 4 agents, seed 42.
pub fn committed_greedy_policy() -> Box<PolicyController> {
    Box::new(PolicyController::load(&committed_ppo_checkpoint(), 4, ActMode::Greedy, 42).unwrap())
}

/// Seed-42 episodes in which the committed policy's greedy actions end in
/// a jam (agents waiting on each other until T_max).
pub const JAMMED_EPISODES: [u64; 7] = [15, 17, 24, 43, 45, 51, 73];

/// The env of the committed policy's seed-42 evaluation: rm-2.1, 4 agents.
pub fn committed_ppo_env() -> GridEnv {
    let map = Arc::new(Map::load("rm-2.1").unwrap());
    let cfg = EnvConfig {
        agents: 4,
        seed: 42,
        ..EnvConfig::default()
    };
    GridEnv::new(map, cfg).unwrap()
}
