//! The multi-agent grid world under either rule set ([`crate::rules`]).
//!
//! Under `thesis` (SPEC §2, the default) one step moves agents
//! **sequentially in index order**: agent `i`'s move succeeds iff the target
//! is inside the grid, not a wall and not occupied at that moment — a
//! lower-index agent may already have moved in or out, so an agent may enter
//! a cell vacated earlier in the same step, and no two agents can swap.
//! Under `pogema` all agents move at once after POGEMA's soft-collision
//! repair ([`crate::rules::resolve_simultaneous`]). Rewards per agent, under
//! both: +0.5 the first time it stands on its goal;
//! +1 to every agent when all stand on their goals after a step (the episode
//! terminates); at truncation (`t == T_max`) −1 to every agent off its goal;
//! −1 to an agent sharing a cell (impossible under these rules; checked).
//!
//! In lifelong mode an agent that reaches its goal earns +0.5 and at once gets
//! a new goal (drawn from the episode RNG, distinct from the other agents'
//! goals; or, after [`GridEnv::reset_with_sequences`], the next goal of its
//! own sequence, which other agents' goals may share, as in POGEMA); there
//! is no termination bonus and no truncation penalty, and
//! throughput = goals reached per step.
//!
//! A step ([`GridEnv::step`]) validates its input, moves the agents, keeps
//! the episode's accounts (arrivals, rewards, termination or truncation,
//! lifelong goal draws) and then shows the step to its observers, plain
//! structs with one job each: potential-based shaping (`shaping.rs`), the
//! visit heatmap (`visits.rs`) and the deadlock/livelock monitor with its
//! inputs (`stall.rs`). The padded per-cell arrays the moves and the
//! observation encoders work on are `board.rs`; what one can read of an
//! env (its accessors) is `view.rs`.

use std::sync::Arc;

use rand::Rng;
use rand_chacha::ChaCha8Rng;

use crate::config::{episode_instance, episode_rng, EnvConfig};
use crate::error::EnvError;
use crate::map::{Cell, Map};
use crate::rules::{resolve_simultaneous, Rules, SimultaneousScratch};

use board::Board;
use shaping::ShapingObserver;
use stall::StallWatch;
use visits::VisitCounts;

mod board;
mod report;
mod sequences;
mod shaping;
mod stall;
mod view;
mod visits;

/// Reward for first standing on one's goal.
pub const REWARD_GOAL: f32 = 0.5;
/// Reward to every agent when all stand on their goals.
pub const REWARD_ALL_AT_GOAL: f32 = 1.0;
/// Reward to every agent off its goal at truncation.
pub const REWARD_TRUNCATED_OFF_GOAL: f32 = -1.0;
/// Reward to each agent sharing a cell with another.
pub const REWARD_COLLISION: f32 = -1.0;

/// Number of actions: 0 stay, 1 up, 2 right, 3 down, 4 left.
pub const NUM_ACTIONS: usize = 5;

/// The RNG of lifelong goal draws: a stream apart from the episode instance's.
fn lifelong_rng(seed: u64, episode: u64) -> ChaCha8Rng {
    episode_rng(crate::seed::lifelong_goals(seed), episode)
}

/// The execution-delay draws of `episode` ([`EnvConfig::delay`]).
fn delay_rng(seed: u64, episode: u64) -> ChaCha8Rng {
    episode_rng(crate::seed::delays(seed), episode)
}

/// `(row, col)` change of each action.
pub(crate) const MOVE_DELTAS: [(isize, isize); NUM_ACTIONS] =
    [(0, 0), (-1, 0), (0, 1), (1, 0), (0, -1)];

/// Moves `cell` by `action` (a move that succeeded, so its target is
/// inside the grid and nothing wraps).
#[inline(always)]
fn shift_cell(cell: &mut Cell, action: u8) {
    let (dr, dc) = MOVE_DELTAS[action as usize];
    cell.row = cell.row.wrapping_add_signed(dr);
    cell.col = cell.col.wrapping_add_signed(dc);
}

/// How a step ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct StepOutcome {
    /// All agents on their goals: the episode is over and successful.
    pub terminated: bool,
    /// `T_max` reached without success.
    pub truncated: bool,
    /// Move requests that failed this step (wall, edge or occupied cell).
    pub blocked_moves: u32,
}

impl StepOutcome {
    /// Whether the episode ended with this step.
    pub fn done(&self) -> bool {
        self.terminated || self.truncated
    }
}

/// One environment instance.
///
/// ```
/// use buridan_env::{EnvConfig, GridEnv, Map, Starts};
/// let map = std::sync::Arc::new(Map::load("rm-1.1").unwrap());
/// let cfg = EnvConfig { agents: 2, starts: Starts::Fixed, ..EnvConfig::default() };
/// let mut env = GridEnv::new(map, cfg).unwrap();
/// let mut rewards = [0.0; 2];
/// let out = env.step(&[2, 4], &mut rewards).unwrap();
/// assert!(!out.done());
/// assert_eq!(env.position(0), buridan_env::Cell::new(1, 2));
/// ```
#[derive(Debug, Clone)]
pub struct GridEnv {
    map: Arc<Map>,
    cfg: EnvConfig,
    /// The padded per-cell arrays (walls, occupants, goals, shared codes).
    board: Board,
    // Per agent.
    /// Padded index of each agent.
    pos: Vec<usize>,
    /// Padded index of each agent's goal.
    goal: Vec<usize>,
    /// Each agent's cell (kept beside `pos` so that no hot path divides).
    cells: Vec<Cell>,
    /// Each agent's goal cell.
    goal_cells: Vec<Cell>,
    /// Goal distance maps (unpadded, row-major) of each agent's goal.
    goal_distance: Vec<Arc<[u16]>>,
    /// Pogema rules: each agent's padded cell after the repair.
    scratch_target: Vec<usize>,
    /// Pogema rules: the repair's buffers (empty under thesis rules).
    simultaneous: SimultaneousScratch,
    // Episode accounting.
    t: u32,
    episode: u64,
    over: bool,
    /// The lifelong goal draws.
    rng: ChaCha8Rng,
    /// The execution-delay draws ([`EnvConfig::delay`]).
    delay_rng: ChaCha8Rng,
    /// The actions carried out in a step with delays (a buffer).
    executed: Vec<u8>,
    /// Moves that delays turned into waits this episode.
    delayed_moves: u32,
    /// Whether each agent has stood on its goal in this episode.
    reached: Vec<bool>,
    /// Whether goals may be shared (set by the resets that allow it).
    shared_goals: bool,
    /// Per agent, its goal sequence ([`GridEnv::reset_with_sequences`]);
    /// empty when lifelong goals are drawn.
    sequences: Vec<Vec<Cell>>,
    /// Per agent, the index in its sequence of the goal it heads for.
    sequence_index: Vec<usize>,
    /// Per agent, whether it reached the last goal of its sequence.
    exhausted: Vec<bool>,
    /// Steps each agent has been off its goal since it last stood on it
    /// (PIBT's priority, for the priority feature).
    off_goal: Vec<u32>,
    /// Per agent, the step (1-based) at which its latest stay on its goal
    /// began, 0 before any: its POGEMA cost while it stays.
    arrival: Vec<u32>,
    episode_reward: f32,
    blocked_moves: u32,
    goals_reached: u32,
    // Observers.
    /// Potential-based shaping (a no-op unless configured).
    shaping: ShapingObserver,
    /// The visit heatmap.
    visits: VisitCounts,
    /// The deadlock/livelock monitor and its inputs.
    stall: StallWatch,
}

impl GridEnv {
    /// A new environment, reset to episode 0.
    pub fn new(map: Arc<Map>, cfg: EnvConfig) -> Result<Self, EnvError> {
        Self::with_episode(map, cfg, 0)
    }

    /// A new environment, reset to the given episode index.
    pub fn with_episode(map: Arc<Map>, cfg: EnvConfig, episode: u64) -> Result<Self, EnvError> {
        cfg.validate()?;
        let board = Board::new(&map.grid, cfg.sensor_range.max(1));
        let n = cfg.agents;
        let mut env = Self {
            pos: vec![0; n],
            goal: vec![0; n],
            cells: vec![Cell::new(0, 0); n],
            goal_cells: vec![Cell::new(0, 0); n],
            goal_distance: Vec::with_capacity(n),
            scratch_target: vec![0; n],
            simultaneous: match cfg.rules {
                Rules::Thesis => SimultaneousScratch::default(),
                Rules::Pogema => SimultaneousScratch::new(board.len()),
            },
            board,
            t: 0,
            episode,
            over: false,
            rng: lifelong_rng(cfg.seed, episode),
            delay_rng: delay_rng(cfg.seed, episode),
            executed: Vec::new(),
            delayed_moves: 0,
            reached: vec![false; n],
            shared_goals: false,
            sequences: Vec::new(),
            sequence_index: vec![0; n],
            exhausted: vec![false; n],
            off_goal: vec![0; n],
            arrival: vec![0; n],
            episode_reward: 0.0,
            blocked_moves: 0,
            goals_reached: 0,
            shaping: ShapingObserver::new(cfg.shaping, n),
            visits: VisitCounts::new(map.grid.height(), map.grid.width()),
            stall: StallWatch::new(n, cfg.stall_window),
            map,
            cfg,
        };
        env.reset_to(episode)?;
        Ok(env)
    }

    /// Starts episode `episode`; its starts and goals come from
    /// [`episode_instance`] and so are a pure function of (map, agents, seed, episode).
    pub fn reset_to(&mut self, episode: u64) -> Result<(), EnvError> {
        let scen = episode_instance(
            &self.map,
            self.cfg.agents,
            self.cfg.starts,
            self.cfg.seed,
            episode,
        )?;
        self.reset_with(episode, &scen.starts, &scen.goals)
    }

    /// Starts the next episode (`episode + stride`).
    pub fn reset_next(&mut self, stride: u64) -> Result<(), EnvError> {
        self.reset_to(self.episode + stride)
    }

    /// Starts an episode with explicit starts and goals (validated: inside
    /// the grid, not on walls, pairwise distinct).
    pub fn reset_with(
        &mut self,
        episode: u64,
        starts: &[Cell],
        goals: &[Cell],
    ) -> Result<(), EnvError> {
        self.validate_instance(starts, goals, false)?;
        self.place(episode, starts, goals);
        Ok(())
    }

    /// Puts the agents of a checked instance on the board and starts
    /// episode `episode` (goals drawn in lifelong mode, not shared; the
    /// resets that allow shared goals or take sequences set that after).
    fn place(&mut self, episode: u64, starts: &[Cell], goals: &[Cell]) {
        let n = self.cfg.agents;
        for i in 0..n {
            self.board.remove_agent(self.pos[i], self.goal[i]);
        }
        self.goal_distance.clear();
        for i in 0..n {
            self.pos[i] = self.board.padded(starts[i]);
            self.goal[i] = self.board.padded(goals[i]);
            self.cells[i] = starts[i];
            self.goal_cells[i] = goals[i];
            self.board.place_agent(i, self.pos[i], self.goal[i]);
            self.goal_distance
                .push(self.map.grid.distances_to(goals[i]));
        }
        for i in 0..n {
            self.board.refresh_code(self.pos[i]);
            self.board.refresh_code(self.goal[i]);
        }
        self.reached.fill(false);
        self.shared_goals = false;
        self.sequences.clear();
        self.sequence_index.fill(0);
        self.exhausted.fill(false);
        self.off_goal.fill(0);
        self.arrival.fill(0);
        self.t = 0;
        self.episode = episode;
        self.over = false;
        self.rng = lifelong_rng(self.cfg.seed, episode);
        self.delay_rng = delay_rng(self.cfg.seed, episode);
        self.delayed_moves = 0;
        self.episode_reward = 0.0;
        self.blocked_moves = 0;
        self.goals_reached = 0;
        self.visits.record(&self.cells);
        let (pos, goal) = (&self.pos, &self.goal);
        let (width, distance) = (self.map.grid.width(), &self.goal_distance);
        self.stall.reset(
            &self.cells,
            |i| pos[i] == goal[i],
            |i, (r, c)| distance[i][r * width + c],
        );
    }

    /// Checks an episode's starts and goals for [`Self::reset_with`]: one
    /// of each per agent, inside the grid, not on walls, starts pairwise
    /// distinct, goals too unless `shared_goals` (and, in lifelong mode
    /// with drawn goals, a free cell to spare for goal draws).
    fn validate_instance(
        &self,
        starts: &[Cell],
        goals: &[Cell],
        shared_goals: bool,
    ) -> Result<(), EnvError> {
        let n = self.cfg.agents;
        for (what, list) in [("starts", starts), ("goals", goals)] {
            EnvError::check_len(what, n, list.len())?;
        }
        let grid = &self.map.grid;
        // Lifelong goal draws need a free cell that is nobody's goal.
        if self.cfg.lifelong && !shared_goals && grid.free_cells().len() <= n {
            return Err(EnvError::TooFewFreeCells {
                map: self.map.name.clone(),
                free: grid.free_cells().len(),
                agents: n,
                needed: n + 1,
            });
        }
        self.check_cells("starts", "start", starts, true)?;
        self.check_cells("goals", "goal", goals, !shared_goals)
    }

    /// Checks one cell per agent (`what`, e.g. "starts"; `which` names one,
    /// "start"): as many as agents, inside the grid, not on walls,
    /// pairwise distinct if `distinct`.
    fn check_cells(
        &self,
        what: &'static str,
        which: &'static str,
        list: &[Cell],
        distinct: bool,
    ) -> Result<(), EnvError> {
        EnvError::check_len(what, self.cfg.agents, list.len())?;
        let grid = &self.map.grid;
        for (i, &cell) in list.iter().enumerate() {
            if let Some(problem) = cell_problem(grid, cell) {
                return Err(EnvError::BadCell {
                    agent: i,
                    which,
                    row: cell.row,
                    col: cell.col,
                    problem,
                });
            }
            if !distinct {
                continue;
            }
            if let Some(j) = list[..i].iter().position(|&c| c == cell) {
                return Err(EnvError::SharedCell {
                    first: j,
                    second: i,
                    which,
                    row: cell.row,
                    col: cell.col,
                });
            }
        }
        Ok(())
    }

    /// Advances one step. `actions[i]` ∈ 0..5 is agent `i`'s action; the
    /// per-agent rewards are written to `rewards`. Invalid input is rejected
    /// before anything changes.
    ///
    /// In order: the input is validated; the agents move (by the rule set;
    /// shaping notes the goal distances before); the episode's accounts are
    /// kept (arrivals, rewards, termination or truncation, lifelong goal
    /// draws); the observers see the step (shaping adds its bonus, the
    /// heatmap counts the agents' cells, the stall monitor updates).
    pub fn step(&mut self, actions: &[u8], rewards: &mut [f32]) -> Result<StepOutcome, EnvError> {
        self.validate_step(actions, rewards)?;
        self.before_moves();
        let mut executed = std::mem::take(&mut self.executed);
        let actions = self.delay(actions, &mut executed);
        let blocked_moves = match self.cfg.rules {
            Rules::Thesis => self.move_sequentially(actions),
            Rules::Pogema => self.move_simultaneously(actions),
        };
        self.executed = executed;
        let outcome = self.account(blocked_moves, rewards);
        self.observe(rewards);
        self.over = outcome.done();
        Ok(outcome)
    }

    /// Rejects a step's input that does not fit: wrong lengths, an action
    /// out of range, or an episode that is over.
    fn validate_step(&self, actions: &[u8], rewards: &[f32]) -> Result<(), EnvError> {
        let n = self.cfg.agents;
        EnvError::check_len("actions", n, actions.len())?;
        EnvError::check_len("rewards", n, rewards.len())?;
        if let Some(agent) = actions.iter().position(|&a| a as usize >= NUM_ACTIONS) {
            return Err(EnvError::InvalidAction {
                agent,
                action: actions[agent],
            });
        }
        if self.over {
            return Err(EnvError::EpisodeOver);
        }
        Ok(())
    }

    /// The actions carried out: `actions` itself without delays; with
    /// them ([`EnvConfig::delay`]) a copy in `buffer` in which each move
    /// fails, becoming a wait, with probability `delay`.
    fn delay<'a>(&mut self, actions: &'a [u8], buffer: &'a mut Vec<u8>) -> &'a [u8] {
        let p = self.cfg.delay;
        if p <= 0.0 {
            return actions;
        }
        buffer.clear();
        buffer.extend_from_slice(actions);
        for action in buffer.iter_mut() {
            // One draw per agent and step, waits included, so that which
            // agents lag does not depend on what the others were told.
            let fails = self.delay_rng.random::<f32>() < p;
            if fails && *action != 0 {
                *action = 0;
                self.delayed_moves += 1;
            }
        }
        buffer
    }

    /// Moves that delays ([`EnvConfig::delay`]) turned into waits in this
    /// episode.
    pub fn delayed_moves(&self) -> u32 {
        self.delayed_moves
    }

    /// Moves the agents one after another in index order under the thesis
    /// rules; returns the requested moves that failed.
    fn move_sequentially(&mut self, actions: &[u8]) -> u32 {
        let mut blocked_moves = 0;
        let board = &mut self.board;
        let agents = self.pos.iter_mut().zip(self.cells.iter_mut());
        for (i, (&action, (pos, cell))) in actions.iter().zip(agents).enumerate() {
            if action == 0 {
                continue;
            }
            let to = pos.wrapping_add_signed(board.step_offsets[action as usize]);
            if board.is_open(to) {
                board.move_agent(i, *pos, to);
                *pos = to;
                shift_cell(cell, action);
                self.stall.moved(i, *cell);
            } else {
                blocked_moves += 1;
            }
        }
        blocked_moves
    }

    /// Moves all agents at once under the pogema rules; returns the
    /// requested moves that became waits.
    fn move_simultaneously(&mut self, actions: &[u8]) -> u32 {
        let blocked_moves = resolve_simultaneous(
            &self.pos,
            actions,
            &self.board.step_offsets,
            &self.board.blocked,
            &self.board.occupant,
            &mut self.scratch_target,
            &mut self.simultaneous,
        );
        // Vacate every source before filling any target: a follower's target
        // is its leader's source.
        for (&from, &to) in self.pos.iter().zip(&self.scratch_target) {
            if to != from {
                self.board.leave(from);
            }
        }
        let agents = self.pos.iter_mut().zip(self.cells.iter_mut());
        let moves = actions.iter().zip(&self.scratch_target).zip(agents);
        for (i, ((&action, &to), (pos, cell))) in moves.enumerate() {
            if to != *pos {
                self.board.enter(i, to);
                *pos = to;
                shift_cell(cell, action);
                self.stall.moved(i, *cell);
            }
        }
        blocked_moves
    }

    /// The episode's accounts after the moves: the step count, arrivals
    /// and costs, the rewards (collision, goal, all-at-goal, truncation),
    /// termination or truncation, lifelong goal draws (in agent order), the
    /// episode return (unshaped) and the blocked-move count.
    fn account(&mut self, blocked_moves: u32, rewards: &mut [f32]) -> StepOutcome {
        let mut outcome = StepOutcome {
            blocked_moves,
            ..StepOutcome::default()
        };
        self.t += 1;
        let (t, lifelong) = (self.t, self.cfg.lifelong);
        rewards.fill(0.0);
        let (mut all_home, mut arrivals) = (true, 0);
        let agents = (self.pos.iter().zip(&self.goal))
            .zip(self.off_goal.iter_mut().zip(&mut self.arrival))
            .zip(&mut self.reached);
        for (i, (reward, (((&p, &g), (off_goal, arrival)), reached))) in
            rewards.iter_mut().zip(agents).enumerate()
        {
            // Collision check: under sequential moves the occupant array has one
            // agent per cell, so a mismatch would mean two agents in one cell.
            if self.board.occupant[p] != i as u16 + 1 {
                *reward += REWARD_COLLISION;
            }
            let home = p == g;
            // An arrival: on the goal now, off it before (or at the start).
            // Only arrivals are written, which keeps this loop as cheap as
            // before costs existed.
            if home && (*off_goal != 0 || t == 1) {
                *arrival = t;
            }
            self.stall.set_at_goal(i, home);
            *off_goal = if home { 0 } else { *off_goal + 1 };
            if home {
                if lifelong && self.exhausted[i] {
                    // At the end of its sequence: nothing more to reach.
                    continue;
                }
                if lifelong {
                    // Its new goal is drawn (or taken from its sequence) below.
                    *reward += REWARD_GOAL;
                    self.goals_reached += 1;
                    self.stall.new_goal(i);
                    arrivals += 1;
                    continue;
                }
                if !*reached {
                    *reached = true;
                    self.goals_reached += 1;
                    *reward += REWARD_GOAL;
                }
            } else {
                all_home = false;
            }
        }
        if lifelong {
            // New goals for this step's arrivals, drawn in agent order (each
            // draw avoids the goals of the agents drawn before it), or the
            // next of each one's sequence.
            for i in 0..self.cfg.agents {
                if arrivals == 0 {
                    break;
                }
                if self.stall.arrived()[i] {
                    self.next_goal(i);
                    arrivals -= 1;
                }
            }
            all_home = false;
        }
        if all_home {
            rewards.iter_mut().for_each(|r| *r += REWARD_ALL_AT_GOAL);
            outcome.terminated = true;
        } else if self.t >= self.cfg.t_max {
            outcome.truncated = true;
            if !self.cfg.lifelong {
                for (reward, (p, g)) in rewards.iter_mut().zip(self.pos.iter().zip(&self.goal)) {
                    if p != g {
                        *reward += REWARD_TRUNCATED_OFF_GOAL;
                    }
                }
            }
        }
        self.episode_reward += rewards.iter().sum::<f32>();
        self.blocked_moves += outcome.blocked_moves;
        outcome
    }

    /// The observers note what they compare the step's outcome with:
    /// shaping, each agent's goal distance before the moves.
    #[inline]
    fn before_moves(&mut self) {
        let (distance, cells, width) = (&self.goal_distance, &self.cells, self.map.grid.width());
        self.shaping
            .before_moves(|i| distance[i][cells[i].row * width + cells[i].col]);
    }

    /// The observers see the step: shaping adds its bonus to `rewards`
    /// (none to an agent with a new goal), the heatmap counts every agent's
    /// cell, the stall monitor takes the step's inputs.
    #[inline]
    fn observe(&mut self, rewards: &mut [f32]) {
        let (distance, cells, width) = (&self.goal_distance, &self.cells, self.map.grid.width());
        self.shaping.add(rewards, self.stall.arrived(), |i| {
            distance[i][cells[i].row * width + cells[i].col]
        });
        self.visits.record(cells);
        self.stall.observe(|i, (r, c)| distance[i][r * width + c]);
    }

    /// Gives agent `agent` a new goal drawn from the episode's lifelong RNG:
    /// a free cell that is nobody's goal.
    fn draw_new_goal(&mut self, agent: usize) {
        let free = self.map.grid.free_cells();
        // Rejection sampling terminates: `reset_with` guarantees more free
        // cells than agents in lifelong mode, so some free cell is nobody's goal.
        let cell = loop {
            let cand = free[self.rng.random_range(0..free.len())];
            let p = self.board.padded(cand);
            if self.board.goals_here[p] == 0 {
                break cand;
            }
        };
        self.set_goal(agent, cell);
    }

    /// Makes `cell` agent `agent`'s goal.
    fn set_goal(&mut self, agent: usize, cell: Cell) {
        let new = self.board.padded(cell);
        self.board.move_goal(self.goal[agent], new);
        self.goal[agent] = new;
        self.goal_cells[agent] = cell;
        self.goal_distance[agent] = self.map.grid.distances_to(cell);
    }
}

/// Why `cell` cannot hold an agent or a goal of `grid`, if it cannot.
fn cell_problem(grid: &crate::map::Grid, cell: Cell) -> Option<&'static str> {
    if !grid.contains(cell) {
        Some("outside the grid")
    } else if grid.is_wall(cell) {
        Some("a wall")
    } else {
        None
    }
}
