//! Rollouts through the PIBT collision shield: training the policy the way
//! it is deployed (`shield_rollouts = true`; CS-PIBT, Veerapaneni et al.,
//! ICAPS 2024).
//!
//! At execution a shielded policy's action probabilities become each
//! agent's preference order and PIBT turns them into one conflict-free
//! joint move (`buridan_eval::shield`). Trained without the shield, the
//! policy never meets it: a move into a cell another agent holds is masked
//! in training, so its logit — which the shield ranks — never learns
//! anything, and the policy cannot learn to rely on the shield's pushes.
//! A [`RolloutShield`] does in rollouts what the shield does at execution:
//!
//! 1. the policy acts under the wall mask ([`GridEnv::write_wall_mask`]):
//!    a move into a neighbour's cell is a legal request, "make way";
//! 2. each agent's sampled action leads its preference order, the others
//!    follow by logit ([`preference_orders`]);
//! 3. [`Shield`] turns the preferences into one joint move, which the env
//!    executes.
//!
//! The fragment keeps the sampled actions, their log-probabilities and the
//! wall masks: to the learner the shield is part of the env's dynamics, as
//! a blocked move is in plain rollouts.

use std::sync::Arc;

use super::{preference_orders, ActionOrder, Shield, ShieldError};
use buridan_env::{seed, BatchedEnv, EnvError, GridEnv, Map, NUM_ACTIONS};

/// Why a shielded rollout step could not be made.
#[derive(Debug, thiserror::Error)]
pub enum RolloutShieldError {
    /// The env is no grid world (a plant, an external simulator): the
    /// shield needs the grid, positions and goals.
    #[error("env {env} is no grid world: shielded rollouts need one")]
    NotAGrid {
        /// The env's index in the batch.
        env: usize,
    },
    /// The env refused to write a mask.
    #[error("the env failed")]
    Env(#[from] EnvError),
    /// The shield refused the state or the preferences.
    #[error("env {env}: the shield failed")]
    Shield {
        /// The env's index in the batch.
        env: usize,
        /// What the shield said.
        #[source]
        source: ShieldError,
    },
}

/// One env's shield and the episode it is on.
struct EnvShield {
    map: Arc<Map>,
    episode: u64,
    shield: Shield,
}

/// Turns a batch's sampled actions into shielded joint moves (see the
/// [module docs](self)). Flat buffers are env-major and agent-minor, as
/// the collector's: agent `i` of env `e` is entry `e · agents + i` (its
/// five logits and mask bytes start at five times that), for local rows
/// and central ones alike.
///
/// ```
/// use std::sync::Arc;
/// use buridan_mapf::shield::rollout::RolloutShield;
/// use buridan_env::{BatchedEnv, EnvConfig, Map, ObsKind, VecEnv};
/// let map = Arc::new(Map::load("rm-2.1").unwrap());
/// let mut venv = VecEnv::new(map, EnvConfig::default(), 2, ObsKind::Local, 1).unwrap();
/// let mut shield = RolloutShield::new(7);
/// let mut masks = vec![0u8; venv.rows() * 5];
/// shield.write_masks(&venv, &mut masks).unwrap();
/// // Every agent asks to stay: the joint move is everybody staying.
/// let (chosen, logits) = (vec![0u8; 8], vec![0f32; 40]);
/// let mut executed = vec![9u8; 8];
/// shield.joint_move(&venv, &chosen, &logits, &masks, &mut executed).unwrap();
/// assert_eq!(executed, vec![0u8; 8]);
/// venv.step(&executed).unwrap();
/// ```
pub struct RolloutShield {
    seed: u64,
    envs: Vec<Option<EnvShield>>,
    prefs: Vec<ActionOrder>,
    kind: Kind,
    /// Pushed agents step out of their pusher's way
    /// ([`Shield::with_stepping_aside`]).
    aside: bool,
}

/// Which shield a [`RolloutShield`] plays through, as the evaluation's
/// controllers of the same names build it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    /// `shield`: PIBT alone.
    Plain,
    /// `shield-settle=K`: goal settling with its progress fallback.
    Settling(u32),
    /// `shield-lanes=K`: the progress fallback, dead ends filled from the
    /// back, one-lane corridors kept one-way.
    Lanes(u32),
}

impl Kind {
    fn build(self, grid: &buridan_env::Grid, aside: bool) -> Shield {
        let shield = self.options(grid);
        if aside {
            shield.with_stepping_aside()
        } else {
            shield
        }
    }

    fn options(self, grid: &buridan_env::Grid) -> Shield {
        let shield = Shield::new(grid);
        match self {
            Kind::Plain => shield,
            Kind::Settling(patience) => shield.with_goal_settling(patience),
            Kind::Lanes(patience) => shield
                .with_progress_fallback(patience)
                .with_dead_end_order()
                .with_one_way_lanes(),
        }
    }
}

impl RolloutShield {
    /// A shield for a batch whose per-episode priority tie-breaks derive
    /// from `seed` (use a different one per actor).
    pub fn new(seed: u64) -> Self {
        Self {
            seed,
            envs: Vec::new(),
            prefs: Vec::new(),
            kind: Kind::Plain,
            aside: false,
        }
    }

    /// This shield with goal settling and its progress fallback after
    /// `patience` steps ([`Shield::with_goal_settling`]), as
    /// `shield-settle=PATIENCE` executes a policy.
    pub fn with_goal_settling(self, patience: u32) -> Self {
        Self {
            kind: Kind::Settling(patience),
            ..self
        }
    }

    /// This shield with its progress fallback after `patience` steps,
    /// dead-end aisles filled from the back and one-lane corridors kept
    /// one-way ([`Shield::with_one_way_lanes`]), as `shield-lanes=PATIENCE`
    /// executes a policy.
    pub fn with_one_way_lanes(self, patience: u32) -> Self {
        Self {
            kind: Kind::Lanes(patience),
            ..self
        }
    }

    /// This shield, whose pushed agents also step out of their pusher's
    /// way ([`Shield::with_stepping_aside`]): with
    /// [`Self::with_one_way_lanes`], as
    /// `shield[patience=PATIENCE,ordered,lanes,aside]` executes a policy.
    pub fn with_stepping_aside(self) -> Self {
        Self {
            aside: true,
            ..self
        }
    }

    /// Writes every agent's wall mask ([`GridEnv::write_wall_mask`]): the
    /// masks the policy acts under in shielded rollouts.
    pub fn write_masks<E: BatchedEnv + ?Sized>(
        &self,
        venv: &E,
        out: &mut [u8],
    ) -> Result<(), RolloutShieldError> {
        let n = venv.agents();
        for (e, env_masks) in out.chunks_mut(n * NUM_ACTIONS).enumerate() {
            let env = grid_env(venv, e)?;
            for (i, agent_mask) in env_masks.chunks_mut(NUM_ACTIONS).enumerate() {
                env.write_wall_mask(i, agent_mask)?;
            }
        }
        Ok(())
    }

    /// The joint move of every env: agent by agent, `chosen` leads the
    /// preference order and the other actions follow by `logits` (those
    /// `masks` allows first); PIBT resolves the preferences into
    /// `executed`, which the env carries out without a blocked move.
    pub fn joint_move<E: BatchedEnv + ?Sized>(
        &mut self,
        venv: &E,
        chosen: &[u8],
        logits: &[f32],
        masks: &[u8],
        executed: &mut [u8],
    ) -> Result<(), RolloutShieldError> {
        let n = venv.agents();
        self.envs.resize_with(venv.num_envs(), || None);
        for e in 0..venv.num_envs() {
            let env = grid_env(venv, e)?;
            let agents = e * n..(e + 1) * n;
            let moves = agents.start * NUM_ACTIONS..agents.end * NUM_ACTIONS;
            preference_orders(
                &chosen[agents.clone()],
                &logits[moves.clone()],
                &masks[moves],
                &mut self.prefs,
            );
            let shield = shield_for(
                &mut self.envs[e],
                self.seed,
                (self.kind, self.aside),
                e,
                env,
            );
            shield
                .step(
                    &env.positions(),
                    &env.goals(),
                    &self.prefs,
                    &mut executed[agents],
                )
                .map_err(|source| RolloutShieldError::Shield { env: e, source })?;
        }
        Ok(())
    }
}

/// Env `e`'s shield in `slot`, begun afresh when the env started another
/// episode (or, in a layout mixture, drew another map).
fn shield_for<'a>(
    slot: &'a mut Option<EnvShield>,
    seed: u64,
    (kind, aside): (Kind, bool),
    e: usize,
    env: &GridEnv,
) -> &'a mut Shield {
    let current = slot
        .as_ref()
        .is_some_and(|s| s.episode == env.episode() && Arc::ptr_eq(&s.map, env.map()));
    if !current {
        let mut shield = match slot.take() {
            Some(s) if Arc::ptr_eq(&s.map, env.map()) => s.shield,
            _ => kind.build(&env.map().grid, aside),
        };
        // Tie-breaks drawn per episode as the evaluation's shield draws
        // them, from the batch's seed and the env's index.
        let ties = seed::shield_ties(seed ^ e as u64, env.episode());
        shield.begin_episode(env.agents(), ties);
        *slot = Some(EnvShield {
            map: env.map().clone(),
            episode: env.episode(),
            shield,
        });
    }
    &mut slot.as_mut().expect("set above").shield
}

fn grid_env<E: BatchedEnv + ?Sized>(venv: &E, e: usize) -> Result<&GridEnv, RolloutShieldError> {
    venv.grid_env(e)
        .ok_or(RolloutShieldError::NotAGrid { env: e })
}

#[cfg(test)]
mod tests {
    use super::*;
    use buridan_env::{Cell, EnvConfig, Grid, ObsKind, Scenario, Starts, VecEnv};

    /// One env of two agents on `rows`, every episode starting from
    /// `starts` bound for `goals`.
    fn fixed_env(rows: &[&str], starts: [Cell; 2], goals: [Cell; 2], t_max: u32) -> VecEnv {
        let map = Arc::new(Map {
            name: "fixed".into(),
            grid: Grid::from_rows(rows).unwrap(),
            scenario: Some(Scenario {
                starts: starts.to_vec(),
                goals: goals.to_vec(),
            }),
        });
        let cfg = EnvConfig {
            agents: 2,
            starts: Starts::Fixed,
            t_max,
            ..EnvConfig::default()
        };
        VecEnv::new(map, cfg, 1, ObsKind::Local, 1).unwrap()
    }

    /// A corridor with a pocket above its second cell; agents 0 and 1 face
    /// each other, each bound for the other's side (a fixed scenario, so
    /// every episode starts so).
    fn face_to_face() -> VecEnv {
        fixed_env(
            &["@.@@", "...."],
            [Cell::new(1, 1), Cell::new(1, 2)],
            [Cell::new(1, 3), Cell::new(1, 0)],
            2,
        )
    }

    #[test]
    fn the_wall_mask_lets_an_agent_ask_for_its_neighbours_cell() {
        let venv = face_to_face();
        let mut masks = [0u8; 10];
        RolloutShield::new(0)
            .write_masks(&venv, &mut masks)
            .unwrap();
        // Agent 0 at (1, 1): stay, up (the pocket), right (agent 1), down
        // (the edge), left.
        assert_eq!(masks[..5], [1, 1, 1, 0, 1]);
        // Agent 1 at (1, 2): up is a wall; left is agent 0's cell.
        assert_eq!(masks[5..], [1, 0, 1, 0, 1]);
    }

    #[test]
    fn two_agents_pushing_into_each_other_get_a_joint_move_the_env_executes() {
        let mut venv = face_to_face();
        let mut shield = RolloutShield::new(3);
        let mut masks = [0u8; 10];
        shield.write_masks(&venv, &mut masks).unwrap();
        // Both ask for the other's cell; agent 0 would duck up next.
        let chosen = [2, 4];
        let logits = [0.0, 1.0, 5.0, -9.0, -1.0, 0.0, -9.0, -1.0, -9.0, 5.0];
        let mut executed = [9u8; 2];
        shield
            .joint_move(&venv, &chosen, &logits, &masks, &mut executed)
            .unwrap();
        assert_ne!(executed, chosen, "a swap is no legal joint move");
        let before = venv.grid_env(0).unwrap().positions();
        venv.step(&executed).unwrap();
        let after = venv.grid_env(0).unwrap().positions();
        // Whatever PIBT chose, the env carried it out: each agent moved
        // exactly where its executed action points (no blocked move).
        let grid = &venv.grid_env(0).unwrap().map().grid;
        for i in 0..2 {
            let target = grid.neighbour(before[i], executed[i]).unwrap_or(before[i]);
            assert_eq!(after[i], target, "agent {i} executed {}", executed[i]);
        }
        assert_ne!(before, after, "somebody made way");
    }

    #[test]
    fn a_plant_like_env_without_a_grid_is_refused_by_name() {
        struct NoGrid(VecEnv);
        impl BatchedEnv for NoGrid {
            fn num_envs(&self) -> usize {
                self.0.num_envs()
            }
            fn agents(&self) -> usize {
                self.0.agents()
            }
            fn kind(&self) -> ObsKind {
                self.0.kind()
            }
            fn obs_dim(&self) -> usize {
                self.0.obs_dim()
            }
            fn obs(&self) -> &[f32] {
                self.0.obs()
            }
            fn masks(&self) -> &[u8] {
                self.0.masks()
            }
            fn step(&mut self, actions: &[u8]) -> Result<(), EnvError> {
                self.0.step(actions)
            }
            fn rewards(&self) -> &[f32] {
                self.0.rewards()
            }
            fn terminated(&self) -> &[u8] {
                self.0.terminated()
            }
            fn truncated(&self) -> &[u8] {
                self.0.truncated()
            }
            fn final_obs(&self) -> &[f32] {
                self.0.final_obs()
            }
            fn drain_episodes(&mut self) -> Vec<buridan_env::EpisodeStats> {
                self.0.drain_episodes()
            }
        }
        let venv = NoGrid(face_to_face());
        let err = RolloutShield::new(0)
            .write_masks(&venv, &mut [0u8; 10])
            .unwrap_err();
        assert!(
            matches!(err, RolloutShieldError::NotAGrid { env: 0 }),
            "{err}"
        );
    }

    #[test]
    fn a_new_episode_begins_the_shield_afresh() {
        let mut venv = face_to_face();
        let mut shield = RolloutShield::new(1);
        let (mut masks, mut executed) = ([0u8; 10], [0u8; 2]);
        shield.write_masks(&venv, &mut masks).unwrap();
        shield
            .joint_move(&venv, &[0, 0], &[0.0; 10], &masks, &mut executed)
            .unwrap();
        let first = shield.envs[0].as_ref().unwrap().episode;
        assert_eq!(first, venv.grid_env(0).unwrap().episode());
        // Both stay until the time limit (2 steps) resets the env.
        venv.step(&executed).unwrap();
        venv.step(&executed).unwrap();
        assert_ne!(venv.grid_env(0).unwrap().episode(), first);
        shield
            .joint_move(&venv, &[0, 0], &[0.0; 10], &masks, &mut executed)
            .unwrap();
        assert_eq!(
            shield.envs[0].as_ref().unwrap().episode,
            venv.grid_env(0).unwrap().episode()
        );
    }

    /// The shield's doctest scene (`Shield::with_stepping_aside`) in an
    /// env: agent 1 rests on its goal at a lane's mouth, agent 0 above it
    /// is bound into the lane and pushes it.
    #[test]
    fn with_stepping_aside_a_pushed_agent_leaves_its_pushers_way() {
        let venv = fixed_env(
            &["@@@@..", "......"],
            [Cell::new(0, 4), Cell::new(1, 4)],
            [Cell::new(1, 0), Cell::new(1, 4)],
            EnvConfig::default().t_max,
        );
        // Agent 0 heads down (then left, stay, right, up); agent 1 would
        // rather stay (then left, up, right, down).
        let chosen = [3, 0];
        let logits = [3.0, 1.0, 2.0, 5.0, 4.0, 5.0, 3.0, 2.0, 1.0, 4.0];
        let pushed = |mut shield: RolloutShield| {
            let (mut masks, mut executed) = ([0u8; 10], [9u8; 2]);
            shield.write_masks(&venv, &mut masks).unwrap();
            // Agent 0's priority grows while it is off its goal; by the
            // third step it outranks agent 1.
            for _ in 0..3 {
                shield
                    .joint_move(&venv, &chosen, &logits, &masks, &mut executed)
                    .unwrap();
            }
            executed[1]
        };
        assert_eq!(pushed(RolloutShield::new(0)), 4, "into the lane");
        assert_eq!(
            pushed(RolloutShield::new(0).with_stepping_aside()),
            2,
            "aside, to the right"
        );
    }
}
