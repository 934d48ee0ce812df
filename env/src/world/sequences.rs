//! Lifelong episodes on given goal sequences, and goals that agents share.
//!
//! A benchmark such as POGEMA's lifelong warehouse fixes every agent's
//! tasks in advance: its start and the goals it is given one after another
//! ([`GridEnv::reset_with_sequences`]). The env then draws nothing: an agent
//! standing on its goal after a step gets the next goal of its own
//! sequence. POGEMA's goals are not exclusive, so several agents may head
//! for one cell at once; the board counts the goals on each cell, and an
//! agent's own goal reads as its own in its observation whoever else heads
//! there.
//!
//! An agent that reaches the *last* goal of its sequence keeps that goal,
//! earns nothing more and is counted in [`GridEnv::sequence_exhausted`]: a
//! measurement whose sequences run out is no measurement, and its runner
//! refuses it (`buridan_eval::throughput`).

use super::{cell_problem, GridEnv};
use crate::error::EnvError;
use crate::map::Cell;

impl GridEnv {
    /// Starts a lifelong episode on given tasks: agent `i` starts on
    /// `starts[i]` and is given the goals of `sequences[i]` in order, the
    /// next one each time it stands on its current one after a step.
    ///
    /// Checked before anything changes: the env is in lifelong mode, one
    /// start and one non-empty sequence per agent, every cell inside the
    /// grid and off the walls, starts pairwise distinct. Goals may be
    /// shared: between agents, and with another agent's start.
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_env::{Cell, EnvConfig, GridEnv, Map, Rules};
    /// let map = Arc::new(Map::load("rm-1.1").unwrap());
    /// let cfg = EnvConfig { agents: 2, lifelong: true, rules: Rules::Pogema, ..EnvConfig::default() };
    /// let mut env = GridEnv::new(map, cfg).unwrap();
    /// let starts = [Cell::new(1, 1), Cell::new(1, 3)];
    /// // Both head for (1, 2) first; agent 0 then for (1, 1).
    /// let sequences = vec![
    ///     vec![Cell::new(1, 2), Cell::new(1, 1)],
    ///     vec![Cell::new(1, 2), Cell::new(1, 4)],
    /// ];
    /// env.reset_with_sequences(0, &starts, &sequences).unwrap();
    /// let mut rewards = [0.0; 2];
    /// env.step(&[2, 0], &mut rewards).unwrap();
    /// assert_eq!(env.goals(), [Cell::new(1, 1), Cell::new(1, 2)]);
    /// assert_eq!(env.stats().goals_reached, 1);
    /// ```
    pub fn reset_with_sequences(
        &mut self,
        episode: u64,
        starts: &[Cell],
        sequences: &[Vec<Cell>],
    ) -> Result<(), EnvError> {
        if !self.cfg.lifelong {
            return Err(EnvError::SequencesNeedLifelong);
        }
        EnvError::check_len("goal sequences", self.cfg.agents, sequences.len())?;
        let mut first = Vec::with_capacity(sequences.len());
        for (agent, sequence) in sequences.iter().enumerate() {
            let Some(&goal) = sequence.first() else {
                return Err(EnvError::EmptySequence { agent });
            };
            first.push(goal);
            for (index, &cell) in sequence.iter().enumerate().skip(1) {
                if let Some(problem) = cell_problem(&self.map.grid, cell) {
                    return Err(EnvError::BadSequenceGoal {
                        agent,
                        index,
                        row: cell.row,
                        col: cell.col,
                        problem,
                    });
                }
            }
        }
        self.validate_instance(starts, &first, true)?;
        self.place(episode, starts, &first);
        self.shared_goals = true;
        self.sequences = sequences.to_vec();
        Ok(())
    }

    /// [`Self::reset_with`] whose goals may be shared between agents (and
    /// whose [`Self::report`]s may then name shared goals): the picture of
    /// a fleet whose tasks are not exclusive. Lifelong goal draws, if any,
    /// still avoid every goal.
    pub fn reset_with_shared_goals(
        &mut self,
        episode: u64,
        starts: &[Cell],
        goals: &[Cell],
    ) -> Result<(), EnvError> {
        self.validate_instance(starts, goals, true)?;
        self.place(episode, starts, goals);
        self.shared_goals = true;
        Ok(())
    }

    /// Whether this episode allows shared goals.
    pub fn allows_shared_goals(&self) -> bool {
        self.shared_goals
    }

    /// The first agent that reached the last goal of its sequence
    /// ([`Self::reset_with_sequences`]), if any.
    pub fn sequence_exhausted(&self) -> Option<usize> {
        self.exhausted.iter().position(|&e| e)
    }

    /// How many goals of its sequence agent `agent` has been given so far
    /// (the one it heads for included); 1 without sequences.
    pub fn goals_given(&self, agent: usize) -> usize {
        self.sequence_index[agent] + 1
    }

    /// Gives agent `agent`, which stands on its goal, its next goal: the
    /// next of its sequence, or a draw without sequences. At the end of its
    /// sequence it keeps its goal and is marked exhausted.
    pub(super) fn next_goal(&mut self, agent: usize) {
        if self.sequences.is_empty() {
            return self.draw_new_goal(agent);
        }
        let next = self.sequence_index[agent] + 1;
        match self.sequences[agent].get(next) {
            Some(&cell) => {
                self.sequence_index[agent] = next;
                self.set_goal(agent, cell);
            }
            None => self.exhausted[agent] = true,
        }
    }
}
