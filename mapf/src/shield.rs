//! A collision shield for learned policies: PIBT over the policy's
//! preferences (CS-PIBT, Veerapaneni et al., ICAPS 2024).
//!
//! A learned policy proposes one action per agent. Executed greedily,
//! symmetric agents wait for each other forever: both face each other, both
//! see the other's cell masked and both choose "stay". The shield instead
//! treats each agent's five actions, ordered by the policy's probabilities,
//! as that agent's *preference order*, and lets PIBT (priority inheritance
//! with backtracking, [`crate::pibt`]) turn the preferences of all agents
//! into one joint move without conflicts:
//!
//! - agents are visited by decreasing priority; each takes its most
//!   preferred move still free at `t + 1`, pushing an undecided occupant out
//!   of the way first (the occupant then takes *its* most preferred move
//!   that is left, and so on, backtracking when a push fails);
//! - the priority rises by 1 each step an agent is off its goal and falls
//!   back to its fixed fractional tie-breaker on the goal (PIBT's rule). The
//!   tie-breakers are drawn once per episode from a seed, so two symmetric
//!   agents never wait on each other: the higher one pushes, the lower one
//!   gives way, and actions stay deterministic.
//!
//! The env moves agents one after the other in index order (SPEC §2): a move
//! into a cell another agent vacates in the same step succeeds only if that
//! agent has a lower index. The shield uses the generator's
//! [`ConflictModel::ENV_EXECUTABLE`] (see [`crate::pibt`]): agent `i` never enters a
//! cell held by a higher-index agent in the same step (it waits one step
//! while that agent is pushed out instead), so **every move the shield
//! returns succeeds in the env** — no blocked move, no collision, no swap.
//!
//! The shield knows no networks: callers pass preference orders (the
//! evaluation crate builds them from a checkpoint's action probabilities;
//! [`rollout::RolloutShield`] from a batch's logits, for training rollouts
//! through the shield).
//!
//! ```
//! use buridan_env::{Cell, Grid};
//! use buridan_mapf::shield::Shield;
//! // A corridor with a pocket above its middle. Agent 0 wants to go right,
//! // agent 1 left; they stand face to face.
//! let grid = Grid::from_rows(&["@@.@@", "....."]).unwrap();
//! let (pos, goals) = ([Cell::new(1, 1), Cell::new(1, 2)], [Cell::new(1, 4), Cell::new(1, 0)]);
//! // Each agent: towards its goal, then stay, up, down, away from the goal.
//! let prefs = [[2, 0, 1, 3, 4], [4, 0, 1, 3, 2]];
//! let mut shield = Shield::new(&grid);
//! shield.begin_episode(2, 0);
//! let mut actions = [0; 2];
//! shield.step(&pos, &goals, &prefs, &mut actions).unwrap();
//! // Agent 0 has the higher priority in this episode: it waits while
//! // agent 1, pushed, ducks into the pocket (agent 0 cannot enter agent
//! // 1's cell in the same step: the env moves agent 0 first).
//! assert_eq!(actions, [0, 1]);
//! ```

mod preference;
mod progress;
pub mod rollout;
mod yielding;

use buridan_env::{Cell, Grid, NUM_ACTIONS};

pub use preference::{preference_order, preference_orders, ActionOrder};

use crate::dead_ends::DeadEnds;
use crate::graph::{Topology, NONE};
use crate::lanes::Lanes;
use crate::limits::{check_online, InstanceError};
use crate::pibt::{online_step, Generator};
use crate::rules::ConflictModel;

use preference::Ranks;
use progress::{shortest_first, GoalDistances, ProgressFallback};
use yielding::{
    evict_from_dead_ends, hurry_the_awaited, keep_lanes_one_way, yield_to_deeper_goals, Fleet,
};

/// Why the shield refused a step.
///
/// ```
/// use buridan_env::{Cell, Grid};
/// use buridan_mapf::shield::{Shield, ShieldError};
/// let grid = Grid::from_rows(&["..."]).unwrap();
/// let mut shield = Shield::new(&grid);
/// let err = shield
///     .step(&[Cell::new(0, 0)], &[Cell::new(0, 2)], &[[0, 0, 1, 2, 3]], &mut [0])
///     .unwrap_err();
/// assert_eq!(err, ShieldError::NotAnOrder { agent: 0, order: [0, 0, 1, 2, 3] });
/// ```
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ShieldError {
    /// Positions and goals are no valid state: a wall, a cell outside the
    /// grid, two agents on one cell, or different lengths.
    #[error("invalid state: {0}")]
    State(#[from] InstanceError),
    /// The preferences or the action buffer do not have one entry per agent.
    #[error("{what}: {got} entries for {agents} agents")]
    WrongLength {
        /// `"preferences"` or `"actions"`.
        what: &'static str,
        /// Agents (positions given).
        agents: usize,
        /// Entries given.
        got: usize,
    },
    /// An agent's preferences are not a permutation of the five actions.
    #[error("agent {agent}: {order:?} is not an order of the 5 actions")]
    NotAnOrder {
        /// The agent.
        agent: usize,
        /// What it was given.
        order: ActionOrder,
    },
}

/// SplitMix64's output function: small or consecutive seeds still give
/// unrelated tie-breakers.
fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The collision shield (see the [module docs](self)): call
/// [`Shield::begin_episode`] at each episode start, then [`Shield::step`]
/// once per env step.
pub struct Shield {
    grid: Grid,
    topo: Topology,
    tie_seed: u64,
    steps: u64,
    priorities: Vec<f64>,
    cur: Vec<u32>,
    goals: Vec<u32>,
    ranks: Ranks,
    fallback: Option<ProgressFallback>,
    dead_ends: Option<DeadEnds>,
    /// Whether agents in a dead end's way back out
    /// ([`Shield::with_dead_end_eviction`]).
    evict: bool,
    /// Per agent: backing out of a dead end this step, moved first.
    urgent: Vec<bool>,
    /// Per agent: held outside a dead end by the order with eviction this
    /// step; no swap pulls it.
    holding: Vec<bool>,
    lanes: Option<Lanes>,
    /// Whether pushed agents step out of their pusher's way
    /// ([`Shield::with_stepping_aside`]).
    aside: bool,
    /// Each agent's distance table to its goal, kept while the fallback,
    /// the lane rule or stepping aside needs it.
    dist: GoalDistances,
}

impl Shield {
    /// A shield for `grid`. Until [`Shield::begin_episode`] is called it
    /// breaks priority ties with seed 0.
    ///
    /// ```
    /// let grid = buridan_env::Map::load("rm-2.1").unwrap().grid;
    /// let shield = buridan_mapf::shield::Shield::new(&grid);
    /// assert!(shield.priorities().is_empty());
    /// ```
    pub fn new(grid: &Grid) -> Self {
        Self {
            grid: grid.clone(),
            topo: Topology::new(grid),
            tie_seed: 0,
            steps: 0,
            priorities: Vec::new(),
            cur: Vec::new(),
            goals: Vec::new(),
            ranks: Ranks(Vec::new()),
            fallback: None,
            dead_ends: None,
            evict: false,
            urgent: Vec::new(),
            holding: Vec::new(),
            lanes: None,
            aside: false,
            dist: GoalDistances::default(),
        }
    }

    /// A shield whose agents fall back on their shortest paths when stuck:
    /// an agent off its goal that has not come closer to it for `patience`
    /// steps ranks its actions by the distance they leave to its goal
    /// (the policy's order breaks ties) until it comes closer. Classic
    /// PIBT's preferences, for the stuck ones only: the standoffs where the
    /// highest-priority agent prefers to wait for an agent that cannot push
    /// it are broken, since an agent that takes its shortest path pushes
    /// the lower-priority agents in its way. `patience = 0` makes every
    /// agent off its goal follow its shortest path at every step.
    ///
    /// Stalled agents also start the swap operation of LaCAM3 (see
    /// [`crate::pibt`]): where two of them must pass each other in a lane,
    /// one backs away and pulls the other along. Under the env's index
    /// order this does not settle every dead-end ordering (two agents bound
    /// for one dead-end aisle, the shallower goal's agent in front, can
    /// still livelock at its mouth); measured on the reference layouts it
    /// settles most (README, "The progress fallback").
    ///
    /// ```
    /// use buridan_env::{Cell, Grid};
    /// use buridan_mapf::shield::Shield;
    /// // A corridor with a pocket; agent 0 stands on its goal between
    /// // agent 1 and agent 1's goal, and both prefer to wait.
    /// let grid = Grid::from_rows(&["@.@@", "...."]).unwrap();
    /// let (pos, goals) = ([Cell::new(1, 1), Cell::new(1, 0)], [Cell::new(1, 1), Cell::new(1, 3)]);
    /// let wait = [[0, 1, 2, 3, 4]; 2];
    /// let mut actions = [9; 2];
    /// let mut patient = Shield::new(&grid);
    /// for _ in 0..5 {
    ///     patient.step(&pos, &goals, &wait, &mut actions).unwrap();
    ///     assert_eq!(actions, [0, 0]); // the policy's wish: both wait
    /// }
    /// let mut shield = Shield::new(&grid).with_progress_fallback(2);
    /// let moved = (0..10)
    ///     .position(|_| {
    ///         shield.step(&pos, &goals, &wait, &mut actions).unwrap();
    ///         actions != [0, 0]
    ///     })
    ///     .unwrap();
    /// // Once agent 1 has waited 2 steps off its goal without coming closer
    /// // (and outranks agent 0), it heads right and pushes agent 0 into the
    /// // pocket.
    /// assert!(moved >= 2);
    /// assert_eq!(actions, [1, 2]);
    /// ```
    pub fn with_progress_fallback(mut self, patience: u32) -> Self {
        self.fallback = Some(ProgressFallback {
            patience,
            best: Vec::new(),
            waiting: Vec::new(),
            stalled: Vec::new(),
            settle: false,
            arrived: Vec::new(),
        });
        self
    }

    /// The progress fallback of [`Shield::with_progress_fallback`] with
    /// progress as the deadlock monitor counts it: reaching the goal is
    /// progress the first time only. An agent that keeps stepping off its
    /// goal and back on never stays "farther than before" for `patience`
    /// steps, so the plain fallback never takes it over, and the episode
    /// never ends with all agents on their goals at once; here its steps
    /// off the goal add up, and once they reach `patience` it follows its
    /// shortest path, which keeps it on the goal. Resting on the goal is
    /// not waiting.
    ///
    /// ```
    /// use buridan_env::{Cell, Grid};
    /// use buridan_mapf::shield::Shield;
    /// // One agent whose policy steps off its goal and back, over and over.
    /// let grid = Grid::from_rows(&["..."]).unwrap();
    /// let goal = [Cell::new(0, 1)];
    /// let off_and_on = |at: Cell| if at == goal[0] { [4, 0, 1, 2, 3] } else { [2, 0, 1, 3, 4] };
    /// let play = |mut shield: Shield| {
    ///     let (mut at, mut on_goal) = (Cell::new(0, 0), 0);
    ///     let mut action = [0];
    ///     for _ in 0..40 {
    ///         shield.step(&[at], &goal, &[off_and_on(at)], &mut action).unwrap();
    ///         at = match action[0] { 2 => Cell::new(0, at.col + 1), 4 => Cell::new(0, at.col - 1), _ => at };
    ///         on_goal = if at == goal[0] { on_goal + 1 } else { 0 };
    ///     }
    ///     on_goal // steps on the goal in a row at the end
    /// };
    /// assert!(play(Shield::new(&grid).with_progress_fallback(4)) <= 1);
    /// assert!(play(Shield::new(&grid).with_goal_settling(4)) > 20);
    /// ```
    pub fn with_goal_settling(mut self, patience: u32) -> Self {
        self = self.with_progress_fallback(patience);
        if let Some(f) = &mut self.fallback {
            f.settle = true;
        }
        self
    }

    /// A shield that fills dead-end aisles from the back
    /// ([`crate::dead_ends`]): an agent whose goal lies on the way to
    /// another agent's goal deeper in the same dead-end branch, while that
    /// agent has not passed it yet, *yields*: standing outside the branch,
    /// it ranks every move into the branch last (whatever the policy or the
    /// progress fallback prefers) and takes the lowest priority, so that
    /// the agents bound deeper push it out of their way. An agent already
    /// inside the branch is left to the other rules. The order is strict
    /// (by depth along one path), so agents never yield to each other in a
    /// circle.
    ///
    /// ```
    /// use buridan_env::{Cell, Grid};
    /// use buridan_mapf::shield::Shield;
    /// // A two-wide spine on the left, a dead-end aisle to the right.
    /// let grid = Grid::from_rows(&["......", "..@@@@"]).unwrap();
    /// // Agent 0 is bound for (0, 3), agent 1 for the far end (0, 5).
    /// let (pos, goals) = ([Cell::new(0, 1), Cell::new(1, 1)], [Cell::new(0, 3), Cell::new(0, 5)]);
    /// let towards_goal = [[2, 0, 1, 3, 4], [1, 0, 2, 3, 4]];
    /// let mut actions = [9; 2];
    /// Shield::new(&grid).step(&pos, &goals, &towards_goal, &mut actions).unwrap();
    /// assert_eq!(actions[0], 2, "without the order, agent 0 enters first");
    /// let mut ordered = Shield::new(&grid).with_dead_end_order();
    /// ordered.step(&pos, &goals, &towards_goal, &mut actions).unwrap();
    /// assert_ne!(actions[0], 2, "agent 0 lets agent 1 in first");
    /// ```
    pub fn with_dead_end_order(mut self) -> Self {
        self.dead_ends = Some(DeadEnds::new(&self.grid));
        self
    }

    /// A shield with the dead-end order ([`Shield::with_dead_end_order`])
    /// that also undoes a wrong order: an agent inside the branch of its
    /// goal that stands in the way of an agent bound deeper (one that has
    /// passed neither its goal nor itself) or of one bound out of the
    /// branch backs out towards the core ahead of everybody else (PIBT
    /// moves it first and pushes whoever is between it and the core out
    /// ahead of it; neither the one-way lane rule nor a lane's traffic
    /// holds it back), then waits outside while the order says so or while
    /// someone inside is bound out. A waiting agent keeps out of the cells
    /// within two steps of the mouth (Manhattan distance) and steps back
    /// out of them, and no swap of the progress fallback pulls it towards
    /// the mouth; nor does a stalled agent about to step onto its own goal
    /// in the open start a swap with the agent beyond it
    /// (`Generator::for_eviction`). An agent inside a branch that others
    /// wait for outside walks its shortest path at once, without the
    /// fallback's patience. Nobody passes through a dead end: an
    /// agent ranks the moves into a branch that holds another agent's goal
    /// but not its own last (inside one, the moves towards the core
    /// first); branches nobody is bound for stay free to step aside into.
    /// Without these rules an aisle entered in the wrong order stays
    /// jammed: the agent at the back cannot get by, and the one in front
    /// has no reason to leave.
    ///
    /// ```
    /// use buridan_env::{Cell, Grid};
    /// use buridan_mapf::shield::Shield;
    /// // A two-wide spine on the left, a dead-end aisle to the right.
    /// let grid = Grid::from_rows(&["......", "..@@@@"]).unwrap();
    /// // Agent 0 rests on its goal in the aisle; agent 1, bound for the
    /// // far end, has just entered behind it.
    /// let goals = [Cell::new(0, 3), Cell::new(0, 5)];
    /// // A policy that heads for its goal and rests there.
    /// let prefs = |at: Cell, goal: Cell| match (goal.col as i32 - at.col as i32).signum() {
    ///     0 if at.row == goal.row => [0, 1, 2, 3, 4],
    ///     1 => [2, 1, 3, 0, 4],
    ///     _ => if at.row == goal.row { [4, 3, 1, 0, 2] } else { [1, 3, 2, 4, 0] },
    /// };
    /// let play = |mut shield: Shield| {
    ///     let mut pos = [Cell::new(0, 3), Cell::new(0, 2)];
    ///     let mut actions = [0u8; 2];
    ///     for t in 0..30 {
    ///         if pos == goals {
    ///             return Some(t);
    ///         }
    ///         let orders = [prefs(pos[0], goals[0]), prefs(pos[1], goals[1])];
    ///         shield.step(&pos, &goals, &orders, &mut actions).unwrap();
    ///         for (p, &a) in pos.iter_mut().zip(&actions) {
    ///             *p = match a {
    ///                 1 => Cell::new(p.row - 1, p.col),
    ///                 2 => Cell::new(p.row, p.col + 1),
    ///                 3 => Cell::new(p.row + 1, p.col),
    ///                 4 => Cell::new(p.row, p.col - 1),
    ///                 _ => *p,
    ///             };
    ///         }
    ///     }
    ///     None
    /// };
    /// assert_eq!(play(Shield::new(&grid).with_dead_end_order()), None, "a livelock");
    /// assert!(play(Shield::new(&grid).with_dead_end_eviction()).is_some(), "refilled from the back");
    /// ```
    pub fn with_dead_end_eviction(mut self) -> Self {
        if self.dead_ends.is_none() {
            self = self.with_dead_end_order();
        }
        self.evict = true;
        self
    }

    /// A shield that keeps one-lane corridors one-way ([`crate::lanes`]):
    /// an agent about to enter a lane waits outside (it ranks every move into
    /// the lane last and takes the lowest priority) while another agent
    /// inside comes towards it through the part of the lane it needs, or
    /// while a higher-priority agent enters that part from the other end.
    /// Agents inside a lane are never held back, so the lane empties.
    ///
    /// ```
    /// use buridan_env::{Cell, Grid};
    /// use buridan_mapf::shield::Shield;
    /// // A one-lane row between two open columns; agent 1 is inside,
    /// // heading left, while agent 0 wants to enter from the left.
    /// let grid = Grid::from_rows(&[".@@@@.", "......", ".@@@@."]).unwrap();
    /// let (pos, goals) = ([Cell::new(1, 0), Cell::new(1, 3)], [Cell::new(1, 5), Cell::new(2, 0)]);
    /// let prefs = [[2, 0, 1, 3, 4], [4, 0, 1, 3, 2]];
    /// let mut actions = [9; 2];
    /// Shield::new(&grid).step(&pos, &goals, &prefs, &mut actions).unwrap();
    /// assert_eq!(actions[0], 2, "without the rule, agent 0 enters");
    /// let mut one_way = Shield::new(&grid).with_one_way_lanes();
    /// one_way.step(&pos, &goals, &prefs, &mut actions).unwrap();
    /// assert_ne!(actions[0], 2, "agent 0 waits for agent 1 to come out");
    /// assert_eq!(actions[1], 4);
    /// ```
    pub fn with_one_way_lanes(mut self) -> Self {
        self.lanes = Some(Lanes::new(&self.grid));
        self
    }

    /// A shield whose pushed agents step out of their pusher's way: an
    /// agent pushed off its cell tries last the moves that lead onto the
    /// pusher's shortest path onward and bring it no closer to its own goal
    /// (see `Generator::with_stepping_aside` in [`crate::pibt`]). Without
    /// it, an agent resting on its goal by a lane's mouth, pushed by one
    /// bound into the lane, steps into the lane (its policy's choice), then
    /// back onto its goal, and the two trade places forever.
    ///
    /// ```
    /// use buridan_env::{Cell, Grid};
    /// use buridan_mapf::shield::Shield;
    /// // A one-lane row ending in a 2 x 2 room on the right. Agent 1 rests
    /// // on its goal at the lane's mouth (1, 4); agent 0 above it is bound
    /// // for the lane's far end (1, 0).
    /// let grid = Grid::from_rows(&["@@@@..", "......"]).unwrap();
    /// let (pos, goals) = ([Cell::new(0, 4), Cell::new(1, 4)], [Cell::new(1, 0), Cell::new(1, 4)]);
    /// // Agent 0 heads down; agent 1 would rather stay, then go left.
    /// let prefs = [[3, 4, 0, 2, 1], [0, 4, 1, 2, 3]];
    /// // Agent 0's priority grows while it is off its goal; by the third
    /// // step it outranks agent 1 and pushes it.
    /// let pushed = |mut shield: Shield| {
    ///     let mut actions = [9; 2];
    ///     for _ in 0..3 {
    ///         shield.step(&pos, &goals, &prefs, &mut actions).unwrap();
    ///     }
    ///     actions[1]
    /// };
    /// assert_eq!(pushed(Shield::new(&grid)), 4, "into the lane");
    /// assert_eq!(pushed(Shield::new(&grid).with_stepping_aside()), 2, "aside, to the right");
    /// ```
    pub fn with_stepping_aside(mut self) -> Self {
        self.aside = true;
        self
    }

    /// Starts an episode with `agents` agents: priorities restart from
    /// tie-breakers in `[0, 1)` drawn from `tie_seed` (distinct seeds per
    /// episode give each episode its own fixed order among equals).
    ///
    /// ```
    /// let grid = buridan_env::Grid::from_rows(&["...."]).unwrap();
    /// let mut shield = buridan_mapf::shield::Shield::new(&grid);
    /// shield.begin_episode(3, 42);
    /// assert!(shield.priorities().iter().all(|&p| (0.0..1.0).contains(&p)));
    /// ```
    pub fn begin_episode(&mut self, agents: usize, tie_seed: u64) {
        self.tie_seed = tie_seed;
        self.steps = 0;
        if let Some(f) = &mut self.fallback {
            f.restart();
        }
        let base = splitmix64(tie_seed);
        self.priorities = (0..agents as u64)
            .map(|i| (splitmix64(base.wrapping_add(i)) >> 11) as f64 / (1u64 << 53) as f64)
            .collect();
    }

    /// Current priorities (the integer part counts steps off goal since
    /// the last arrival).
    pub fn priorities(&self) -> &[f64] {
        &self.priorities
    }

    /// Turns each agent's preference order into one conflict-free joint
    /// move from `positions` towards `goals` (which only drive the
    /// priorities) and writes the env actions into `actions`. A call with a
    /// different number of agents than the episode begun starts a new one
    /// with the same tie seed.
    pub fn step(
        &mut self,
        positions: &[Cell],
        goals: &[Cell],
        preferences: &[ActionOrder],
        actions: &mut [u8],
    ) -> Result<(), ShieldError> {
        check_online(&self.grid, positions, goals)?;
        let n = positions.len();
        for (what, got) in [
            ("preferences", preferences.len()),
            ("actions", actions.len()),
        ] {
            if got != n {
                return Err(ShieldError::WrongLength {
                    what,
                    agents: n,
                    got,
                });
            }
        }
        self.cur.clear();
        self.cur
            .extend(positions.iter().map(|&c| self.topo.index(c)));
        self.goals.clear();
        self.goals.extend(goals.iter().map(|&c| self.topo.index(c)));
        if let Some(f) = &mut self.fallback {
            f.fit(n);
        }
        self.ranks.0.clear();
        for (agent, order) in preferences.iter().enumerate() {
            let mut rank = [u8::MAX; NUM_ACTIONS];
            for (r, &a) in order.iter().enumerate() {
                match rank.get_mut(usize::from(a)) {
                    Some(slot) if *slot == u8::MAX => *slot = r as u8,
                    _ => {
                        return Err(ShieldError::NotAnOrder {
                            agent,
                            order: *order,
                        })
                    }
                }
            }
            if self.fallback.is_some() || self.lanes.is_some() || self.aside {
                let new_goal = self.dist.update(&self.grid, agent, goals[agent]);
                if let Some(f) = &mut self.fallback {
                    let at = self.cur[agent];
                    let dist = &self.dist.table[agent];
                    if f.update(agent, dist[at as usize], new_goal) {
                        shortest_first(dist, self.topo.moves(at), &mut rank);
                    }
                }
            }
            self.ranks.0.push(rank);
        }
        if self.priorities.len() != n {
            self.begin_episode(n, self.tie_seed);
        }
        let fleet = Fleet {
            topo: &self.topo,
            cur: &self.cur,
            goals: &self.goals,
        };
        self.urgent.clear();
        if let Some(dead_ends) = self.dead_ends.as_ref().filter(|_| self.evict) {
            self.urgent.resize(n, false);
            evict_from_dead_ends(dead_ends, fleet, &mut self.ranks.0, &mut self.urgent);
        }
        self.holding.clear();
        self.holding.resize(n, false);
        if let Some(dead_ends) = &self.dead_ends {
            yield_to_deeper_goals(
                dead_ends,
                fleet,
                &mut self.ranks.0,
                &mut self.priorities,
                &mut self.holding,
                self.evict,
            );
        }
        if let Some(dead_ends) = self.dead_ends.as_ref().filter(|_| self.evict) {
            hurry_the_awaited(
                dead_ends,
                fleet,
                &self.holding,
                &self.urgent,
                &self.dist.table,
                &mut self.ranks.0,
            );
        }
        if let Some(lanes) = &self.lanes {
            keep_lanes_one_way(
                lanes,
                fleet,
                &self.dist.table,
                &mut self.ranks.0,
                &mut self.priorities,
                &self.urgent,
            );
        }
        let mut gen = Generator::new(
            &self.topo,
            ConflictModel::ENV_EXECUTABLE,
            self.tie_seed ^ self.steps,
        );
        if self.aside {
            gen = gen.with_stepping_aside(&self.dist.table);
        }
        // Stalled agents also back away and pull where two of them must
        // pass in a lane (LaCAM3's swap, see [`crate::pibt`]).
        if let Some(f) = self.fallback.as_ref().filter(|f| f.stalled.contains(&true)) {
            gen = gen.with_swap_for(&self.dist.table, &self.goals, &f.stalled);
            if self.evict {
                gen = gen.for_eviction(&self.holding);
            }
        }
        let next = online_step(
            gen,
            &self.ranks,
            &self.cur,
            &self.goals,
            &mut self.priorities,
            &self.urgent,
        );
        self.steps += 1;
        for ((a, &from), &to) in actions.iter_mut().zip(&self.cur).zip(&next) {
            let moves = self.topo.moves(from);
            *a = moves
                .iter()
                .position(|&v| v == to && v != NONE)
                .expect("PIBT moves to a neighbour or stays") as u8;
        }
        Ok(())
    }
}
