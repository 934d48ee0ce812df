//! What can go wrong while imitating: errors as data.

use buridan_env::EnvError;
use buridan_policy::PolicyError;

/// An imitation run that cannot start or continue.
///
/// ```
/// use buridan_imitate::ImitationError;
/// let e = ImitationError::Invalid { field: "rounds", problem: "must be at least 1".into() };
/// assert_eq!(e.to_string(), "rounds: must be at least 1");
/// ```
#[derive(Debug, thiserror::Error)]
pub enum ImitationError {
    /// A setting is out of range. The message names the key alone: the
    /// training config's error wraps it with its section, `[imitation]` or
    /// `[polish]`.
    #[error("{field}: {problem}")]
    Invalid {
        /// The setting (`rounds`, `expert`, ...).
        field: &'static str,
        /// What is wrong with it.
        problem: String,
    },
    /// The policy cannot be trained by behaviour cloning.
    #[error("imitation needs {needed}; this policy is {found}")]
    Unsupported {
        /// What imitation needs.
        needed: &'static str,
        /// What the policy is.
        found: String,
    },
    /// The environment refused a step or a reset.
    #[error(transparent)]
    Env(#[from] EnvError),
    /// The network failed.
    #[error(transparent)]
    Policy(#[from] PolicyError),
    /// A tensor operation failed.
    #[error("tensor: {0}")]
    Tensor(#[from] candle_core::Error),
    /// A shielded rollout step could not be made
    /// ([`crate::config::Rollout::Shielded`]).
    #[error("shielded rollout")]
    Shield(#[from] buridan_mapf::shield::rollout::RolloutShieldError),
    /// A thread of a sharded gradient step panicked.
    #[error(transparent)]
    Thread(#[from] buridan_policy::shards::SharePanicked),
}
