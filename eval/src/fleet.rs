//! Closed-loop control of a fleet: each control cycle, the robots report
//! where they stand and where they head, and any controller answers with
//! every robot's next move. The base of a fleet controller service.
//!
//! A [`FleetSession`] keeps a [`GridEnv`] as its picture of the fleet and
//! never moves the robots itself: every step starts from the positions
//! reported ([`GridEnv::report`]), whatever the robots were told before.
//! A policy or a shield chooses from that state, as in training. A
//! planner ([`Controller::follows_plan`]) plans once and follows its plan
//! by the clock; the session plans again from the reported state when a
//! robot is not where the plan put it (a robot lagged) or a goal changed.
//!
//! Goals are exclusive unless the session opens with
//! [`FleetOptions::with_shared_goals`] (POGEMA's lifelong tasks, where
//! several robots may head for one cell). A one-shot planner cannot plan
//! for two agents ending on one cell, so there each replan gives it
//! distinct stand-in goals ([`planning_goals`]): of the robots sharing a
//! goal the nearest keeps it, the others head for the nearest cells that
//! are nobody's goal; when the first arrives and gets its next goal, the
//! goals change and the session plans again with the others' real goals.
//! The robots' own goals are never changed: arrivals are counted on them.
//!
//! ```
//! use std::sync::Arc;
//! use buridan_env::{EnvConfig, GridEnv, Map, Rules};
//! use buridan_eval::fleet::FleetSession;
//! let map = Arc::new(Map::load("rm-2.1").unwrap());
//! // The robots: an env whose moves fail one time in ten.
//! let cfg = EnvConfig { agents: 4, delay: 0.1, ..EnvConfig::default() };
//! let mut robots = GridEnv::with_episode(map.clone(), cfg, 3).unwrap();
//! let controller = "lacam".parse().unwrap();
//! let mut fleet = FleetSession::open(map, Rules::Thesis, &controller, &robots.positions(), &robots.goals(), 42).unwrap();
//! let mut rewards = [0.0; 4];
//! while !robots.is_over() {
//!     let moves = fleet.step(&robots.positions(), &robots.goals()).unwrap().to_vec();
//!     robots.step(&moves, &mut rewards).unwrap();
//! }
//! assert!(robots.stats().success);
//! ```

use std::sync::Arc;

use buridan_env::map::UNREACHABLE;
use buridan_env::{Cell, EnvConfig, EnvError, Grid, GridEnv, Map, Rules};
use buridan_mapf::Limits;

use crate::by_name::{Controller as ControllerSpec, ControllerNameError};
use crate::controller::{Controller, GiveUp};

/// Why a fleet session could not open or answer.
#[derive(Debug, thiserror::Error)]
pub enum FleetError {
    /// The map, the robots' report or the controller's settings do not fit.
    #[error(transparent)]
    Env(#[from] EnvError),
    /// The controller could not be built.
    #[error(transparent)]
    Controller(#[from] ControllerNameError),
    /// A planner found no plan from the reported state: the robots wait
    /// this step and the session plans again at the next.
    #[error("the controller found no plan ({0}): every robot waits")]
    GaveUp(GiveUp),
}

/// One fleet under closed-loop control (see the [module docs](self)).
pub struct FleetSession {
    env: GridEnv,
    controller: Box<dyn Controller>,
    moves: Vec<u8>,
    /// The rewards of the last reported step (a recurrent policy reads them).
    rewards: Vec<f32>,
    /// Where the last moves put each robot if carried out.
    expected: Vec<Cell>,
    /// Plans made after the first.
    replans: u64,
    /// Whether the controller holds a plan to follow.
    planned: bool,
    /// No step yet: the state is the one the session opened with.
    opened: bool,
    /// The last step answered with the controller's moves.
    answered: bool,
    /// The goals of the last report (a planner's env may hold stand-ins).
    goals: Vec<Cell>,
    /// Whether robots may share goals ([`FleetOptions::with_shared_goals`]).
    shared_goals: bool,
}

/// How a [`FleetSession`] opens beyond its fleet and controller: the seed
/// of the controller's draws (sampled actions, shield ties), the limits
/// its planners plan within each time they plan (a service bounds a
/// step's latency so; the defaults otherwise), and whether robots may
/// share goals (several robots heading for one cell, as in POGEMA's
/// lifelong tasks: reports may name shared goals, and a planner plans for
/// distinct stand-ins, see the [module docs](self)). A bare seed is the
/// options with that seed and the rest by default.
///
/// ```
/// use buridan_eval::fleet::FleetOptions;
/// use buridan_mapf::Limits;
/// let o = FleetOptions::from(42).within(Limits::default()).with_shared_goals();
/// assert_eq!((o.seed, o.shared_goals), (42, true));
/// assert!(!FleetOptions::from(7).shared_goals);
/// ```
#[derive(Debug, Clone, Default)]
pub struct FleetOptions {
    /// Seeds the controller's draws.
    pub seed: u64,
    /// What a planner may spend each time it plans.
    pub limits: Limits,
    /// Whether robots may share goals.
    pub shared_goals: bool,
}

impl FleetOptions {
    /// These options with planners planning within `limits`.
    pub fn within(self, limits: Limits) -> Self {
        Self { limits, ..self }
    }

    /// These options with goals that robots may share.
    pub fn with_shared_goals(self) -> Self {
        Self {
            shared_goals: true,
            ..self
        }
    }
}

impl From<u64> for FleetOptions {
    fn from(seed: u64) -> Self {
        Self {
            seed,
            ..Self::default()
        }
    }
}

impl FleetSession {
    /// A session for the robots standing on `positions` and heading for
    /// `goals` on `map` under `rules`, driven by `controller` (the
    /// controller grammar; policies read the window and features of their
    /// checkpoint), opened with `options` ([`FleetOptions`]; a bare seed
    /// for the defaults).
    pub fn open(
        map: Arc<Map>,
        rules: Rules,
        controller: &ControllerSpec,
        positions: &[Cell],
        goals: &[Cell],
        options: impl Into<FleetOptions>,
    ) -> Result<Self, FleetError> {
        let FleetOptions {
            seed,
            limits,
            shared_goals,
        } = options.into();
        let agents = positions.len();
        let controller = controller.factory(agents, seed, limits, rules)?();
        let cfg = EnvConfig {
            agents,
            rules,
            t_max: rules.default_t_max(),
            seed,
            sensor_range: controller.obs_sensor_range(),
            features: controller.obs_features(),
            ..EnvConfig::default()
        };
        let env = GridEnv::new(map, cfg)?;
        let mut session = Self {
            env,
            controller,
            moves: vec![0; agents],
            rewards: vec![0.0; agents],
            expected: positions.to_vec(),
            replans: 0,
            planned: false,
            opened: true,
            answered: false,
            goals: goals.to_vec(),
            shared_goals,
        };
        session.reset_env(0, positions, goals)?;
        // A planner that finds no plan yet leaves `planned` false: the
        // first step tries again and says so.
        session.begin().ok();
        Ok(session)
    }

    /// The next move of every robot (0 stay, 1 up, 2 right, 3 down, 4
    /// left), for the robots on `positions` heading for `goals`. A report
    /// that does not fit ([`GridEnv::report`]: a robot on a wall, off the
    /// map, on another's cell or more than one cell from its last
    /// position) is refused and changes nothing.
    pub fn step(&mut self, positions: &[Cell], goals: &[Cell]) -> Result<&[u8], FleetError> {
        self.answered = false;
        let goals_changed = goals != self.goals.as_slice();
        let lagged = positions != self.expected.as_slice();
        // The first report of the state the session opened with is that
        // state, not a step after it (a refused report is no first report).
        if !self.opened || goals_changed || lagged {
            self.env.report(positions, goals, &mut self.rewards)?;
            self.controller.after_step(&self.rewards);
            self.goals.clear();
            self.goals.extend_from_slice(goals);
        }
        self.opened = false;
        if self.controller.follows_plan() && (goals_changed || lagged || !self.planned) {
            // Plan afresh from the reported state, on a clock of its own.
            self.reset_env(self.env.episode() + 1, positions, goals)?;
            self.replans += 1;
            if let Err(e) = self.begin() {
                self.moves.fill(0);
                self.expected = positions.to_vec();
                return Err(e);
            }
        }
        self.controller.act(&self.env, &mut self.moves);
        self.answered = true;
        let grid = &self.env.map().grid;
        for (expected, (&cell, &action)) in self
            .expected
            .iter_mut()
            .zip(positions.iter().zip(&self.moves))
        {
            *expected = grid.neighbour(cell, action).unwrap_or(cell);
        }
        Ok(&self.moves)
    }

    /// Puts the session's env in the state of `positions` and `goals`
    /// (episode `episode`): with shared goals allowed, a planner's env gets
    /// distinct stand-ins ([`planning_goals`]).
    fn reset_env(
        &mut self,
        episode: u64,
        positions: &[Cell],
        goals: &[Cell],
    ) -> Result<(), EnvError> {
        if !self.shared_goals {
            return self.env.reset_with(episode, positions, goals);
        }
        if self.controller.follows_plan() {
            let stand_ins = planning_goals(&self.env.map().grid, positions, goals);
            self.env
                .reset_with_shared_goals(episode, positions, &stand_ins)
        } else {
            self.env.reset_with_shared_goals(episode, positions, goals)
        }
    }

    /// The controller's plan (or its state) for the env as it stands.
    fn begin(&mut self) -> Result<(), FleetError> {
        self.planned = false;
        self.controller
            .begin_episode(&self.env)
            .map_err(FleetError::GaveUp)?;
        self.planned = true;
        Ok(())
    }

    /// The session's picture of the fleet after the last report.
    pub fn env(&self) -> &GridEnv {
        &self.env
    }

    /// Per robot, whether the last step's move is not the policy's own
    /// first choice (the shield changed it); `None` for a controller
    /// without a shield, or after a step that answered no moves.
    pub fn overridden(&self) -> Option<&[bool]> {
        if self.answered {
            self.controller.overridden()
        } else {
            None
        }
    }

    /// How often a planner planned again after the first plan.
    pub fn replans(&self) -> u64 {
        self.replans
    }
}

/// Distinct goals for a one-shot planner from goals robots may share: of
/// the robots heading for one cell the nearest (by shortest path on the
/// static grid; ties to the lower index) keeps it, every other one heads
/// for the cell nearest that goal that is nobody's goal yet (ties to the
/// lower cell index). Goals nobody shares are kept as they are.
///
/// ```
/// use buridan_env::{Cell, Grid};
/// use buridan_eval::fleet::planning_goals;
/// let grid = Grid::from_rows(&["....."]).unwrap();
/// let (pos, shared) = ([Cell::new(0, 0), Cell::new(0, 3)], Cell::new(0, 2));
/// // Robot 1 is nearer: it keeps the goal; robot 0 stops next to it.
/// assert_eq!(planning_goals(&grid, &pos, &[shared, shared]), [Cell::new(0, 1), shared]);
/// ```
pub fn planning_goals(grid: &Grid, positions: &[Cell], goals: &[Cell]) -> Vec<Cell> {
    let mut out = goals.to_vec();
    let mut taken: std::collections::HashSet<Cell> = goals.iter().copied().collect();
    for (i, &goal) in goals.iter().enumerate() {
        let sharing: Vec<usize> = (0..goals.len()).filter(|&j| goals[j] == goal).collect();
        if sharing.len() < 2 {
            continue;
        }
        let dist = grid.distances_to(goal);
        let nearest = sharing
            .iter()
            .copied()
            .min_by_key(|&j| (dist[grid.index(positions[j])], j));
        if nearest == Some(i) {
            continue;
        }
        let stand_in = grid
            .free_cells()
            .iter()
            .copied()
            .filter(|c| !taken.contains(c) && dist[grid.index(*c)] != UNREACHABLE)
            .min_by_key(|&c| (dist[grid.index(c)], grid.index(c)));
        if let Some(cell) = stand_in {
            out[i] = cell;
            taken.insert(cell);
        }
    }
    out
}

/// Plays `robots` (an env standing in for the fleet: its moves may fail,
/// [`EnvConfig::delay`]) to the end of its episode through `fleet`: each
/// step the fleet reports the robots' positions and goals and the robots
/// carry out the moves the session answers. A step whose planner found no
/// plan is a step of waits. `after` sees the robots after every step.
///
/// ```
/// use std::sync::Arc;
/// use buridan_env::{EnvConfig, GridEnv, Map, Rules};
/// use buridan_eval::fleet::{play, FleetSession};
/// let map = Arc::new(Map::load("rm-2.1").unwrap());
/// let cfg = EnvConfig { agents: 4, delay: 0.2, ..EnvConfig::default() };
/// let mut robots = GridEnv::with_episode(map.clone(), cfg, 0).unwrap();
/// let spec = "pibt".parse().unwrap();
/// let mut fleet = FleetSession::open(map, Rules::Thesis, &spec, &robots.positions(), &robots.goals(), 42).unwrap();
/// let mut steps = 0;
/// play(&mut robots, &mut fleet, |_| steps += 1).unwrap();
/// assert_eq!(steps, robots.t());
/// ```
pub fn play(
    robots: &mut GridEnv,
    fleet: &mut FleetSession,
    mut after: impl FnMut(&GridEnv),
) -> Result<(), FleetError> {
    let agents = robots.agents();
    let (mut moves, mut rewards) = (vec![0u8; agents], vec![0.0f32; agents]);
    while !robots.is_over() {
        match fleet.step(&robots.positions(), &robots.goals()) {
            Ok(answer) => moves.copy_from_slice(answer),
            Err(FleetError::GaveUp(_)) => moves.fill(0),
            Err(e) => return Err(e),
        }
        robots.step(&moves, &mut rewards)?;
        after(robots);
    }
    Ok(())
}
