//! The stall watch: the deadlock/livelock monitor and its inputs.

use crate::map::Cell;
use crate::monitor::StallMonitor;

/// A [`StallMonitor`] with the inputs it observes after each step, kept up
/// to date as agents move rather than refilled every step: each agent's
/// `(row, col)`, whether it stands on its goal, and (lifelong mode) whether
/// it got a new goal this step.
#[derive(Debug, Clone)]
pub(super) struct StallWatch {
    /// The monitor.
    monitor: StallMonitor,
    /// Each agent's `(row, col)`.
    cells: Vec<(usize, usize)>,
    /// Whether each agent stands on its goal (false after a new goal).
    at_goal: Vec<bool>,
    /// Lifelong mode: agents that reached a goal this step (and got a new
    /// one); all false between steps.
    arrived: Vec<bool>,
}

impl StallWatch {
    /// A watch over `agents` agents with the monitor's window `window`.
    pub(super) fn new(agents: usize, window: u32) -> Self {
        Self {
            monitor: StallMonitor::new(agents, window),
            cells: vec![(0, 0); agents],
            at_goal: vec![false; agents],
            arrived: vec![false; agents],
        }
    }

    /// Starts an episode with the agents on `cells`, `at_goal(i)` whether
    /// agent `i` stands on its goal, `distance(i, cell)` its goal distance
    /// from `cell`.
    pub(super) fn reset(
        &mut self,
        cells: &[Cell],
        at_goal: impl Fn(usize) -> bool,
        distance: impl Fn(usize, (usize, usize)) -> u16,
    ) {
        for (i, cell) in cells.iter().enumerate() {
            self.cells[i] = (cell.row, cell.col);
            self.at_goal[i] = at_goal(i);
        }
        self.monitor.reset(&self.cells, distance);
    }

    /// Agent `agent` now stands on `cell`.
    #[inline(always)]
    pub(super) fn moved(&mut self, agent: usize, cell: Cell) {
        self.cells[agent] = (cell.row, cell.col);
    }

    /// Whether agent `agent` stands on its goal after this step.
    #[inline(always)]
    pub(super) fn set_at_goal(&mut self, agent: usize, home: bool) {
        self.at_goal[agent] = home;
    }

    /// Agent `agent` reached its goal this step and got a new one (lifelong
    /// mode): it is off its (new) goal, and its progress starts afresh.
    #[inline]
    pub(super) fn new_goal(&mut self, agent: usize) {
        self.arrived[agent] = true;
        self.at_goal[agent] = false;
    }

    /// The agents that got a new goal this step.
    #[inline]
    pub(super) fn arrived(&self) -> &[bool] {
        &self.arrived
    }

    /// Shows the monitor this step's inputs, `distance(i, cell)` being agent
    /// `i`'s distance from `cell` to its current goal; then forgets the
    /// step's arrivals.
    #[inline]
    pub(super) fn observe(&mut self, distance: impl Fn(usize, (usize, usize)) -> u16) {
        self.monitor
            .observe(&self.cells, &self.at_goal, &self.arrived, distance);
        self.arrived.fill(false);
    }

    /// The monitor.
    pub(super) fn monitor(&self) -> &StallMonitor {
        &self.monitor
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Manhattan distance to the goal `(0, col)` of agent `i`, col = 3i.
    fn distance(i: usize, (r, c): (usize, usize)) -> u16 {
        (r + c.abs_diff(3 * i)) as u16
    }

    #[test]
    fn inputs_follow_moves_and_arrivals() {
        let mut w = StallWatch::new(2, 2);
        w.reset(&[Cell::new(2, 0), Cell::new(0, 3)], |i| i == 1, distance);
        assert_eq!(w.cells, [(2, 0), (0, 3)]);
        assert_eq!(w.at_goal, [false, true]);
        w.moved(0, Cell::new(1, 0));
        w.set_at_goal(0, false);
        w.new_goal(1);
        assert_eq!(w.cells, [(1, 0), (0, 3)]);
        assert_eq!(
            (w.at_goal.as_slice(), w.arrived()),
            (&[false, false][..], &[false, true][..])
        );
        w.observe(distance);
        assert_eq!(w.arrived(), [false, false]);
    }

    #[test]
    fn an_agent_that_waits_off_its_goal_gets_stuck() {
        let mut w = StallWatch::new(1, 2);
        w.reset(&[Cell::new(2, 0)], |_| false, distance);
        for _ in 0..3 {
            w.set_at_goal(0, false);
            w.observe(distance);
        }
        assert!(w.monitor().is_stuck(0));
        // Moving closer frees it.
        w.moved(0, Cell::new(1, 0));
        w.observe(distance);
        assert!(!w.monitor().is_stuck(0));
    }
}
