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

use std::collections::VecDeque;
use std::sync::Arc;

use buridan_env::{episode_rng, EnvError};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use crate::kpi::Kpis;
use crate::plant::{Arrivals, Plant};

/// Actions per AGV: 0 hold, 1 forward, 2 backward.
pub const NUM_ACTIONS: usize = 3;
/// Stand still.
pub const HOLD: u8 = 0;
/// Drive along the route towards the goal.
pub const FORWARD: u8 = 1;
/// Reverse away from the goal.
pub const BACKWARD: u8 = 2;

/// Floats per local observation row: agent id, status of units A and B,
/// buffer counts of sources A and B, x, y, speed, goal, carrying flag,
/// remaining route length.
pub const LOCAL_OBS_DIM: usize = 11;
/// Floats per AGV in a central observation (x, y, speed, goal, carrying,
/// route length), after the 4 plant floats.
pub const CENTRAL_PER_AGENT: usize = 6;

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

/// A place on the track: a segment and the offset in metres from its
/// `from` node.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackPos {
    /// Segment index.
    pub segment: usize,
    /// Metres from the segment's `from` node.
    pub offset: f64,
}

/// What the dispatcher told an AGV to do next.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Task {
    /// Nothing to do (goal 0).
    Idle,
    /// Fetch a raw product from source `p`'s buffer (goal 4 or 5).
    FetchRaw(usize),
    /// Bring the raw product to unit `p` (goal 1 or 2).
    DropRaw(usize),
    /// Fetch a finished product from unit `p`'s output buffer (goal 1 or 2).
    FetchFinished(usize),
    /// Bring the finished product to the sink (goal 3).
    Deliver,
}

impl Task {
    /// The observation's goal code: 0 none, 1 unit A, 2 unit B, 3 sink,
    /// 4 buffer 1 (source A), 5 buffer 2 (source B).
    ///
    /// ```
    /// use buridan_plant::Task;
    /// assert_eq!((Task::FetchRaw(1).goal_code(), Task::FetchFinished(0).goal_code()), (5, 1));
    /// ```
    pub fn goal_code(self) -> u8 {
        match self {
            Task::Idle => 0,
            Task::DropRaw(p) | Task::FetchFinished(p) => 1 + p as u8,
            Task::Deliver => 3,
            Task::FetchRaw(p) => 4 + p as u8,
        }
    }
}

/// What an AGV carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Load {
    /// Nothing.
    Empty,
    /// An unprocessed product of type `product`, created at step `created`.
    Raw {
        /// Product index (0 = A, 1 = B).
        product: usize,
        /// Step the source produced it.
        created: u32,
    },
    /// A processed product.
    Finished {
        /// Product index.
        product: usize,
        /// Step the source produced it.
        created: u32,
    },
}

/// One AGV's state.
#[derive(Debug, Clone, PartialEq)]
pub struct Agv {
    /// Where it is.
    pub pos: TrackPos,
    /// Its current task (its goal).
    pub task: Task,
    /// What it carries.
    pub load: Load,
    /// Direction of its front on its segment: +1 towards `to`, −1 towards
    /// `from` (the direction it last drove forward).
    pub facing: f64,
    /// Seconds of loading/unloading left; it cannot move while positive.
    pub handling_left: f64,
    /// Signed speed of the last step in m/s: + forward, − backward.
    pub speed: f64,
    /// Consecutive steps it has waited for another AGV on its route.
    pub waiting_steps: u32,
}

/// A unit's state.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct UnitState {
    /// Creation steps of the products in the input buffer (FIFO).
    pub input: VecDeque<u32>,
    /// The product being processed: (creation step, time in seconds it is
    /// done).
    pub processing: Option<(u32, f64)>,
    /// A finished product waiting for room in the output buffer.
    pub finished_waiting: Option<u32>,
    /// Creation steps of the products in the output buffer.
    pub output: VecDeque<u32>,
}

impl UnitState {
    /// Products inside (buffers and machine).
    pub fn products(&self) -> usize {
        self.input.len()
            + self.output.len()
            + usize::from(self.processing.is_some())
            + usize::from(self.finished_waiting.is_some())
    }
}

/// A source's state.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SourceState {
    /// Creation steps of the products in the output buffer (FIFO).
    pub buffer: VecDeque<u32>,
    /// Time in seconds of the next arrival (pending while the buffer is full).
    pub next_arrival: f64,
}

/// What one step produced.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct StepOutcome {
    /// The episode reached `t_max` in this step.
    pub truncated: bool,
}

/// Where one step's move would take an AGV ([`PlantEnv::preview`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Preview {
    /// The position after the move.
    pub end: TrackPos,
    /// Segments driven on, in order (the current one first).
    pub segments: Vec<usize>,
    /// Nodes reached, in order.
    pub nodes: Vec<usize>,
}

/// One straight piece of a planned move: along `segment` from offset
/// `start` to `end`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Piece {
    segment: usize,
    start: f64,
    end: f64,
}

impl Piece {
    fn len(&self) -> f64 {
        (self.end - self.start).abs()
    }
    fn dir(&self) -> f64 {
        if self.end >= self.start {
            1.0
        } else {
            -1.0
        }
    }
}

/// Per-step events of one AGV, for rewards and KPIs.
#[derive(Debug, Clone, Copy, Default)]
struct StepEvents {
    collision: bool,
    blocked: bool,
}

/// One plant episode with `agents` AGVs.
#[derive(Debug, Clone)]
pub struct PlantEnv {
    plant: Arc<Plant>,
    cfg: PlantConfig,
    episode: u64,
    rng: ChaCha8Rng,
    t: u32,
    agvs: Vec<Agv>,
    sources: Vec<SourceState>,
    units: Vec<UnitState>,
    sidings: Vec<bool>,
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
        let sidings = siding_flags(&plant);
        let mut env = Self {
            rng: episode_rng(cfg.seed, episode),
            plant,
            cfg,
            episode,
            t: 0,
            agvs: Vec::new(),
            sources: Vec::new(),
            units: Vec::new(),
            sidings,
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
        let plant = self.plant.clone();
        let margin = plant.agv.length;
        self.agvs = (0..self.cfg.agents)
            .map(|i| {
                let seg = &plant.segments[plant.starts[i]];
                // Clear of both ends by one body length, so AGVs on
                // neighbouring start segments never touch.
                let span = seg.length - 2.0 * margin;
                let offset = margin + span * self.rng.random::<f64>();
                Agv {
                    pos: TrackPos {
                        segment: plant.starts[i],
                        offset,
                    },
                    task: Task::Idle,
                    load: Load::Empty,
                    facing: 1.0,
                    handling_left: 0.0,
                    speed: 0.0,
                    waiting_steps: 0,
                }
            })
            .collect();
        self.sources = plant
            .products
            .iter()
            .map(|p| SourceState {
                buffer: std::iter::repeat_n(0, p.source.initial as usize).collect(),
                next_arrival: 0.0,
            })
            .collect();
        for p in 0..plant.products.len() {
            self.sources[p].next_arrival = self.arrival_gap(p);
        }
        self.units = vec![UnitState::default(); plant.products.len()];
        self.working_steps = vec![0; plant.products.len()];
        self.lead_time_sum = 0.0;
        self.kpis = Kpis {
            episode,
            products_created: plant.products.iter().map(|p| p.source.initial).sum(),
            unit_utilisation: vec![0.0; plant.products.len()],
            ..Kpis::default()
        };
        self.dispatch();
    }

    /// Starts the next episode of this env's sequence (`episode + stride`).
    pub fn reset_next(&mut self, stride: u64) {
        self.reset_to(self.episode + stride);
    }

    /// Seconds to the next arrival at source `p`.
    fn arrival_gap(&mut self, p: usize) -> f64 {
        let source = &self.plant.products[p].source;
        match source.arrivals {
            Arrivals::Fixed => source.interarrival,
            Arrivals::Exponential => {
                let u: f64 = self.rng.random();
                -source.interarrival * (1.0 - u).ln()
            }
        }
    }

    /// The plant.
    pub fn plant(&self) -> &Arc<Plant> {
        &self.plant
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
        &self.sources
    }
    /// The units (A, B).
    pub fn units(&self) -> &[UnitState] {
        &self.units
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
        self.t >= self.plant.episode.t_max
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
        k.seconds = f64::from(self.t) * self.plant.episode.step;
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
        self.sources.iter().map(|s| s.buffer.len()).sum::<usize>()
            + self.units.iter().map(UnitState::products).sum::<usize>()
            + self.agvs.iter().filter(|a| a.load != Load::Empty).count()
    }

    /// Puts AGV `agent` at `pos` facing `facing` (+1 towards the segment's
    /// `to`), standing still; its task stays. For scripted scenarios and
    /// tests; the position must be on the segment and clear of the others.
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_plant::{Plant, PlantConfig, PlantEnv, TrackPos};
    /// let plant = Arc::new(Plant::load("dissertation").unwrap());
    /// let mut env = PlantEnv::new(plant.clone(), PlantConfig { agents: 1, ..Default::default() }).unwrap();
    /// let s1 = plant.segment_index("s1").unwrap();
    /// env.place_agv(0, TrackPos { segment: s1, offset: 4.0 }, 1.0).unwrap();
    /// assert_eq!(env.xy(env.agvs()[0].pos), (4.0, 20.0));
    /// ```
    pub fn place_agv(&mut self, agent: usize, pos: TrackPos, facing: f64) -> Result<(), EnvError> {
        let n = self.agents();
        let seg = self.plant.segments.get(pos.segment).ok_or_else(|| {
            EnvError::InvalidConfig(format!(
                "segment index {} of {}",
                pos.segment,
                self.plant.segments.len()
            ))
        })?;
        if agent >= n || !(0.0..=seg.length).contains(&pos.offset) {
            return Err(EnvError::InvalidConfig(format!(
                "cannot place AGV {agent} of {n} at offset {} of segment {} ({} m)",
                pos.offset, seg.id, seg.length
            )));
        }
        if let Some(other) = (0..n).find(|&j| {
            j != agent && self.track_distance(pos, self.agvs[j].pos) < self.contact() - EPS
        }) {
            return Err(EnvError::InvalidConfig(format!(
                "AGV {agent} at offset {} of segment {} would overlap AGV {other}",
                pos.offset, seg.id
            )));
        }
        let agv = &mut self.agvs[agent];
        agv.pos = pos;
        agv.facing = if facing < 0.0 { -1.0 } else { 1.0 };
        agv.speed = 0.0;
        Ok(())
    }

    /// Contact distance: two AGVs never come closer than this along the
    /// track.
    pub fn contact(&self) -> f64 {
        self.plant.agv.length
    }

    /// The node an AGV's task leads to, `None` when idle.
    pub fn goal_node(&self, agent: usize) -> Option<usize> {
        let p = &self.plant;
        match self.agvs.get(agent)?.task {
            Task::Idle => None,
            Task::FetchRaw(k) => Some(p.products[k].source_node),
            Task::DropRaw(k) | Task::FetchFinished(k) => Some(p.products[k].unit_node),
            Task::Deliver => Some(p.sink),
        }
    }

    /// The node `pos` stands on, if it stands on one.
    pub fn node_at(&self, pos: TrackPos) -> Option<usize> {
        let seg = &self.plant.segments[pos.segment];
        if pos.offset <= EPS {
            Some(seg.from)
        } else if pos.offset >= seg.length - EPS {
            Some(seg.to)
        } else {
            None
        }
    }

    /// x/y coordinates of a track position (linear between the nodes).
    pub fn xy(&self, pos: TrackPos) -> (f64, f64) {
        let seg = &self.plant.segments[pos.segment];
        let (a, b) = (&self.plant.nodes[seg.from], &self.plant.nodes[seg.to]);
        let f = (pos.offset / seg.length).clamp(0.0, 1.0);
        (a.x + f * (b.x - a.x), a.y + f * (b.y - a.y))
    }

    /// Track distance from `pos` to node `node`.
    pub fn distance_to_node(&self, pos: TrackPos, node: usize) -> f64 {
        let seg = &self.plant.segments[pos.segment];
        (pos.offset + self.plant.node_distance(seg.from, node))
            .min(seg.length - pos.offset + self.plant.node_distance(seg.to, node))
    }

    /// Track distance between two positions: the shortest way along the
    /// network.
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_plant::{Plant, PlantConfig, PlantEnv, TrackPos};
    /// let plant = Arc::new(Plant::load("dissertation").unwrap());
    /// let env = PlantEnv::new(plant.clone(), PlantConfig::default()).unwrap();
    /// let s2 = plant.segment_index("s2").unwrap(); // j1 -> j2, 15 m
    /// let s3 = plant.segment_index("s3").unwrap(); // j2 -> j3, 15 m
    /// let a = TrackPos { segment: s2, offset: 14.0 };
    /// let b = TrackPos { segment: s3, offset: 0.5 };
    /// assert!((env.track_distance(a, b) - 1.5).abs() < 1e-9);
    /// ```
    pub fn track_distance(&self, a: TrackPos, b: TrackPos) -> f64 {
        let sa = &self.plant.segments[a.segment];
        let mut d = a.offset + self.distance_to_node(b, sa.from);
        d = d.min(sa.length - a.offset + self.distance_to_node(b, sa.to));
        if a.segment == b.segment {
            d = d.min((a.offset - b.offset).abs());
        }
        d
    }

    /// Remaining route length of an AGV to its goal in metres (−1 without a
    /// goal).
    pub fn route_length(&self, agent: usize) -> f64 {
        match self.goal_node(agent) {
            Some(g) => self.distance_to_node(self.agvs[agent].pos, g),
            None => -1.0,
        }
    }

    /// The AGV stands at its goal node.
    pub fn at_goal(&self, agent: usize) -> bool {
        self.goal_node(agent)
            .is_some_and(|g| self.node_at(self.agvs[agent].pos) == Some(g))
    }

    /// The AGV is loading or unloading and cannot move.
    pub fn is_handling(&self, agent: usize) -> bool {
        self.agvs[agent].handling_left > EPS
    }

    /// Whether `segment` is a siding: it leads to a dead end without a
    /// station (where reversing AGVs go first).
    pub fn is_siding(&self, segment: usize) -> bool {
        self.sidings[segment]
    }

    /// The branch an AGV bound for `goal` takes when it reverses through
    /// node `node`: a dead-end siding if one leaves the node, else the
    /// lowest-index branch; never a branch of a shortest way to the goal
    /// (with loops there can be several) nor `came` (the segment it just
    /// drove along). `None` at a dead end.
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_plant::{Plant, PlantConfig, PlantEnv};
    /// let plant = Arc::new(Plant::load("dissertation").unwrap());
    /// let env = PlantEnv::new(plant.clone(), PlantConfig::default()).unwrap();
    /// let node = |id| plant.node_index(id).unwrap();
    /// let seg = |id| plant.segment_index(id).unwrap();
    /// // Bound for the sink, reversing at j2 goes into the siding p1 ...
    /// assert_eq!(env.escape_branch(node("j2"), Some(node("sink")), None), Some(seg("p1_spur")));
    /// // ... or, coming out of it, back west along s2.
    /// assert_eq!(env.escape_branch(node("j2"), Some(node("sink")), Some(seg("p1_spur"))), Some(seg("s2")));
    /// ```
    pub fn escape_branch(
        &self,
        node: usize,
        goal: Option<usize>,
        came: Option<usize>,
    ) -> Option<usize> {
        let plant = &self.plant;
        let towards_goal = |s: usize| {
            goal.is_some_and(|g| {
                let seg = &plant.segments[s];
                seg.length + plant.node_distance(seg.other(node), g)
                    <= plant.node_distance(node, g) + EPS
            })
        };
        plant
            .incident(node)
            .iter()
            .copied()
            .filter(|&s| Some(s) != came && !towards_goal(s))
            .min_by_key(|&s| (!self.sidings[s], s))
    }

    /// The route of an AGV from where it stands to its goal: the segments
    /// it will drive on (its current one first unless it stands on a node)
    /// and the nodes it will reach, goal last. Empty without a goal.
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_plant::{Plant, PlantConfig, PlantEnv};
    /// let plant = Arc::new(Plant::load("dissertation").unwrap());
    /// let env = PlantEnv::new(plant.clone(), PlantConfig { agents: 1, ..Default::default() }).unwrap();
    /// let (segments, nodes) = env.route(0);
    /// assert_eq!(nodes.last().copied(), env.goal_node(0));
    /// assert_eq!(segments.len(), nodes.len());
    /// ```
    pub fn route(&self, agent: usize) -> (Vec<usize>, Vec<usize>) {
        let (mut segments, mut nodes) = (Vec::new(), Vec::new());
        let Some(goal) = self.goal_node(agent) else {
            return (segments, nodes);
        };
        let pos = self.agvs[agent].pos;
        let mut at = match self.node_at(pos) {
            Some(n) => n,
            None => {
                let dir = self.route_direction(pos, goal);
                let seg = &self.plant.segments[pos.segment];
                segments.push(pos.segment);
                let end = if dir > 0.0 { seg.to } else { seg.from };
                nodes.push(end);
                end
            }
        };
        while at != goal {
            let Some(s) = self.plant.next_segment(at, goal) else {
                break;
            };
            segments.push(s);
            at = self.plant.segments[s].other(at);
            nodes.push(at);
        }
        (segments, nodes)
    }

    /// Direction (+1 towards `to`) of the shortest route to `goal` from a
    /// position inside a segment.
    fn route_direction(&self, pos: TrackPos, goal: usize) -> f64 {
        let seg = &self.plant.segments[pos.segment];
        let via_from = pos.offset + self.plant.node_distance(seg.from, goal);
        let via_to = seg.length - pos.offset + self.plant.node_distance(seg.to, goal);
        if via_from < via_to - EPS {
            -1.0
        } else {
            1.0
        }
    }

    /// The pieces an AGV would drive with `action` over `distance` metres
    /// if nobody were in the way, and its facing afterwards.
    fn plan(&self, agent: usize, action: u8, distance: f64) -> (Vec<Piece>, f64) {
        let agv = &self.agvs[agent];
        let goal = self.goal_node(agent);
        let mut pos = agv.pos;
        let mut facing = agv.facing;
        let mut left = distance;
        let mut pieces = Vec::new();
        let plant = &self.plant;
        // Bounded: each iteration drives to a node or ends the move, and a
        // move is a few segments long.
        for _ in 0..64 {
            if left <= EPS {
                break;
            }
            let dir;
            if let Some(n) = self.node_at(pos) {
                if Some(n) == goal && !pieces.is_empty() {
                    break;
                }
                let route_next = goal
                    .filter(|&g| g != n)
                    .and_then(|g| plant.next_segment(n, g));
                let leave = match action {
                    FORWARD => route_next,
                    // Reversing through a junction: not back onto the
                    // segment just driven (that would be driving forward);
                    // from a standstill any branch off the route will do.
                    _ => self.escape_branch(n, goal, (!pieces.is_empty()).then_some(pos.segment)),
                };
                let Some(s) = leave else {
                    break;
                };
                let seg = &plant.segments[s];
                pos = TrackPos {
                    segment: s,
                    offset: if seg.from == n { 0.0 } else { seg.length },
                };
                dir = if seg.from == n { 1.0 } else { -1.0 };
            } else {
                dir = match (action, goal) {
                    (FORWARD, Some(g)) => self.route_direction(pos, g),
                    (FORWARD, None) => break,
                    (_, Some(g)) if Some(g) != self.node_at(pos) => -self.route_direction(pos, g),
                    _ => -facing,
                };
            }
            let seg = &plant.segments[pos.segment];
            let end_offset = if dir > 0.0 { seg.length } else { 0.0 };
            let step = left.min((end_offset - pos.offset).abs());
            let end = pos.offset + dir * step;
            pieces.push(Piece {
                segment: pos.segment,
                start: pos.offset,
                end,
            });
            facing = if action == FORWARD { dir } else { -dir };
            left -= step;
            pos.offset = end;
            if step <= EPS {
                break;
            }
        }
        (pieces, facing)
    }

    /// Where a move with `action` would take AGV `agent` in one step if
    /// nobody were in the way: the end position, the segments driven on
    /// and the nodes reached, in order. A hold (or a handling AGV) stays.
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_plant::{Plant, PlantConfig, PlantEnv, FORWARD};
    /// let plant = Arc::new(Plant::load("dissertation").unwrap());
    /// let env = PlantEnv::new(plant, PlantConfig { agents: 1, ..Default::default() }).unwrap();
    /// let moved = env.preview(0, FORWARD);
    /// assert_eq!(moved.segments[0], env.agvs()[0].pos.segment);
    /// assert!((env.track_distance(env.agvs()[0].pos, moved.end) - 1.0).abs() < 1e-9);
    /// ```
    pub fn preview(&self, agent: usize, action: u8) -> Preview {
        let start = self.agvs[agent].pos;
        if action == HOLD || self.is_handling(agent) {
            return Preview {
                end: start,
                segments: vec![start.segment],
                nodes: Vec::new(),
            };
        }
        let distance = self.plant.agv.speed * self.plant.episode.step;
        let (pieces, _) = self.plan(agent, action, distance);
        let mut preview = Preview {
            end: start,
            segments: Vec::new(),
            nodes: Vec::new(),
        };
        for piece in &pieces {
            if preview.segments.last() != Some(&piece.segment) {
                preview.segments.push(piece.segment);
            }
            preview.end = TrackPos {
                segment: piece.segment,
                offset: piece.end,
            };
            if let Some(n) = self.node_at(preview.end) {
                if preview.nodes.last() != Some(&n) {
                    preview.nodes.push(n);
                }
            }
        }
        if preview.segments.is_empty() {
            preview.segments.push(start.segment);
        }
        preview
    }

    /// How far along `pieces` the AGV `agent` can drive before touching
    /// another AGV, and the first AGV it touches then.
    fn drivable(&self, agent: usize, pieces: &[Piece]) -> (f64, Option<usize>) {
        let contact = self.contact();
        let mut driven = 0.0;
        for piece in pieces {
            let seg = &self.plant.segments[piece.segment];
            let (len, dir) = (piece.len(), piece.dir());
            let mut allowed = len;
            let mut blocker = None;
            for (j, other) in self.agvs.iter().enumerate() {
                if j == agent {
                    continue;
                }
                // The distance to `other` is the minimum of linear
                // functions of the distance t driven on this piece; only
                // the falling ones can bring a touch.
                let q = other.pos;
                let via_from = self.distance_to_node(q, seg.from);
                let via_to = self.distance_to_node(q, seg.to);
                let mut falling: Vec<f64> = Vec::with_capacity(2);
                if dir < 0.0 {
                    falling.push(piece.start + via_from);
                } else {
                    falling.push(seg.length - piece.start + via_to);
                }
                if q.segment == piece.segment && dir * (q.offset - piece.start) >= -EPS {
                    falling.push(dir * (q.offset - piece.start));
                }
                for value in falling {
                    let t = (value - contact).max(0.0);
                    if t < allowed - EPS {
                        allowed = t;
                        blocker = Some(j);
                    }
                }
            }
            if blocker.is_some() {
                return (driven + allowed, blocker);
            }
            driven += len;
        }
        (driven, None)
    }

    /// Whether AGV `agent`, driving with `action`, moves towards `target`.
    fn approaches(&self, agent: usize, action: u8, target: TrackPos) -> bool {
        if action == HOLD || self.is_handling(agent) {
            return false;
        }
        let probe = 1e-3;
        let (pieces, _) = self.plan(agent, action, probe);
        let Some(last) = pieces.last() else {
            return false;
        };
        let moved = TrackPos {
            segment: last.segment,
            offset: last.end,
        };
        let driven: f64 = pieces.iter().map(Piece::len).sum();
        driven > probe / 2.0
            && self.track_distance(moved, target)
                < self.track_distance(self.agvs[agent].pos, target) - probe / 2.0
    }

    /// Drives `agent` `distance` metres along `pieces`, updating its
    /// position and facing.
    fn drive(&mut self, agent: usize, action: u8, pieces: &[Piece], distance: f64) {
        let mut left = distance;
        let agv = &mut self.agvs[agent];
        for piece in pieces {
            let len = piece.len();
            if left <= EPS && len > EPS {
                break;
            }
            let step = left.min(len);
            agv.pos = TrackPos {
                segment: piece.segment,
                offset: piece.start + piece.dir() * step,
            };
            agv.facing = if action == FORWARD {
                piece.dir()
            } else {
                -piece.dir()
            };
            left -= step;
        }
        let sign = if action == FORWARD { 1.0 } else { -1.0 };
        agv.speed = sign * distance / self.plant.episode.step;
    }

    /// Writes the action mask of `agent` (`action_slots` bytes): hold is
    /// always legal; forward when the AGV has a goal, is not at it and not
    /// handling; backward when not handling and not stuck at a dead end.
    /// Other AGVs do not mask anything: driving into them is the agent's
    /// mistake to learn.
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_plant::{Plant, PlantConfig, PlantEnv};
    /// let plant = Arc::new(Plant::load("dissertation").unwrap());
    /// let env = PlantEnv::new(plant, PlantConfig { agents: 1, ..Default::default() }).unwrap();
    /// let mut mask = [0u8; 3];
    /// env.write_mask(0, &mut mask).unwrap();
    /// assert_eq!(mask, [1, 1, 1]); // on the main line with a goal: all legal
    /// ```
    pub fn write_mask(&self, agent: usize, out: &mut [u8]) -> Result<(), EnvError> {
        check_len("mask bytes", self.cfg.action_slots, out.len())?;
        if agent >= self.agents() {
            return Err(EnvError::InvalidConfig(format!(
                "agent {agent} of {}",
                self.agents()
            )));
        }
        out.fill(0);
        out[usize::from(HOLD)] = 1;
        if self.is_handling(agent) {
            return Ok(());
        }
        let can = |action| {
            let (pieces, _) = self.plan(agent, action, 1e-3);
            pieces.iter().map(Piece::len).sum::<f64>() > 5e-4
        };
        out[usize::from(FORWARD)] =
            u8::from(self.goal_node(agent).is_some() && !self.at_goal(agent) && can(FORWARD));
        out[usize::from(BACKWARD)] = u8::from(can(BACKWARD));
        Ok(())
    }

    /// Floats per local observation row.
    pub fn local_obs_dim(&self) -> usize {
        LOCAL_OBS_DIM
    }

    /// Floats per central observation row: units' status, sources' counts,
    /// then per AGV x, y, speed, goal, carrying, route length.
    pub fn central_obs_dim(&self) -> usize {
        4 + CENTRAL_PER_AGENT * self.agents()
    }

    /// Writes the 4 plant floats: status of units A and B (1 working),
    /// buffer counts of sources A and B.
    fn write_plant_obs(&self, out: &mut [f32]) {
        for (p, unit) in self.units.iter().enumerate() {
            out[p] = f32::from(u8::from(unit.processing.is_some()));
        }
        for (p, source) in self.sources.iter().enumerate() {
            let count = source.buffer.len() as f32;
            let scale = if self.cfg.normalize {
                self.plant.products[p].source.capacity as f32
            } else {
                1.0
            };
            out[2 + p] = count / scale;
        }
    }

    /// Writes the 6 per-AGV floats: x, y, speed, goal, carrying, route length.
    fn write_agv_obs(&self, agent: usize, out: &mut [f32]) {
        let agv = &self.agvs[agent];
        let (x, y) = self.xy(agv.pos);
        let route = self.route_length(agent);
        let goal = f64::from(agv.task.goal_code());
        let carrying = f64::from(u8::from(agv.load != Load::Empty));
        let values = if self.cfg.normalize {
            let (x0, y0, x1, y1) = self.plant.bounds();
            let route = if route < 0.0 {
                -1.0
            } else {
                route / self.plant.diameter().max(EPS)
            };
            [
                (x - x0) / (x1 - x0).max(EPS),
                (y - y0) / (y1 - y0).max(EPS),
                agv.speed / self.plant.agv.speed,
                goal / 5.0,
                carrying,
                route,
            ]
        } else {
            [x, y, agv.speed, goal, carrying, route]
        };
        for (o, v) in out.iter_mut().zip(values) {
            *o = v as f32;
        }
    }

    /// Writes the local observation of `agent` ([`LOCAL_OBS_DIM`] floats):
    /// agent id, status of units A and B, buffer counts of sources A and B,
    /// x, y, speed, goal code, carrying flag, remaining route length.
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_plant::{Plant, PlantConfig, PlantEnv};
    /// let plant = Arc::new(Plant::load("dissertation").unwrap());
    /// let env = PlantEnv::new(plant, PlantConfig { agents: 2, ..Default::default() }).unwrap();
    /// let mut obs = [0.0f32; 11];
    /// env.write_local_obs(1, &mut obs).unwrap();
    /// assert_eq!(obs[0], 1.0); // agent id
    /// assert_eq!((obs[3], obs[4]), (1.0, 1.0)); // one product in each source buffer
    /// ```
    pub fn write_local_obs(&self, agent: usize, out: &mut [f32]) -> Result<(), EnvError> {
        check_len("observation floats", LOCAL_OBS_DIM, out.len())?;
        if agent >= self.agents() {
            return Err(EnvError::InvalidConfig(format!(
                "agent {agent} of {}",
                self.agents()
            )));
        }
        out[0] = if self.cfg.normalize {
            agent as f32 / (self.agents().max(2) - 1) as f32
        } else {
            agent as f32
        };
        self.write_plant_obs(&mut out[1..5]);
        self.write_agv_obs(agent, &mut out[5..]);
        Ok(())
    }

    /// Writes the central observation ([`PlantEnv::central_obs_dim`] floats).
    pub fn write_central_obs(&self, out: &mut [f32]) -> Result<(), EnvError> {
        check_len("observation floats", self.central_obs_dim(), out.len())?;
        self.write_plant_obs(&mut out[..4]);
        for (i, chunk) in out[4..].chunks_mut(CENTRAL_PER_AGENT).enumerate() {
            self.write_agv_obs(i, chunk);
        }
        Ok(())
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
        let events = self.move_agvs(actions);
        for (i, e) in events.iter().enumerate() {
            if e.collision {
                rewards[i] += REWARD_COLLISION;
                self.kpis.collisions += 1;
            }
            if e.blocked {
                self.kpis.blocked_moves += 1;
            }
        }
        let step = self.plant.episode.step;
        for agv in &mut self.agvs {
            agv.handling_left = (agv.handling_left - step).max(0.0);
        }
        self.t += 1;
        self.transfer(rewards);
        self.run_units();
        self.run_sources();
        self.dispatch();
        let idle = self.units.iter().filter(|u| u.processing.is_none()).count();
        for (p, unit) in self.units.iter().enumerate() {
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

    /// Moves every AGV by its action; see the module docs for the order.
    fn move_agvs(&mut self, actions: &[u8]) -> Vec<StepEvents> {
        let n = self.agents();
        let distance = self.plant.agv.speed * self.plant.episode.step;
        let plans: Vec<(Vec<Piece>, f64)> = (0..n)
            .map(|i| {
                if actions[i] == HOLD || self.is_handling(i) {
                    (Vec::new(), self.agvs[i].facing)
                } else {
                    self.plan(i, actions[i], distance)
                }
            })
            .collect();
        let mut events = vec![StepEvents::default(); n];
        let mut done: Vec<bool> = plans.iter().map(|(p, _)| p.is_empty()).collect();
        for (i, agv) in self.agvs.iter_mut().enumerate() {
            if done[i] {
                agv.speed = 0.0;
            }
        }
        while let Some(first_open) = done.iter().position(|d| !d) {
            let mut progress = false;
            for i in 0..n {
                if done[i] {
                    continue;
                }
                let (_, blocker) = self.drivable(i, &plans[i].0);
                // A follower waits for the AGV ahead to move first.
                if blocker.is_some_and(|j| !done[j]) {
                    continue;
                }
                events[i] = self.execute(i, actions, &plans[i].0);
                done[i] = true;
                progress = true;
            }
            if !progress {
                // Everyone left waits for someone else in a circle (head-on
                // pairs, rings): the lowest index moves against the others'
                // current positions.
                events[first_open] = self.execute(first_open, actions, &plans[first_open].0);
                done[first_open] = true;
            }
        }
        events
    }

    /// Drives `agent` as far as its plan and the others allow.
    fn execute(&mut self, agent: usize, actions: &[u8], pieces: &[Piece]) -> StepEvents {
        let (driven, blocker) = self.drivable(agent, pieces);
        self.drive(agent, actions[agent], pieces, driven);
        match blocker {
            Some(j) => StepEvents {
                collision: self.approaches(j, actions[j], self.agvs[agent].pos),
                blocked: true,
            },
            None => StepEvents::default(),
        }
    }

    /// Loads and unloads the AGVs standing at their goals.
    fn transfer(&mut self, rewards: &mut [f32]) {
        let handling = self.plant.agv.handling_time;
        for (i, reward) in rewards.iter_mut().enumerate() {
            if self.is_handling(i) || !self.at_goal(i) {
                continue;
            }
            let now = self.t;
            let agv = &mut self.agvs[i];
            let done = match agv.task {
                Task::Idle => false,
                Task::FetchRaw(p) => match self.sources[p].buffer.pop_front() {
                    Some(created) => {
                        agv.load = Load::Raw {
                            product: p,
                            created,
                        };
                        agv.task = Task::DropRaw(p);
                        *reward += REWARD_PICKUP;
                        self.kpis.pickups += 1;
                        true
                    }
                    None => {
                        // Not reachable while claims are honoured; never
                        // leave the AGV stuck on a vanished product.
                        agv.task = Task::Idle;
                        false
                    }
                },
                Task::DropRaw(p) => {
                    let unit = &mut self.units[p];
                    let room =
                        (unit.input.len() as u32) < self.plant.products[p].unit.input_capacity;
                    match agv.load {
                        Load::Raw { created, .. } if room => {
                            unit.input.push_back(created);
                            agv.load = Load::Empty;
                            agv.task = Task::Idle;
                            *reward += REWARD_PLACE;
                            self.kpis.placements += 1;
                            true
                        }
                        // A full input buffer: wait at the unit.
                        _ => false,
                    }
                }
                Task::FetchFinished(p) => match self.units[p].output.pop_front() {
                    Some(created) => {
                        agv.load = Load::Finished {
                            product: p,
                            created,
                        };
                        agv.task = Task::Deliver;
                        true
                    }
                    None => {
                        agv.task = Task::Idle;
                        false
                    }
                },
                Task::Deliver => match agv.load {
                    Load::Finished { created, .. } => {
                        agv.load = Load::Empty;
                        agv.task = Task::Idle;
                        *reward += REWARD_DELIVERY;
                        self.kpis.deliveries += 1;
                        self.lead_time_sum += f64::from(now - created) * self.plant.episode.step;
                        true
                    }
                    _ => {
                        agv.task = Task::Idle;
                        false
                    }
                },
            };
            if done {
                agv.handling_left = handling;
            }
        }
    }

    /// Units finish products, pass them to their output buffers and start
    /// the next, as often as the step's end time allows.
    fn run_units(&mut self) {
        let now = f64::from(self.t) * self.plant.episode.step;
        for (p, unit) in self.units.iter_mut().enumerate() {
            let params = &self.plant.products[p].unit;
            loop {
                if let Some((created, done_at)) = unit.processing {
                    if done_at > now + EPS || unit.finished_waiting.is_some() {
                        break;
                    }
                    unit.processing = None;
                    unit.finished_waiting = Some(created);
                }
                if let Some(created) = unit.finished_waiting {
                    if (unit.output.len() as u32) < params.output_capacity {
                        unit.output.push_back(created);
                        unit.finished_waiting = None;
                    }
                }
                if unit.processing.is_none() && unit.finished_waiting.is_none() {
                    if let Some(created) = unit.input.pop_front() {
                        unit.processing = Some((created, now + params.process_time));
                        continue;
                    }
                }
                break;
            }
        }
    }

    /// Sources produce the products due by the end of the step; a full
    /// buffer holds the next product back until there is room.
    fn run_sources(&mut self) {
        let now = f64::from(self.t) * self.plant.episode.step;
        for p in 0..self.sources.len() {
            let capacity = self.plant.products[p].source.capacity as usize;
            // Bounded: at most a buffer's worth of arrivals per step.
            for _ in 0..=capacity {
                let source = &self.sources[p];
                if source.next_arrival > now + EPS || source.buffer.len() >= capacity {
                    break;
                }
                let t = self.t;
                self.sources[p].buffer.push_back(t);
                self.kpis.products_created += 1;
                let gap = self.arrival_gap(p);
                let source = &mut self.sources[p];
                // Time lost while the buffer was full is not made up.
                source.next_arrival = source.next_arrival.max(now - self.plant.episode.step) + gap;
            }
        }
    }

    /// Hands every idle AGV its next task: the nearest unclaimed finished
    /// product in a unit's output buffer; else the nearest unclaimed raw
    /// product whose unit has input room for it (counting products already
    /// on their way there); else nothing.
    fn dispatch(&mut self) {
        for i in 0..self.agents() {
            if self.agvs[i].task != Task::Idle {
                continue;
            }
            match self.agvs[i].load {
                Load::Raw { product, .. } => {
                    self.agvs[i].task = Task::DropRaw(product);
                    continue;
                }
                Load::Finished { .. } => {
                    self.agvs[i].task = Task::Deliver;
                    continue;
                }
                Load::Empty => {}
            }
            let claimed = |task: Task| self.agvs.iter().filter(|a| a.task == task).count();
            let pos = self.agvs[i].pos;
            let products = 0..self.plant.products.len();
            let finished = products
                .clone()
                .filter(|&p| self.units[p].output.len() > claimed(Task::FetchFinished(p)))
                .map(|p| {
                    (
                        self.distance_to_node(pos, self.plant.products[p].unit_node),
                        Task::FetchFinished(p),
                    )
                });
            let raw = products
                .filter(|&p| {
                    let bound = claimed(Task::FetchRaw(p)) + claimed(Task::DropRaw(p));
                    self.sources[p].buffer.len() > claimed(Task::FetchRaw(p))
                        && self.units[p].input.len() + bound
                            < self.plant.products[p].unit.input_capacity as usize
                })
                .map(|p| {
                    (
                        self.distance_to_node(pos, self.plant.products[p].source_node),
                        Task::FetchRaw(p),
                    )
                });
            // Nearest first; on a tie the oldest product (by the creation
            // step of the buffer's front), so equidistant sources share.
            let oldest = |task: Task| match task {
                Task::FetchRaw(p) => self.sources[p].buffer.front().copied(),
                Task::FetchFinished(p) => self.units[p].output.front().copied(),
                _ => None,
            };
            let nearest = |c: Vec<(f64, Task)>| {
                c.into_iter()
                    .min_by(|a, b| {
                        a.0.total_cmp(&b.0)
                            .then_with(|| oldest(a.1).cmp(&oldest(b.1)))
                    })
                    .map(|(_, t)| t)
            };
            let task = nearest(finished.collect()).or_else(|| nearest(raw.collect()));
            if let Some(task) = task {
                self.agvs[i].task = task;
            }
        }
    }

    /// Who each AGV waits for: the AGV touching it on its route ahead.
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_plant::{Plant, PlantConfig, PlantEnv};
    /// let plant = Arc::new(Plant::load("dissertation").unwrap());
    /// let env = PlantEnv::new(plant, PlantConfig { agents: 2, ..Default::default() }).unwrap();
    /// assert_eq!(env.waits_for(), vec![None, None]); // starts are apart
    /// ```
    pub fn waits_for(&self) -> Vec<Option<usize>> {
        (0..self.agents())
            .map(|i| {
                if self.goal_node(i).is_none() || self.at_goal(i) || self.is_handling(i) {
                    return None;
                }
                let (pieces, _) = self.plan(i, FORWARD, 1e-3);
                let (driven, blocker) = self.drivable(i, &pieces);
                blocker.filter(|_| driven < 5e-4)
            })
            .collect()
    }

    /// Updates waiting counters, then counts deadlocks: cycles of waiting
    /// AGVs whose every member has waited `deadlock_after` steps.
    fn detect_deadlocks(&mut self) {
        let waits = self.waits_for();
        for (agv, w) in self.agvs.iter_mut().zip(&waits) {
            agv.waiting_steps = if w.is_some() {
                agv.waiting_steps + 1
            } else {
                0
            };
        }
        let k = self.plant.episode.deadlock_after;
        let n = self.agents();
        let mut any = false;
        for start in 0..n {
            // Follow the waits from `start`; it is on a cycle iff it comes
            // back within n hops. Count each cycle once, at its lowest index.
            let mut cycle = vec![start];
            let mut at = start;
            let mut closed = false;
            for _ in 0..n {
                match waits[at] {
                    Some(next) if next == start => {
                        closed = true;
                        break;
                    }
                    Some(next) => {
                        cycle.push(next);
                        at = next;
                    }
                    None => break,
                }
            }
            if !closed || cycle.iter().any(|&c| c < start) {
                continue;
            }
            let age = cycle
                .iter()
                .map(|&c| self.agvs[c].waiting_steps)
                .min()
                .unwrap_or(0);
            if age >= k {
                any = true;
                if age == k {
                    self.kpis.deadlock_events += 1;
                }
            }
        }
        if any {
            self.kpis.deadlock_steps += 1;
        }
    }
}

/// Dead-end segments without a station: where reversing AGVs go.
fn siding_flags(plant: &Plant) -> Vec<bool> {
    let stations: Vec<usize> = plant
        .products
        .iter()
        .flat_map(|p| [p.source_node, p.unit_node])
        .chain([plant.sink])
        .collect();
    plant
        .segments
        .iter()
        .map(|s| {
            [s.from, s.to]
                .iter()
                .any(|&n| plant.incident(n).len() == 1 && !stations.contains(&n))
        })
        .collect()
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
