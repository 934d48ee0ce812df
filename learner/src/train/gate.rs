//! Which experience the learner takes — one rule for every transport.
//!
//! PPO is on-policy: each published version asks for exactly one train
//! batch of env steps collected with it; experience of an older version is
//! *stale*, experience beyond the batch is *surplus*, and actors wait for
//! the next version. IMPALA is off-policy: any version at most
//! `max_policy_lag` updates old is taken.
//!
//! ```
//! use buridan_learner::train::gate::{Gate, Refusal, Staleness};
//! let mut gate = Gate::new(Staleness::OnPolicy);
//! gate.open(3, Some(100));
//! assert_eq!(gate.admit(3, 60), Ok(false)); // 40 steps still wanted
//! assert_eq!(gate.admit(3, 60), Ok(true)); // the batch is full: wait
//! assert_eq!(gate.admit(3, 60), Err(Refusal::Surplus { version: 3 }));
//! assert_eq!(gate.admit(2, 60), Err(Refusal::Stale { version: 2, current: 3 }));
//! ```

/// How old experience may be.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Staleness {
    /// Only the newest version's (PPO).
    OnPolicy,
    /// At most this many versions older than the newest (IMPALA).
    MaxLag(u64),
}

impl Staleness {
    /// Whether experience of policy `version` is too old for a learner at
    /// version `current`.
    pub fn is_stale(self, version: u64, current: u64) -> bool {
        let lag = current.saturating_sub(version);
        match self {
            Staleness::OnPolicy => lag > 0,
            Staleness::MaxLag(max) => lag > max,
        }
    }
}

/// Why experience was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Refusal {
    /// Collected with a version too old.
    #[error("stale: collected with policy version {version}, the learner is at {current}")]
    Stale {
        /// The fragment's version.
        version: u64,
        /// The learner's.
        current: u64,
    },
    /// The on-policy batch of this version is already full.
    #[error("surplus: the train batch of policy version {version} is already full")]
    Surplus {
        /// The fragment's version.
        version: u64,
    },
}

/// The newest version and how much experience it still wants.
#[derive(Debug, Clone)]
pub struct Gate {
    staleness: Staleness,
    version: u64,
    /// Env steps still wanted of `version`; `None`: no limit.
    remaining: Option<u64>,
}

impl Gate {
    /// A closed gate at version 0: nothing is admitted before [`Gate::open`].
    pub fn new(staleness: Staleness) -> Self {
        Self {
            staleness,
            version: 0,
            remaining: Some(0),
        }
    }

    /// The newest version is `version`; on-policy runs want `wanted_env_steps`
    /// of it (`None`: unlimited, as off-policy runs always are).
    pub fn open(&mut self, version: u64, wanted_env_steps: Option<u64>) {
        self.version = version;
        self.remaining = match self.staleness {
            Staleness::OnPolicy => wanted_env_steps,
            Staleness::MaxLag(_) => None,
        };
    }

    /// Admits no more experience (the run is over).
    pub fn close(&mut self) {
        self.remaining = Some(0);
    }

    /// The newest version.
    pub fn version(&self) -> u64 {
        self.version
    }

    /// Takes `env_steps` of experience collected with `version`; `Ok(true)`
    /// when that filled the on-policy batch (actors should wait).
    pub fn admit(&mut self, version: u64, env_steps: u64) -> Result<bool, Refusal> {
        if self.staleness.is_stale(version, self.version) {
            return Err(Refusal::Stale {
                version,
                current: self.version,
            });
        }
        match &mut self.remaining {
            None => Ok(false),
            Some(0) => Err(Refusal::Surplus { version }),
            Some(left) => {
                *left = left.saturating_sub(env_steps);
                Ok(*left == 0)
            }
        }
    }
}
