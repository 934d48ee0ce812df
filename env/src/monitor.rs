//! Deadlock and livelock detection, judged on what agents achieve.
//!
//! The dissertation only counts failed episodes. This monitor says *why* an
//! episode is failing while it runs, and it looks at outcomes, not requests:
//! under action masking a blocked agent is offered only "stay", never asks
//! for a move and so never "fails" one — a detector built on failed move
//! requests sees no deadlock in episodes that end in one.
//!
//! # Definitions
//!
//! Distances are shortest-path steps to the agent's goal on the static
//! layout (other agents ignored); `k` is the window ([`EnvConfig::stall_window`],
//! default [`DEFAULT_WINDOW`] = 8), `r` the radius (default [`DEFAULT_RADIUS`] = 3).
//!
//! - **Progress.** An agent makes progress in a step if its goal distance
//!   after the step is smaller than every distance it had in the `k` steps
//!   before (a new low over the sliding window). Walking towards the goal is
//!   progress at every step; going back and forth, or waiting, is not;
//!   coming back after giving way is progress again once the agent is closer
//!   than anywhere it stood during the last `k` steps. Reaching the goal is
//!   progress the first time only (as its +0.5 reward): stepping off one's
//!   goal and back on, or returning to it after giving way, is not.
//! - **Stuck.** An agent is stuck when it is off its goal and has made no
//!   progress in the last `k` steps (an episode start, and in lifelong mode
//!   a new goal, start the count anew). An agent that parked on its goal
//!   long ago and steps off is stuck at once.
//! - **In the way.** Agent `j` is in agent `i`'s way when it stands within
//!   Manhattan distance `r` of `i` on a cell closer to `i`'s goal than `i`'s
//!   own cell (ahead of `i`, typically on its shortest path).
//! - **Jammed.** A stuck agent is jammed when someone is in its way and
//!   everyone it waits on — the agents in its way, the agents in theirs, and
//!   so on — is stuck too or stands on its goal. Put differently, `i` and
//!   the agents it waits on form a group near each other in which *no agent
//!   off its goal is getting closer* to it. An agent parked on its goal in a
//!   corridor jams the ones behind it, but is never jammed itself.
//! - **Deadlocked / livelocked.** A jammed agent is *deadlocked* if it has
//!   not changed cell during the last `k` steps (it waits, e.g. choosing
//!   "stay" under a mask), and *livelocked* if it has (it moves, but around,
//!   not forward).
//!
//! What is *not* a deadlock: a stuck agent with nobody in its way (pushing
//! into a wall, dithering in the open: the policy's failure, reported by
//! [`StallMonitor::stuck`] only); an agent waiting behind one that is making
//! progress (a queue, or giving way); an agent that merely passes a jam
//! without waiting on it. The first `k` steps of a jam are not counted (the
//! window must fill before anyone is stuck), and a group that keeps
//! exchanging places without anyone reaching a new low is a livelock.
//!
//! Per step the monitor reports how many agents are deadlocked and
//! livelocked; per episode it counts the steps with at least one deadlocked
//! (livelocked) agent, the *deadlock events* (an agent becoming deadlocked),
//! and, per agent, its deadlocked and livelocked steps.
//!
//! ```
//! use buridan_env::monitor::StallMonitor;
//! // A 1-wide corridor: agent 0 at column 2 wants column 5, agent 1 at
//! // column 3 wants column 0. Each is in the other's way; both "stay".
//! let goals = [5usize, 0];
//! let dist = |i: usize, (_, col): (usize, usize)| col.abs_diff(goals[i]) as u16;
//! let cells = [(0, 2), (0, 3)];
//! let mut m = StallMonitor::new(2, 3);
//! m.reset(&cells, dist);
//! for _ in 0..3 {
//!     m.observe(&cells, &[false, false], &[false, false], dist);
//! }
//! assert_eq!(m.deadlocked(), 2);
//! assert_eq!(m.deadlock_events(), 2);
//! assert_eq!(m.agent_deadlock_steps(), [1, 1]);
//! ```
//!
//! [`EnvConfig::stall_window`]: crate::EnvConfig::stall_window

/// Default window `k`: steps without progress before an agent is stuck.
pub const DEFAULT_WINDOW: u32 = 8;

/// Default radius `r` of "in the way" (Manhattan distance). 3 rather than 2:
/// on the seed-42 greedy evaluation of the shipped PPO rm-2.1 policy, radius 2
/// missed a livelock in which an agent parked on its goal three cells ahead
/// on the other's only route (both mirroring each other's moves, 80 steps).
pub const DEFAULT_RADIUS: usize = 3;

/// What the monitor concluded about one agent after the last step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum AgentState {
    /// Progressing, at its goal, or stuck on its own (nobody in its way).
    #[default]
    Free,
    /// Stuck in a jam and has not changed cell for `k` steps.
    Deadlocked,
    /// Stuck in a jam but has changed cell within the last `k` steps.
    Livelocked,
}

/// Per-agent progress tracking, jam detection and per-episode counters
/// (definitions in the [module docs](self)).
#[derive(Debug, Clone)]
pub struct StallMonitor {
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

impl StallMonitor {
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
    ///
    /// ```
    /// let m = buridan_env::monitor::StallMonitor::new(4, 8).with_radius(1);
    /// assert_eq!((m.window(), m.radius()), (8, 1));
    /// ```
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
