//! The progress fallback of the shield: each agent's distance to its goal
//! and its progress towards it; an agent that stalls follows its shortest
//! path.

use buridan_env::{Cell, Grid, NUM_ACTIONS};

use crate::graph::{distance_table, NONE};

use super::yielding::rerank;

/// Per agent: its goal (once seen) and the distance table to it, rebuilt
/// only when the goal changes.
#[derive(Default)]
pub(super) struct GoalDistances {
    pub(super) goal: Vec<Option<Cell>>,
    pub(super) table: Vec<Vec<u32>>,
}

impl GoalDistances {
    /// Keeps agent `i`'s table for `goal` and says whether the goal is new.
    pub(super) fn update(&mut self, grid: &Grid, i: usize, goal: Cell) -> bool {
        if self.goal.len() <= i {
            self.goal.resize(i + 1, None);
            self.table.resize_with(i + 1, Vec::new);
        }
        if self.goal[i] == Some(goal) {
            return false;
        }
        self.goal[i] = Some(goal);
        self.table[i] = distance_table(grid, goal);
        true
    }
}

/// Each agent's progress towards its goal, for
/// [`Shield::with_progress_fallback`](super::Shield::with_progress_fallback).
pub(super) struct ProgressFallback {
    /// Steps without progress before the shortest path leads.
    pub(super) patience: u32,
    /// Per agent: the shortest distance to its goal since it last
    /// improved it or left its goal.
    pub(super) best: Vec<u32>,
    /// Per agent: steps since then.
    pub(super) waiting: Vec<u32>,
    /// Per agent: whether it follows its shortest path this step.
    pub(super) stalled: Vec<bool>,
    /// Whether only the first arrival on a goal counts as progress
    /// ([`Shield::with_goal_settling`](super::Shield::with_goal_settling)).
    pub(super) settle: bool,
    /// Per agent: whether it has stood on its current goal (with `settle`).
    pub(super) arrived: Vec<bool>,
}

impl ProgressFallback {
    /// Sizes the per-agent tables for `n` agents.
    pub(super) fn fit(&mut self, n: usize) {
        self.best.resize(n, u32::MAX);
        self.waiting.resize(n, 0);
        self.stalled.resize(n, false);
        self.arrived.resize(n, false);
    }

    /// Forgets every agent's progress: a new episode.
    pub(super) fn restart(&mut self) {
        self.best.iter_mut().for_each(|b| *b = u32::MAX);
        self.waiting.iter_mut().for_each(|w| *w = 0);
        self.arrived.iter_mut().for_each(|a| *a = false);
    }

    /// Updates agent `i`'s progress, `d` steps from its goal (`new_goal`:
    /// a goal it has just been given), and says whether it has waited
    /// `patience` steps or more.
    pub(super) fn update(&mut self, i: usize, d: u32, new_goal: bool) -> bool {
        if new_goal {
            self.best[i] = u32::MAX;
            self.waiting[i] = 0;
            self.arrived[i] = false;
        }
        if self.settle && self.arrived[i] {
            // Back on the goal after leaving it is no progress, and resting
            // there does not count as waiting: an agent that steps on and
            // off its goal runs out of patience off it, then settles on it.
            if d > 0 {
                self.waiting[i] += 1;
            }
        } else if d == 0 {
            self.arrived[i] = self.settle;
            // On the goal: nothing to wait for; leaving it starts afresh.
            self.best[i] = u32::MAX;
            self.waiting[i] = 0;
        } else if d < self.best[i] {
            self.best[i] = d;
            self.waiting[i] = 0;
        } else {
            self.waiting[i] += 1;
        }
        self.stalled[i] = self.waiting[i] >= self.patience;
        self.stalled[i]
    }
}

/// An agent's actions from `moves` (its cell's move table) by the distance
/// they leave to its goal (`dist`, its table; walls and the edge last), ties
/// by `rank` (the policy's order).
pub(super) fn shortest_first(
    dist: &[u32],
    moves: &[u32; NUM_ACTIONS],
    rank: &mut [u8; NUM_ACTIONS],
) {
    let after = |a: u8| match moves[usize::from(a)] {
        NONE => u32::MAX,
        v => dist[v as usize],
    };
    rerank(rank, after);
}
