//! The deadlock detector as first written (`buridan_env::monitor` at the
//! commit that introduced it): a straightforward implementation kept as the
//! reference the optimised `StallMonitor` must agree with, step by step.
#![allow(dead_code)]

use buridan_env::monitor::{AgentState, DEFAULT_RADIUS};

/// Per-agent progress tracking, jam detection and per-episode counters
/// (definitions in `buridan_env::monitor`).
#[derive(Debug, Clone)]
pub struct ReferenceMonitor {
    window: u32,
    radius: usize,
    /// Steps observed in this episode.
    t: u32,
    /// Per agent, its goal distances of the last `window` steps, a ring
    /// indexed by `t % window`.
    history: Vec<u16>,
    /// Steps since the agent's last progress (or reset, or new goal).
    streak: Vec<u32>,
    /// Off its goal and `streak >= window`.
    stuck: Vec<bool>,
    /// Has stood on its (current) goal in this episode.
    reached: Vec<bool>,
    /// Each agent's cell after the last step.
    cell: Vec<(usize, usize)>,
    /// Step at which the agent last changed cell (0 = since reset).
    last_move: Vec<u32>,
    state: Vec<AgentState>,
    agent_deadlock_steps: Vec<u32>,
    agent_livelock_steps: Vec<u32>,
    // Scratch of the jam search: per stuck agent the agents in its way,
    // whether it can escape (waits on someone making progress), the result.
    in_way: Vec<Vec<usize>>,
    escapes: Vec<bool>,
    jammed: Vec<bool>,
    stuck_now: usize,
    deadlocked_now: usize,
    livelocked_now: usize,
    deadlock_steps: u32,
    livelock_steps: u32,
    deadlock_events: u32,
}

impl ReferenceMonitor {
    /// A monitor for `agents` agents with window `window` steps (at least
    /// 1) and radius [`DEFAULT_RADIUS`].
    pub fn new(agents: usize, window: u32) -> Self {
        let window = window.max(1);
        Self {
            window,
            radius: DEFAULT_RADIUS,
            t: 0,
            history: vec![0; agents * window as usize],
            streak: vec![0; agents],
            stuck: vec![false; agents],
            reached: vec![false; agents],
            cell: vec![(0, 0); agents],
            last_move: vec![0; agents],
            state: vec![AgentState::Free; agents],
            agent_deadlock_steps: vec![0; agents],
            agent_livelock_steps: vec![0; agents],
            in_way: vec![Vec::new(); agents],
            escapes: vec![false; agents],
            jammed: vec![false; agents],
            stuck_now: 0,
            deadlocked_now: 0,
            livelocked_now: 0,
            deadlock_steps: 0,
            livelock_steps: 0,
            deadlock_events: 0,
        }
    }

    /// The same monitor with "in the way" radius `radius` (Manhattan).
    pub fn with_radius(mut self, radius: usize) -> Self {
        self.radius = radius;
        self
    }

    /// The window `k`.
    pub fn window(&self) -> u32 {
        self.window
    }

    /// The radius `r`.
    pub fn radius(&self) -> usize {
        self.radius
    }

    fn agents(&self) -> usize {
        self.streak.len()
    }

    /// Starts a new episode from each agent's `(row, col)`;
    /// `distance(i, cell)` is agent `i`'s goal distance from `cell`.
    pub fn reset(
        &mut self,
        cells: &[(usize, usize)],
        distance: impl Fn(usize, (usize, usize)) -> u16,
    ) {
        let w = self.window as usize;
        self.t = 0;
        for (i, &cell) in cells.iter().enumerate() {
            let d = distance(i, cell);
            self.history[i * w..(i + 1) * w].fill(d);
            self.reached[i] = d == 0;
        }
        self.streak.fill(0);
        self.stuck.fill(false);
        self.cell.copy_from_slice(cells);
        self.last_move.fill(0);
        self.state.fill(AgentState::Free);
        self.agent_deadlock_steps.fill(0);
        self.agent_livelock_steps.fill(0);
        self.stuck_now = 0;
        self.deadlocked_now = 0;
        self.livelocked_now = 0;
        self.deadlock_steps = 0;
        self.livelock_steps = 0;
        self.deadlock_events = 0;
    }

    /// Records one step: each agent's `(row, col)` after the step, whether
    /// it stands on its goal, whether it got a new goal this step (lifelong
    /// mode; its progress history then starts afresh), and
    /// `distance(i, cell)`, agent `i`'s distance from `cell` to its current
    /// goal.
    pub fn observe(
        &mut self,
        cells: &[(usize, usize)],
        at_goal: &[bool],
        new_goal: &[bool],
        distance: impl Fn(usize, (usize, usize)) -> u16,
    ) {
        let n = self.agents();
        let w = self.window as usize;
        self.t += 1;
        let slot = self.t as usize % w;
        self.stuck_now = 0;
        for i in 0..n {
            if cells[i] != self.cell[i] {
                self.cell[i] = cells[i];
                self.last_move[i] = self.t;
            }
            let d = distance(i, cells[i]);
            let history = &mut self.history[i * w..(i + 1) * w];
            if new_goal[i] {
                history.fill(d);
                self.streak[i] = 0;
                self.stuck[i] = false;
                self.reached[i] = at_goal[i];
                continue;
            }
            // `history` holds the last `w` distances before this step. Only
            // the first arrival counts: coming back home is no progress.
            let repeat_arrival = at_goal[i] && self.reached[i];
            self.reached[i] |= at_goal[i];
            if !repeat_arrival && history.iter().all(|&h| d < h) {
                self.streak[i] = 0;
            } else {
                self.streak[i] = self.streak[i].saturating_add(1);
            }
            history[slot] = d;
            self.stuck[i] = !at_goal[i] && self.streak[i] >= self.window;
            self.stuck_now += usize::from(self.stuck[i]);
        }
        self.deadlocked_now = 0;
        self.livelocked_now = 0;
        if self.stuck_now == 0 {
            self.state.fill(AgentState::Free);
            return;
        }
        self.find_jams(cells, at_goal, &distance);
        for i in 0..n {
            let new = if !self.jammed[i] {
                AgentState::Free
            } else if self.t - self.last_move[i] >= self.window {
                AgentState::Deadlocked
            } else {
                AgentState::Livelocked
            };
            match new {
                AgentState::Deadlocked => {
                    self.deadlocked_now += 1;
                    self.agent_deadlock_steps[i] += 1;
                    if self.state[i] != AgentState::Deadlocked {
                        self.deadlock_events += 1;
                    }
                }
                AgentState::Livelocked => {
                    self.livelocked_now += 1;
                    self.agent_livelock_steps[i] += 1;
                }
                AgentState::Free => {}
            }
            self.state[i] = new;
        }
        self.deadlock_steps += u32::from(self.deadlocked_now > 0);
        self.livelock_steps += u32::from(self.livelocked_now > 0);
    }

    /// Marks the jammed agents: stuck, someone in their way, and every
    /// agent reachable through "in the way" links stuck or on its goal.
    fn find_jams(
        &mut self,
        cells: &[(usize, usize)],
        at_goal: &[bool],
        distance: &impl Fn(usize, (usize, usize)) -> u16,
    ) {
        let n = self.agents();
        let stuck = |m: &Self, i: usize| m.stuck[i];
        for i in 0..n {
            self.in_way[i].clear();
            if !stuck(self, i) {
                continue;
            }
            let (a, di) = (cells[i], distance(i, cells[i]));
            for (j, &b) in cells.iter().enumerate() {
                if j != i
                    && a.0.abs_diff(b.0) + a.1.abs_diff(b.1) <= self.radius
                    && distance(i, b) < di
                {
                    self.in_way[i].push(j);
                }
            }
        }
        // An agent escapes if it waits on an agent that is making progress
        // (off its goal and not stuck) or on one that escapes.
        self.escapes.fill(false);
        loop {
            let mut changed = false;
            for i in 0..n {
                if self.escapes[i] || !stuck(self, i) {
                    continue;
                }
                let escapes = self.in_way[i]
                    .iter()
                    .any(|&j| self.escapes[j] || (!at_goal[j] && !stuck(self, j)));
                if escapes {
                    self.escapes[i] = true;
                    changed = true;
                }
            }
            if !changed {
                break;
            }
        }
        for i in 0..n {
            self.jammed[i] = stuck(self, i) && !self.in_way[i].is_empty() && !self.escapes[i];
        }
    }

    /// Agents stuck after the last step, in a jam or not.
    pub fn stuck(&self) -> usize {
        self.stuck_now
    }

    /// Agents deadlocked after the last step.
    pub fn deadlocked(&self) -> usize {
        self.deadlocked_now
    }

    /// Agents livelocked after the last step.
    pub fn livelocked(&self) -> usize {
        self.livelocked_now
    }

    /// What the monitor concluded about `agent` after the last step.
    pub fn state(&self, agent: usize) -> AgentState {
        self.state[agent]
    }

    /// Whether `agent` is stuck: off its goal (after the last step) and
    /// without progress for `k` steps.
    pub fn is_stuck(&self, agent: usize) -> bool {
        self.stuck[agent]
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

    /// Per agent, its deadlocked steps in this episode.
    pub fn agent_deadlock_steps(&self) -> &[u32] {
        &self.agent_deadlock_steps
    }

    /// Per agent, its livelocked steps in this episode.
    pub fn agent_livelock_steps(&self) -> &[u32] {
        &self.agent_livelock_steps
    }

    /// Agents deadlocked at least once in this episode.
    pub fn deadlocked_agents(&self) -> usize {
        self.agent_deadlock_steps.iter().filter(|&&s| s > 0).count()
    }
}
