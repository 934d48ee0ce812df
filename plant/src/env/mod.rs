//! [`PlantEnv`]: one plant episode — AGVs on the track network, sources,
//! units, the sink, the dispatcher, rewards and KPIs.
//!
//! One step is `episode.step` seconds (1 s). Its order: AGVs move (see
//! below); AGVs standing at their goal load or unload; units finish and
//! start processing; sources produce; AGVs without a task get one from the
//! dispatcher; the idle-unit penalty and the deadlock detector see the
//! state at the end of the step.
//!
//! **Movement.** Action 1 (forward) drives an AGV `speed · step` metres
//! along its route, the shortest track route to its goal; action 2
//! (backward) reverses it away from its goal: on a segment, against the
//! route's direction; at a junction into a dead-end siding (a dead end
//! without a station) if one leaves the junction, else onto the
//! lowest-index branch that is not the route's; it stops at dead ends. AGVs
//! never turn: an AGV without a goal reverses against the direction it last
//! drove forward. Any move stops at the AGV's goal node.
//!
//! **Contact and collisions.** AGVs are points on the track with a body of
//! `agv.length`; two touch when their track distance (shortest route along
//! the network, so junctions are shared) equals the length, and never come
//! closer: a move stops at the first touch. AGVs move one after another, a
//! follower after the AGV it follows (so queues move as trains), and in
//! index order where waiting goes in a circle. A move stopped by an AGV that
//! itself drives towards the mover is a **collision** of the mover, the
//! oncoming AGV (−1); both get it when both push. A move stopped by an AGV
//! that stands or drives away is a blocked move, not a collision.
//!
//! **Deadlocks.** An AGV *waits for* another when it has a goal, is not at
//! it and not handling, and the other touches it on its route ahead. A
//! cycle of waiting AGVs that has lasted `episode.deadlock_after` steps is
//! a deadlock (one event when it reaches that age; every step of it counts
//! as a deadlock step). The detector judges routes, not actions: two AGVs
//! facing each other on a lane and holding are deadlocked too.
//!
//! **Parts.** `track` holds the network's geometry: positions, distances,
//! routes and the pieces a move would drive. A step then runs, in order,
//! `motion` (the moves under the contact rule, collisions), `logistics`
//! (loading and unloading, units, sources, the dispatcher), the episode's
//! rewards and KPIs (here) and `deadlock` (the detector); `observe` writes
//! masks and observations of the state the step left.
//!
//! ```
//! use std::sync::Arc;
//! use buridan_plant::{Plant, PlantConfig, PlantEnv};
//! let plant = Arc::new(Plant::load("dissertation").unwrap());
//! let mut env = PlantEnv::new(plant, PlantConfig { agents: 2, ..PlantConfig::default() }).unwrap();
//! let mut rewards = [0.0f32; 2];
//! let out = env.step(&[1, 0], &mut rewards).unwrap();
//! assert!(!out.truncated);
//! assert_eq!(env.local_obs_dim(), 11);
//! ```

use std::sync::Arc;

use buridan_env::{episode_rng, EnvError};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use crate::kpi::Kpis;
use crate::plant::Plant;

mod agv;
mod deadlock;
mod logistics;
mod motion;
mod observe;
mod track;

pub use agv::{Agv, Load, Task};
pub use logistics::{SourceState, UnitState};
pub use motion::Preview;
pub use observe::{CENTRAL_PER_AGENT, LOCAL_OBS_DIM};
pub use track::TrackPos;

use logistics::{Handover, Stations};
use motion::Movement;
use track::{Piece, Track};

/// Actions per AGV: 0 hold, 1 forward, 2 backward.
pub const NUM_ACTIONS: usize = 3;
/// Stand still.
pub const HOLD: u8 = 0;
/// Drive along the route towards the goal.
pub const FORWARD: u8 = 1;
/// Reverse away from the goal.
pub const BACKWARD: u8 = 2;

/// Reward for delivering a finished product to the sink.
pub const REWARD_DELIVERY: f32 = 1.0;
/// Reward for picking up a product at a source.
pub const REWARD_PICKUP: f32 = 0.1;
/// Reward for placing a product in its unit.
pub const REWARD_PLACE: f32 = 0.1;
/// Reward per unit not working, per step, to every AGV.
pub const REWARD_IDLE_UNIT: f32 = -0.01;
/// Reward for a collision, to the oncoming AGV.
pub const REWARD_COLLISION: f32 = -1.0;

/// What one AGV can be rewarded in one step: at worst a collision while
/// both units stand idle (−1.02), at best a delivery (+1; an AGV hands over
/// at most one product per step). The learner checks rewards that actors
/// send from plant envs against it.
///
/// ```
/// let r = buridan_plant::env::step_reward_range();
/// assert!(r.contains(-1.02) && r.contains(1.0) && !r.contains(1.1));
/// ```
pub fn step_reward_range() -> buridan_env::RewardRange {
    // A plant has exactly two units (products A and B).
    buridan_env::RewardRange {
        min: REWARD_COLLISION + 2.0 * REWARD_IDLE_UNIT,
        max: REWARD_DELIVERY.max(REWARD_PICKUP).max(REWARD_PLACE),
    }
}

/// Positions within this many metres count as equal.
const EPS: f64 = 1e-9;

/// How a [`PlantEnv`] is run: agents, seed and observation options.
///
/// ```
/// let cfg = buridan_plant::PlantConfig { agents: 3, seed: 7, ..Default::default() };
/// assert_eq!(cfg.action_slots, 3);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct PlantConfig {
    /// AGVs (at most the plant's starts).
    pub agents: usize,
    /// Seed of the episode streams (start positions, arrivals).
    pub seed: u64,
    /// Scale observations to about [0, 1] (ids by agents, counts by
    /// capacities, positions by the plant's bounds, speed by the AGV speed,
    /// goal by 5, route length by the plant's diameter); raw physical units
    /// (as the dissertation's Plant Simulation interface gave them) if false.
    pub normalize: bool,
    /// Mask bytes per AGV: 3, or more to drive the plant with a policy built
    /// for more actions (the extra actions are always masked out).
    pub action_slots: usize,
}

impl Default for PlantConfig {
    fn default() -> Self {
        Self {
            agents: 2,
            seed: 0,
            normalize: false,
            action_slots: NUM_ACTIONS,
        }
    }
}

/// What one step produced.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct StepOutcome {
    /// The episode reached `t_max` in this step.
    pub truncated: bool,
}

/// One plant episode with `agents` AGVs.
#[derive(Debug, Clone)]
pub struct PlantEnv {
    track: Track,
    cfg: PlantConfig,
    episode: u64,
    rng: ChaCha8Rng,
    t: u32,
    agvs: Vec<Agv>,
    stations: Stations,
    kpis: Kpis,
    /// Per unit: steps it was working.
    working_steps: Vec<u32>,
    lead_time_sum: f64,
}

impl PlantEnv {
    /// Episode 0 of `plant` with `cfg`.
    pub fn new(plant: Arc<Plant>, cfg: PlantConfig) -> Result<Self, EnvError> {
        Self::with_episode(plant, cfg, 0)
    }

    /// Episode `episode` of `plant` with `cfg`: start positions and arrivals
    /// follow from (plant, agents, seed, episode).
    pub fn with_episode(
        plant: Arc<Plant>,
        cfg: PlantConfig,
        episode: u64,
    ) -> Result<Self, EnvError> {
        if cfg.agents == 0 || cfg.agents > plant.starts.len() {
            return Err(EnvError::InvalidConfig(format!(
                "plant '{}' has starts for 1 to {} AGVs, {} requested",
                plant.id,
                plant.starts.len(),
                cfg.agents
            )));
        }
        if cfg.action_slots < NUM_ACTIONS {
            return Err(EnvError::InvalidConfig(format!(
                "action_slots must be at least {NUM_ACTIONS}, got {}",
                cfg.action_slots
            )));
        }
        let mut env = Self {
            rng: episode_rng(cfg.seed, episode),
            track: Track::new(plant),
            cfg,
            episode,
            t: 0,
            agvs: Vec::new(),
            stations: Stations::default(),
            kpis: Kpis::default(),
            working_steps: Vec::new(),
            lead_time_sum: 0.0,
        };
        env.reset_to(episode);
        Ok(env)
    }

    /// Starts episode `episode` afresh.
    pub fn reset_to(&mut self, episode: u64) {
        self.episode = episode;
        self.rng = episode_rng(self.cfg.seed, episode);
        self.t = 0;
        let plant = self.track.plant.clone();
        let margin = plant.agv.length;
        self.agvs = (0..self.cfg.agents)
            .map(|i| {
                let seg = &plant.segments[plant.starts[i]];
                // Clear of both ends by one body length, so AGVs on
                // neighbouring start segments never touch.
                let span = seg.length - 2.0 * margin;
                let offset = margin + span * self.rng.random::<f64>();
                Agv::at(TrackPos {
                    segment: plant.starts[i],
                    offset,
                })
            })
            .collect();
        self.stations = Stations::new(&plant, &mut self.rng);
        self.working_steps = vec![0; plant.products.len()];
        self.lead_time_sum = 0.0;
        self.kpis = Kpis {
            episode,
            products_created: plant.products.iter().map(|p| p.source.initial).sum(),
            unit_utilisation: vec![0.0; plant.products.len()],
            ..Kpis::default()
        };
        self.stations.dispatch(&self.track, &mut self.agvs);
    }

    /// Starts the next episode of this env's sequence (`episode + stride`).
    pub fn reset_next(&mut self, stride: u64) {
        self.reset_to(self.episode + stride);
    }

    /// The plant.
    pub fn plant(&self) -> &Arc<Plant> {
        &self.track.plant
    }
    /// The configuration.
    pub fn config(&self) -> &PlantConfig {
        &self.cfg
    }
    /// Number of AGVs.
    pub fn agents(&self) -> usize {
        self.agvs.len()
    }
    /// The AGVs.
    pub fn agvs(&self) -> &[Agv] {
        &self.agvs
    }
    /// The sources (A, B).
    pub fn sources(&self) -> &[SourceState] {
        &self.stations.sources
    }
    /// The units (A, B).
    pub fn units(&self) -> &[UnitState] {
        &self.stations.units
    }
    /// Steps taken in this episode.
    pub fn time(&self) -> u32 {
        self.t
    }
    /// The episode index.
    pub fn episode(&self) -> u64 {
        self.episode
    }
    /// The episode has reached `t_max` (step again only after a reset).
    pub fn is_over(&self) -> bool {
        self.t >= self.track.plant.episode.t_max
    }

    /// Products delivered so far this episode: [`Self::kpis`]`().deliveries`
    /// without building the whole KPI record (per-step recorders call it).
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_plant::{Plant, PlantConfig, PlantEnv};
    /// let plant = Arc::new(Plant::load("dissertation").unwrap());
    /// let mut env = PlantEnv::new(plant, PlantConfig { agents: 1, ..Default::default() }).unwrap();
    /// env.step(&[0], &mut [0.0]).unwrap();
    /// assert_eq!(env.deliveries(), env.kpis().deliveries);
    /// ```
    pub fn deliveries(&self) -> u32 {
        self.kpis.deliveries
    }

    /// KPIs of the episode so far.
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_plant::{Plant, PlantConfig, PlantEnv};
    /// let plant = Arc::new(Plant::load("dissertation").unwrap());
    /// let mut env = PlantEnv::new(plant, PlantConfig { agents: 1, ..Default::default() }).unwrap();
    /// env.step(&[0], &mut [0.0]).unwrap();
    /// let k = env.kpis();
    /// assert_eq!((k.steps, k.deliveries, k.products_created), (1, 0, 2));
    /// ```
    pub fn kpis(&self) -> Kpis {
        let mut k = self.kpis.clone();
        k.steps = self.t;
        k.seconds = f64::from(self.t) * self.track.plant.episode.step;
        k.throughput_per_hour = if k.seconds > 0.0 {
            f64::from(k.deliveries) * 3600.0 / k.seconds
        } else {
            0.0
        };
        k.unit_utilisation = self
            .working_steps
            .iter()
            .map(|&w| {
                if self.t == 0 {
                    0.0
                } else {
                    f64::from(w) / f64::from(self.t)
                }
            })
            .collect();
        k.mean_lead_time = (k.deliveries > 0).then(|| self.lead_time_sum / f64::from(k.deliveries));
        k
    }

    /// Products inside the plant now: in source buffers, units and on AGVs.
    /// With the deliveries this always equals the products created.
    pub fn products_in_plant(&self) -> usize {
        self.stations
            .sources
            .iter()
            .map(|s| s.buffer.len())
            .sum::<usize>()
            + self
                .stations
                .units
                .iter()
                .map(UnitState::products)
                .sum::<usize>()
            + self.agvs.iter().filter(|a| a.load != Load::Empty).count()
    }

    /// Steps the plant one `episode.step` with one action per AGV (0 hold,
    /// 1 forward, 2 backward), writing each AGV's reward.
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_plant::{Plant, PlantConfig, PlantEnv};
    /// let plant = Arc::new(Plant::load("dissertation").unwrap());
    /// let mut env = PlantEnv::new(plant, PlantConfig { agents: 1, ..Default::default() }).unwrap();
    /// let mut rewards = [0.0];
    /// env.step(&[0], &mut rewards).unwrap();
    /// // Both units are empty: two idle units cost 0.01 each.
    /// assert!((rewards[0] + 0.02).abs() < 1e-6);
    /// ```
    pub fn step(&mut self, actions: &[u8], rewards: &mut [f32]) -> Result<StepOutcome, EnvError> {
        let n = self.agents();
        check_len("actions", n, actions.len())?;
        check_len("rewards", n, rewards.len())?;
        if let Some(agent) = actions.iter().position(|&a| usize::from(a) >= NUM_ACTIONS) {
            return Err(EnvError::InvalidConfig(format!(
                "agent {agent}: action {} is outside 0..3 (0 hold, 1 forward, 2 backward)",
                actions[agent]
            )));
        }
        if self.is_over() {
            return Err(EnvError::EpisodeOver);
        }
        rewards.fill(0.0);
        let events = Movement {
            track: &self.track,
            agvs: &mut self.agvs,
        }
        .run(actions);
        for (i, e) in events.iter().enumerate() {
            if e.collision {
                rewards[i] += REWARD_COLLISION;
                self.kpis.collisions += 1;
            }
            if e.blocked {
                self.kpis.blocked_moves += 1;
            }
        }
        let plant = &self.track.plant;
        let step = plant.episode.step;
        for agv in &mut self.agvs {
            agv.handling_left = (agv.handling_left - step).max(0.0);
        }
        self.t += 1;
        self.hand_over(rewards);
        let plant = &self.track.plant;
        self.stations.run_units(plant, self.t);
        self.kpis.products_created += self.stations.run_sources(plant, self.t, &mut self.rng);
        self.stations.dispatch(&self.track, &mut self.agvs);
        let idle = self
            .stations
            .units
            .iter()
            .filter(|u| u.processing.is_none())
            .count();
        for (p, unit) in self.stations.units.iter().enumerate() {
            if unit.processing.is_some() {
                self.working_steps[p] += 1;
            }
        }
        let penalty = REWARD_IDLE_UNIT * idle as f32;
        for r in rewards.iter_mut() {
            *r += penalty;
        }
        self.detect_deadlocks();
        self.kpis.reward += rewards.iter().sum::<f32>();
        Ok(StepOutcome {
            truncated: self.is_over(),
        })
    }

    /// Loads and unloads the AGVs standing at their goals, with the
    /// rewards and KPIs of each hand-over.
    fn hand_over(&mut self, rewards: &mut [f32]) {
        let plant = &self.track.plant;
        for (i, reward) in rewards.iter_mut().enumerate() {
            if self.agvs[i].is_handling() || !self.at_goal(i) {
                continue;
            }
            let Some(handover) = self.stations.hand_over(plant, &mut self.agvs[i]) else {
                continue;
            };
            match handover {
                Handover::Pickup => {
                    *reward += REWARD_PICKUP;
                    self.kpis.pickups += 1;
                }
                Handover::Place => {
                    *reward += REWARD_PLACE;
                    self.kpis.placements += 1;
                }
                Handover::Fetch => {}
                Handover::Delivery { created } => {
                    *reward += REWARD_DELIVERY;
                    self.kpis.deliveries += 1;
                    self.lead_time_sum += f64::from(self.t - created) * plant.episode.step;
                }
            }
            self.agvs[i].handling_left = plant.agv.handling_time;
        }
    }
}

fn check_len(what: &'static str, expected: usize, got: usize) -> Result<(), EnvError> {
    if expected != got {
        return Err(EnvError::WrongLength {
            what,
            expected,
            got,
        });
    }
    Ok(())
}
