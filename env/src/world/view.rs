//! What one can read of a [`GridEnv`]: its settings, the agents' cells,
//! goals, costs and priorities, the episode's statistics and the observers'
//! records, and [`RawView`], the internals the observation encoders borrow.

use std::ops::Range;
use std::sync::Arc;

use super::{GridEnv, NUM_ACTIONS};
use crate::config::EnvConfig;
use crate::map::{Cell, Map};
use crate::monitor::StallMonitor;
use crate::rules::Rules;
use crate::stats::EpisodeStats;

impl GridEnv {
    /// The map.
    pub fn map(&self) -> &Arc<Map> {
        &self.map
    }

    /// The configuration.
    pub fn config(&self) -> &EnvConfig {
        &self.cfg
    }

    /// Number of agents.
    pub fn agents(&self) -> usize {
        self.cfg.agents
    }

    /// Steps taken in this episode.
    pub fn t(&self) -> u32 {
        self.t
    }

    /// Index of the current episode.
    pub fn episode(&self) -> u64 {
        self.episode
    }

    /// Whether the current episode has ended.
    pub fn is_over(&self) -> bool {
        self.over
    }

    /// Agent `i`'s cell.
    pub fn position(&self, agent: usize) -> Cell {
        self.cells[agent]
    }

    /// Agent `i`'s goal.
    pub fn goal(&self, agent: usize) -> Cell {
        self.goal_cells[agent]
    }

    /// All agents' cells.
    pub fn positions(&self) -> Vec<Cell> {
        self.cells.clone()
    }

    /// All agents' goals.
    pub fn goals(&self) -> Vec<Cell> {
        self.goal_cells.clone()
    }

    /// Whether agent `i` stands on its goal.
    pub fn at_goal(&self, agent: usize) -> bool {
        self.pos[agent] == self.goal[agent]
    }

    /// Agent `i`'s cost in POGEMA's sense (its `SumOfCostsAndMakespanMetric`),
    /// as if the episode ended now: the step (1-based) at which it last
    /// arrived on its goal and has stayed since, or the steps taken so far if
    /// it is off its goal (`T_max` at truncation). An agent that starts on
    /// its goal and stays costs 1. Like POGEMA, an agent that leaves its goal
    /// in the truncating step `T_max` itself keeps the cost of its last
    /// arrival. Meaningful for one-shot episodes (not lifelong mode, where
    /// goals move).
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_env::{Cell, EnvConfig, GridEnv, Map, Rules};
    /// let map = Arc::new(Map::load("rm-1.1").unwrap());
    /// let mut env = GridEnv::new(map, EnvConfig { agents: 1, ..EnvConfig::for_rules(Rules::Pogema) }).unwrap();
    /// env.reset_with(0, &[Cell::new(1, 1)], &[Cell::new(1, 2)]).unwrap();
    /// env.step(&[0], &mut [0.0]).unwrap();
    /// assert_eq!(env.cost(0), 1); // off its goal after 1 step
    /// env.step(&[2], &mut [0.0]).unwrap(); // right, onto its goal: success
    /// assert_eq!((env.cost(0), env.sum_of_costs(), env.makespan()), (2, 2, 2));
    /// ```
    pub fn cost(&self, agent: usize) -> u32 {
        // POGEMA's metric skips its "left the goal" reset in the truncating
        // step, so an agent that left exactly then keeps its arrival.
        let left_in_last_step = self.t >= self.cfg.t_max && self.off_goal[agent] == 1;
        match self.arrival[agent] {
            step if step != 0 && (self.at_goal(agent) || left_in_last_step) => step,
            _ => self.t,
        }
    }

    /// Sum of [`Self::cost`] over the agents (POGEMA's SoC).
    pub fn sum_of_costs(&self) -> u64 {
        (0..self.cfg.agents).map(|i| u64::from(self.cost(i))).sum()
    }

    /// Maximum of [`Self::cost`] over the agents (POGEMA's makespan).
    pub fn makespan(&self) -> u32 {
        (0..self.cfg.agents)
            .map(|i| self.cost(i))
            .max()
            .unwrap_or(0)
    }

    /// The rule set this env moves agents by.
    pub fn rules(&self) -> Rules {
        self.cfg.rules
    }

    /// Per-cell visit counts since the env was created (row-major): each
    /// episode's starts once, then every agent's cell after every step.
    pub fn visits(&self) -> &[u64] {
        self.visits.counts()
    }

    /// Sets all visit counts to zero.
    pub fn clear_visits(&mut self) {
        self.visits.clear();
    }

    /// The deadlock/livelock monitor of this episode.
    pub fn monitor(&self) -> &StallMonitor {
        self.stall.monitor()
    }

    /// Statistics of the episode so far (final once [`Self::is_over`]).
    pub fn stats(&self) -> EpisodeStats {
        let n = self.cfg.agents;
        EpisodeStats {
            episode: self.episode,
            reward: self.episode_reward,
            length: self.t,
            success: !self.cfg.lifelong && (0..n).all(|i| self.at_goal(i)),
            agents_at_goal: (0..n).filter(|&i| self.at_goal(i)).count() as u32,
            blocked_moves: self.blocked_moves,
            goals_reached: self.goals_reached,
            deadlock_steps: self.monitor().deadlock_steps(),
            livelock_steps: self.monitor().livelock_steps(),
            deadlock_events: self.monitor().deadlock_events(),
            layout: 0,
            replay: 0,
        }
    }

    // Accessors for the observation encoders.
    pub(crate) fn raw(&self) -> RawView<'_> {
        RawView {
            padded_width: self.board.padded_width,
            goals_here: &self.board.goals_here,
            occupant: &self.board.occupant,
            shared_code: &self.board.shared_code,
            pos: &self.pos,
            goal_pos: &self.goal,
            cells: &self.cells,
            goal_cells: &self.goal_cells,
            step_offsets: &self.board.step_offsets,
        }
    }

    /// Goal distance (shortest path on the static layout) of agent `i`;
    /// [`crate::map::UNREACHABLE`] if its goal cannot be reached.
    pub fn goal_distance(&self, agent: usize) -> u16 {
        self.goal_distance_at(agent, self.position(agent))
    }

    /// Goal distance of agent `i` from `cell` (inside the grid).
    pub(crate) fn goal_distance_at(&self, agent: usize, cell: Cell) -> u16 {
        self.goal_distance[agent][self.map.grid.index(cell)]
    }

    /// Steps agent `i` has been off its goal since it last stood on it (0
    /// on its goal and at the episode start): PIBT's priority.
    pub fn steps_off_goal(&self, agent: usize) -> u32 {
        self.off_goal[agent]
    }

    /// True if agent `a` has priority over agent `b`: longer off its goal,
    /// ties to the lower index (see [`crate::recipe`]).
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_env::{EnvConfig, GridEnv, Map};
    /// let env = GridEnv::new(Arc::new(Map::load("rm-2.1").unwrap()), EnvConfig::default()).unwrap();
    /// // At the start nobody has waited: the index decides.
    /// assert!(env.outranks(0, 1) && !env.outranks(1, 0));
    /// ```
    pub fn outranks(&self, a: usize, b: usize) -> bool {
        (self.off_goal[a], std::cmp::Reverse(a)) > (self.off_goal[b], std::cmp::Reverse(b))
    }
}

/// Borrowed internals for the observation encoders.
pub(crate) struct RawView<'a> {
    pub padded_width: usize,
    pub goals_here: &'a [u16],
    pub occupant: &'a [u16],
    pub shared_code: &'a [u8],
    pub pos: &'a [usize],
    pub goal_pos: &'a [usize],
    pub cells: &'a [Cell],
    pub goal_cells: &'a [Cell],
    pub step_offsets: &'a [isize; NUM_ACTIONS],
}

impl RawView<'_> {
    /// The padded-index range of each row of `agent`'s window of radius
    /// `r`, top row first (the padding keeps every range inside the grid's
    /// buffers).
    pub fn window_rows(&self, agent: usize, r: usize) -> impl Iterator<Item = Range<usize>> + '_ {
        let side = 2 * r + 1;
        let top_left = self.pos[agent] - r * self.padded_width - r;
        (0..side).map(move |k| {
            let start = top_left + k * self.padded_width;
            start..start + side
        })
    }
}
