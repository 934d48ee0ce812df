//! The random controller: every AGV picks uniformly among its legal
//! actions (the env's mask), from a seeded stream.

use buridan_env::EnvError;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::env::{PlantEnv, NUM_ACTIONS};

/// Uniform choice among each AGV's legal actions.
///
/// ```
/// use std::sync::Arc;
/// use buridan_plant::{controllers::RandomController, Plant, PlantConfig, PlantEnv};
/// let plant = Arc::new(Plant::load("dissertation").unwrap());
/// let env = PlantEnv::new(plant, PlantConfig { agents: 3, ..Default::default() }).unwrap();
/// let mut actions = [0u8; 3];
/// RandomController::new(1).actions(&env, &mut actions).unwrap();
/// assert!(actions.iter().all(|&a| a < 3));
/// ```
#[derive(Debug, Clone)]
pub struct RandomController {
    rng: ChaCha8Rng,
}

impl RandomController {
    /// A controller drawing from the stream of evaluation seed `seed`
    /// ([`buridan_env::seed::random_controller`]).
    pub fn new(seed: u64) -> Self {
        Self {
            rng: ChaCha8Rng::seed_from_u64(buridan_env::seed::random_controller(seed)),
        }
    }

    /// A controller for episode `episode` of evaluation seed `seed`: its
    /// draws depend only on `(seed, episode)`, as the grid evaluation's
    /// random controller's do, whatever episodes ran before.
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_plant::{controllers::RandomController, Plant, PlantConfig, PlantEnv};
    /// let plant = Arc::new(Plant::load("dissertation").unwrap());
    /// let env = PlantEnv::new(plant, PlantConfig { agents: 4, ..Default::default() }).unwrap();
    /// let draw = |episode| {
    ///     let mut c = RandomController::for_episode(42, episode);
    ///     let mut actions = [0u8; 4];
    ///     (0..8).map(|_| { c.actions(&env, &mut actions).unwrap(); actions }).collect::<Vec<_>>()
    /// };
    /// assert_eq!(draw(3), draw(3));
    /// ```
    pub fn for_episode(seed: u64, episode: u64) -> Self {
        Self {
            rng: buridan_env::episode_rng(buridan_env::seed::random_controller(seed), episode),
        }
    }

    /// Writes one legal action per AGV of `env` into `out`.
    pub fn actions(&mut self, env: &PlantEnv, out: &mut [u8]) -> Result<(), EnvError> {
        if out.len() != env.agents() {
            return Err(EnvError::WrongLength {
                what: "actions",
                expected: env.agents(),
                got: out.len(),
            });
        }
        let mut mask = vec![0u8; env.config().action_slots];
        for (agent, action) in out.iter_mut().enumerate() {
            env.write_mask(agent, &mut mask)?;
            let legal: Vec<u8> = (0..NUM_ACTIONS as u8)
                .filter(|&a| mask[usize::from(a)] != 0)
                .collect();
            // Hold is always legal, so `legal` is never empty.
            *action = legal[self.rng.random_range(0..legal.len())];
        }
        Ok(())
    }
}
