//! The controller trait every evaluated policy implements, and the random one.

use buridan_env::{GridEnv, NUM_ACTIONS};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Why a controller gave up on an episode before acting.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum GiveUp {
    /// The per-instance time limit ran out.
    TimeLimit,
    /// The memory cap was reached.
    MemoryLimit,
    /// The instance has no solution.
    NoSolution,
    /// No plan is at most this many steps long (the steps left in the
    /// episode): the planner proved it.
    NoSolutionWithin(usize),
    /// Anything else, in words.
    Other(String),
}

impl std::fmt::Display for GiveUp {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            GiveUp::TimeLimit => f.write_str("time limit"),
            GiveUp::MemoryLimit => f.write_str("memory limit"),
            GiveUp::NoSolution => f.write_str("no solution"),
            GiveUp::NoSolutionWithin(steps) => write!(f, "no solution within {steps} steps"),
            GiveUp::Other(why) => f.write_str(why),
        }
    }
}

/// Something that drives all agents of a [`GridEnv`]: a planner, a random
/// controller or a trained policy. The harness times every call.
///
/// ```
/// use buridan_eval::{Controller, GiveUp};
/// struct Idle;
/// impl Controller for Idle {
///     fn name(&self) -> String { "idle".into() }
///     fn begin_episode(&mut self, _: &buridan_env::GridEnv) -> Result<(), GiveUp> { Ok(()) }
///     fn act(&mut self, _: &buridan_env::GridEnv, actions: &mut [u8]) { actions.fill(0) }
/// }
/// ```
pub trait Controller: Send {
    /// Name used in reports.
    fn name(&self) -> String;
    /// Prepares for the env's freshly reset episode (a planner plans here).
    fn begin_episode(&mut self, env: &GridEnv) -> Result<(), GiveUp>;
    /// Writes one action per agent for the env's current state.
    fn act(&mut self, env: &GridEnv, actions: &mut [u8]);
    /// Sees the per-agent rewards of the step just taken (recurrent policies
    /// feed them back as inputs).
    fn after_step(&mut self, _rewards: &[f32]) {}
    /// Extra per-episode facts (e.g. a planner's makespan), reported in the CSV.
    fn episode_notes(&self) -> PlanNotes {
        PlanNotes::default()
    }
    /// The observation features this controller reads from the env: a
    /// trained policy's, recorded in its checkpoint; none for planners.
    fn obs_features(&self) -> buridan_env::ObsFeatures {
        buridan_env::ObsFeatures::default()
    }
    /// The local window's radius this controller reads: a trained
    /// policy's, recorded in its checkpoint; the env's default otherwise.
    fn obs_sensor_range(&self) -> usize {
        buridan_env::EnvConfig::default().sensor_range
    }
    /// Whether this controller follows a plan made in `begin_episode` by
    /// the clock (a planner), rather than choosing each step's actions
    /// from the state (a policy, a shield). A closed-loop
    /// [`crate::fleet::FleetSession`] replans such a controller when the
    /// robots stop matching the plan or their goals change.
    fn follows_plan(&self) -> bool {
        false
    }
    /// Per agent, whether the last [`Controller::act`] changed the
    /// policy's own first choice (a policy through the shield,
    /// [`crate::shield`]); `None` for a controller without such a choice
    /// (a planner, a raw policy). A fleet service reports it per robot.
    fn overridden(&self) -> Option<&[bool]> {
        None
    }
}

/// Optional facts a planner reports about its plan.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct PlanNotes {
    /// Makespan of the plan, if one was found.
    pub plan_makespan: Option<u32>,
    /// Sum of costs of the plan, if one was found.
    pub plan_sum_of_costs: Option<u32>,
    /// Search nodes expanded.
    pub expanded: Option<u64>,
    /// Plans a rescuing controller followed to end a jam
    /// ([`crate::rescue`]).
    pub rescues: Option<u32>,
    /// Agent-steps whose executed action was not the policy's first
    /// choice: a policy through the collision shield ([`crate::shield`])
    /// counts every move the shield or its rules changed.
    pub overridden: Option<u32>,
}

/// Uniformly random legal actions (the action mask decides what is legal);
/// reproducible per episode from the seed.
pub struct RandomController {
    seed: u64,
    rng: ChaCha8Rng,
    mask: [u8; NUM_ACTIONS],
}

impl RandomController {
    /// A random controller whose draws in episode `e` depend only on `(seed, e)`.
    pub fn new(seed: u64) -> Self {
        Self {
            seed,
            rng: ChaCha8Rng::seed_from_u64(seed),
            mask: [1; NUM_ACTIONS],
        }
    }
}

impl Controller for RandomController {
    fn name(&self) -> String {
        "random".into()
    }

    fn begin_episode(&mut self, env: &GridEnv) -> Result<(), GiveUp> {
        self.rng = buridan_env::episode_rng(
            buridan_env::seed::random_controller(self.seed),
            env.episode(),
        );
        Ok(())
    }

    fn act(&mut self, env: &GridEnv, actions: &mut [u8]) {
        for (i, a) in actions.iter_mut().enumerate() {
            env.write_action_mask(i, &mut self.mask)
                .expect("mask buffer has 5 bytes");
            let legal = self.mask.iter().filter(|&&m| m == 1).count();
            let pick = self.rng.random_range(0..legal);
            *a = (0..NUM_ACTIONS as u8)
                .filter(|&k| self.mask[k as usize] == 1)
                .nth(pick)
                .unwrap_or(0);
        }
    }
}
