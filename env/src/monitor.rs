//! Deadlock and livelock detection.
//!
//! Definitions (beyond the dissertation, which only counts failures):
//!
//! - An agent is **stalled** when, for the last `k` steps (`stall_window`,
//!   default 8), it was off its goal, requested a move (action ≠ 0) every
//!   step, and never got closer to its goal than it was when the window began
//!   (distance = shortest-path steps on the static layout, ignoring agents).
//! - A stalled agent is **deadlocked** if it has not changed cell during
//!   those `k` steps (every move was blocked, or it did not leave its cell)
//!   and another agent is *nearby* (Manhattan distance ≤ 2): it is trying,
//!   and someone is in the way.
//! - A stalled agent is **livelocked** if it did change cell during the window
//!   and another agent is nearby: it keeps moving, but around, not forward.
//!
//! Per step the monitor reports how many agents are deadlocked and
//! livelocked; per episode it counts the steps with at least one deadlocked
//! (livelocked) agent and the *deadlock events* — the times an agent becomes
//! deadlocked.
//!
//! ```
//! use buridan_env::monitor::StallMonitor;
//! let mut m = StallMonitor::new(2, 3);
//! // Two agents face each other, both keep pushing, nobody moves.
//! let pos = [(0, 0), (0, 1)];
//! m.reset(&[5, 5], &pos);
//! for _ in 0..3 {
//!     m.observe(&[2, 4], &[5, 5], &pos, &[false, false]);
//! }
//! assert_eq!(m.deadlocked(), 2);
//! assert_eq!(m.deadlock_events(), 2);
//! ```

/// Per-agent stall tracking and per-episode counters.
#[derive(Debug, Clone)]
pub struct StallMonitor {
    window: u32,
    streak: Vec<u32>,
    best_distance: Vec<u16>,
    window_cell: Vec<(usize, usize)>,
    moved: Vec<bool>,
    was_deadlocked: Vec<bool>,
    deadlocked_now: usize,
    livelocked_now: usize,
    deadlock_steps: u32,
    livelock_steps: u32,
    deadlock_events: u32,
}

impl StallMonitor {
    /// A monitor for `agents` agents with stall window `window` steps.
    pub fn new(agents: usize, window: u32) -> Self {
        Self {
            window: window.max(1),
            streak: vec![0; agents],
            best_distance: vec![u16::MAX; agents],
            window_cell: vec![(usize::MAX, usize::MAX); agents],
            moved: vec![false; agents],
            was_deadlocked: vec![false; agents],
            deadlocked_now: 0,
            livelocked_now: 0,
            deadlock_steps: 0,
            livelock_steps: 0,
            deadlock_events: 0,
        }
    }

    /// Starts a new episode from each agent's goal distance and `(row, col)`.
    pub fn reset(&mut self, distance: &[u16], cell: &[(usize, usize)]) {
        let n = self.streak.len();
        *self = Self::new(n, self.window);
        self.best_distance.copy_from_slice(distance);
        self.window_cell.copy_from_slice(cell);
    }

    /// Records one step: the actions taken, each agent's goal distance and
    /// `(row, col)` after the step, and whether it stands on its goal.
    pub fn observe(
        &mut self,
        actions: &[u8],
        distance: &[u16],
        cell: &[(usize, usize)],
        at_goal: &[bool],
    ) {
        let n = self.streak.len();
        let mut any_stalled = false;
        for i in 0..n {
            let pushing = actions[i] != 0 && !at_goal[i];
            if pushing && distance[i] >= self.best_distance[i] {
                self.streak[i] += 1;
                self.moved[i] |= cell[i] != self.window_cell[i];
            } else {
                // Progress, a pause or arrival: a fresh window starts here.
                self.streak[i] = 0;
                self.best_distance[i] = distance[i];
                self.window_cell[i] = cell[i];
                self.moved[i] = false;
            }
            any_stalled |= self.streak[i] >= self.window;
        }
        self.deadlocked_now = 0;
        self.livelocked_now = 0;
        if !any_stalled {
            self.was_deadlocked.iter_mut().for_each(|d| *d = false);
            return;
        }
        for i in 0..n {
            let stalled = self.streak[i] >= self.window;
            let nearby = stalled
                && (0..n).any(|j| {
                    j != i && cell[i].0.abs_diff(cell[j].0) + cell[i].1.abs_diff(cell[j].1) <= 2
                });
            let deadlocked = nearby && !self.moved[i];
            if deadlocked {
                self.deadlocked_now += 1;
                if !self.was_deadlocked[i] {
                    self.deadlock_events += 1;
                }
            } else if nearby {
                self.livelocked_now += 1;
            }
            self.was_deadlocked[i] = deadlocked;
        }
        self.deadlock_steps += u32::from(self.deadlocked_now > 0);
        self.livelock_steps += u32::from(self.livelocked_now > 0);
    }

    /// Agents deadlocked after the last step.
    pub fn deadlocked(&self) -> usize {
        self.deadlocked_now
    }

    /// Agents livelocked after the last step.
    pub fn livelocked(&self) -> usize {
        self.livelocked_now
    }

    /// Steps of this episode with at least one deadlocked agent.
    pub fn deadlock_steps(&self) -> u32 {
        self.deadlock_steps
    }

    /// Steps of this episode with at least one livelocked agent.
    pub fn livelock_steps(&self) -> u32 {
        self.livelock_steps
    }

    /// Times in this episode that an agent became deadlocked.
    pub fn deadlock_events(&self) -> u32 {
        self.deadlock_events
    }
}
