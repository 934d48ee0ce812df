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

/// Radii up to this take the fast search for neighbours ([`near_lanes`]);
/// larger ones the plain one.
const PACKED_RADIUS: usize = 63;

/// A word of eight 8-bit lanes, each 1.
const LANES: u64 = 0x0101_0101_0101_0101;

/// The top bit of each lane.
const TOPS: u64 = 0x8080_8080_8080_8080;

/// A cell rotated by 45°, `row + col` and `row - col`, modulo 128. The
/// Manhattan distance of two cells is the larger of the differences of
/// the rotated coordinates (their Chebyshev distance), so "within the
/// radius" is two range tests; modulo 128 they can only err by including
/// a far cell, never by missing a near one (for radii up to 63).
fn rotated((row, col): (usize, usize)) -> (u64, u64) {
    (
        (row.wrapping_add(col) & 0x7f) as u64,
        (row.wrapping_sub(col) & 0x7f) as u64,
    )
}

/// Sets lane `lane` of a pair of words to `cell` [`rotated`].
fn set_lanes(words: &mut [u64; 2], lane: usize, cell: (usize, usize)) {
    let (diag, anti) = rotated(cell);
    let shift = lane * 8;
    words[0] = words[0] & !(0xff << shift) | diag << shift;
    words[1] = words[1] & !(0xff << shift) | anti << shift;
}

/// The lanes of `words` (their top bits) whose rotated cell `(x, y)` has
/// `(x - x0) mod 128 <= 2r` and `(y - y0) mod 128 <= 2r`, eight at once,
/// given `low = (x0 - r, y0 - r) mod 128`: each lane computes `d = (x | 128)
/// - (x0 - r)`, which lies in `(0, 256)`, so that no lane borrows from the
/// next, and tests `(d mod 128) + 127 - 2r < 128`. This includes every cell
/// within Manhattan distance `r` of `(x0, y0)`.
fn near_lanes(words: [u64; 2], low: (u64, u64), r: u64) -> u64 {
    let dx = ((words[0] | TOPS) - LANES * low.0) & !TOPS;
    let dy = ((words[1] | TOPS) - LANES * low.1) & !TOPS;
    let limit = LANES * (127 - 2 * r);
    !((dx + limit) | (dy + limit)) & TOPS
}

/// Fills an agent's window (`groups` of eight, `w` slots used) with `d`.
fn fill_window(groups: &mut [[u16; 8]], w: usize, d: u16) {
    for (k, slot) in groups.as_flattened_mut().iter_mut().enumerate() {
        *slot = if k < w { d } else { u16::MAX };
    }
}

/// The smallest distance in an agent's window, whose group `current` (at
/// index `at`) was just updated.
fn window_low(groups: &[[u16; 8]], at: usize, current: [u16; 8]) -> u16 {
    let mut low = current;
    for (k, group) in groups.iter().enumerate() {
        if k != at {
            for (low, &d) in low.iter_mut().zip(group) {
                *low = (*low).min(d);
            }
        }
    }
    // A tree, not a chain of dependent minima.
    for half in [4, 2, 1] {
        for k in 0..half {
            low[k] = low[k].min(low[k + half]);
        }
    }
    low[0]
}

/// One agent's progress bookkeeping.
#[derive(Debug, Clone, Copy, Default)]
struct Track {
    /// Its cell after the last step.
    cell: (usize, usize),
    /// Its goal distance after the last step.
    dist: u16,
    /// The smallest of its goal distances in `history` (the window's low).
    low: u16,
    /// Step of its last progress (or reset, or new goal).
    since: u32,
    /// Step at which it last changed cell (0 = since reset).
    last_move: u32,
    /// Has stood on its (current) goal in this episode.
    reached: bool,
    /// Off its goal and without progress for `window` steps.
    stuck: bool,
    /// Off its goal and not stuck: the agents waiting on it can escape.
    progressing: bool,
}

/// A stuck agent with someone in its way: its in-way agents are
/// `ways[start..end]`.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    agent: u32,
    start: u32,
    end: u32,
    /// Waits on an agent making progress, or on a candidate that escapes.
    escapes: bool,
}

/// Per-agent progress tracking, jam detection and per-episode counters
/// (definitions in the [module docs](self)).
///
/// A step costs O(agents), without allocation and nearly without branches
/// on where agents stand, while nobody is stuck. Then the jam search looks,
/// for each stuck agent, at the agents near it only (found eight at a time
/// in packed rotated coordinates), and follows the
/// wait-for links among the stuck agents that have someone in their way (as
/// bit sets for up to 64 agents).
#[derive(Debug, Clone)]
pub struct StallMonitor {
    window: u32,
    radius: usize,
    /// Steps observed in this episode.
    t: u32,
    /// Per agent, its goal distances of the last `window` steps, a ring
    /// indexed by `t % window`, in groups of eight (padded with
    /// `u16::MAX`, so that the window's low is a branch-free minimum).
    history: Vec<[u16; 8]>,
    /// Groups of eight per agent in `history`.
    groups: usize,
    track: Vec<Track>,
    /// `t % window`.
    slot: usize,
    /// Each agent's cell [`rotated`], in 8-bit lanes eight to a word (the
    /// unused lanes 0).
    rotated: Vec<[u64; 2]>,
    state: Vec<AgentState>,
    agent_deadlock_steps: Vec<u32>,
    agent_livelock_steps: Vec<u32>,
    // Scratch of one step, reused: the stuck agents; the candidates and
    // their in-way lists; which candidates escape (all false between
    // steps); the agents not `Free` and their next states.
    stuck_list: Vec<u32>,
    /// The stuck agents are `stuck_list[..stuck_now]`.
    stuck_now: usize,
    candidates: Vec<Candidate>,
    ways: Vec<u32>,
    escapes: Vec<bool>,
    /// The jammed agents.
    jammed: Vec<u32>,
    /// At most 64 agents: per stuck agent, the agents in its way (bits);
    /// which agents are progressing (bits).
    way_masks: Vec<u64>,
    progressing: u64,
    flagged: Vec<u32>,
    next_flagged: Vec<(u32, AgentState)>,
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
            history: vec![[u16::MAX; 8]; agents * (window as usize).div_ceil(8)],
            groups: (window as usize).div_ceil(8),
            track: vec![Track::default(); agents],
            rotated: vec![[0; 2]; agents.div_ceil(8)],
            slot: 0,
            state: vec![AgentState::Free; agents],
            agent_deadlock_steps: vec![0; agents],
            agent_livelock_steps: vec![0; agents],
            stuck_list: vec![0; agents],
            stuck_now: 0,
            candidates: Vec::with_capacity(agents),
            ways: Vec::with_capacity(agents),
            escapes: vec![false; agents],
            jammed: Vec::with_capacity(agents),
            way_masks: vec![0; agents],
            progressing: 0,
            flagged: Vec::with_capacity(agents),
            next_flagged: Vec::with_capacity(agents),
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
        self.track.len()
    }

    /// Starts a new episode from each agent's `(row, col)`;
    /// `distance(i, cell)` is agent `i`'s goal distance from `cell`.
    pub fn reset(
        &mut self,
        cells: &[(usize, usize)],
        distance: impl Fn(usize, (usize, usize)) -> u16,
    ) {
        let (w, g) = (self.window as usize, self.groups);
        self.t = 0;
        self.slot = 0;
        for (i, &cell) in cells[..self.agents()].iter().enumerate() {
            let d = distance(i, cell);
            fill_window(&mut self.history[i * g..(i + 1) * g], w, d);
            set_lanes(&mut self.rotated[i / 8], i % 8, cell);
            self.track[i] = Track {
                cell,
                dist: d,
                low: d,
                since: 0,
                last_move: 0,
                reached: d == 0,
                stuck: false,
                progressing: false,
            };
        }
        self.stuck_now = 0;
        self.state.fill(AgentState::Free);
        self.flagged.clear();
        self.agent_deadlock_steps.fill(0);
        self.agent_livelock_steps.fill(0);
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
        let (cells, at_goal, new_goal) = (&cells[..n], &at_goal[..n], &new_goal[..n]);
        let (w, g) = (self.window as usize, self.groups);
        self.t += 1;
        let t = self.t;
        self.slot = if self.slot + 1 == w { 0 } else { self.slot + 1 };
        let (group, lane) = (self.slot / 8, self.slot % 8);
        let lane_mask: [u16; 8] = std::array::from_fn(|k| if k == lane { u16::MAX } else { 0 });
        let mut stuck = 0;
        let mut progressing = 0u64;
        let windows = self.history.chunks_exact_mut(g);
        let inputs = cells.iter().zip(at_goal).zip(new_goal);
        let agents = self.track.iter_mut().zip(windows).zip(inputs);
        for (i, ((track, history), ((&cell, &home), &fresh))) in agents.enumerate() {
            // Branch-free where the outcome is a coin toss (random moves).
            let moved = cell != track.cell;
            track.cell = cell;
            track.last_move = if moved { t } else { track.last_move };
            set_lanes(&mut self.rotated[i / 8], i % 8, cell);
            let d = distance(i, cell);
            track.dist = d;
            if fresh {
                fill_window(history, w, d);
                track.low = d;
                track.since = t;
                track.stuck = false;
                track.progressing = !home;
                progressing |= u64::from(!home) << (i % 64);
                track.reached = home;
                continue;
            }
            // `history` holds the last `w` distances before this step. Only
            // the first arrival counts: coming back home is no progress.
            let repeat_arrival = home & track.reached;
            track.reached |= home;
            let progress = !repeat_arrival & (d < track.low);
            track.since = if progress { t } else { track.since };
            // Updated in registers and stored whole: reading the group back
            // right after a 2-byte store into it would stall (no store
            // forwarding from a narrower store).
            let mut current = history[group];
            for (slot, &mask) in current.iter_mut().zip(&lane_mask) {
                *slot = *slot & !mask | d & mask;
            }
            history[group] = current;
            track.low = window_low(history, group, current);
            track.stuck = !home & (t - track.since >= self.window);
            track.progressing = !home & !track.stuck;
            progressing |= u64::from(track.progressing) << (i % 64);
            self.stuck_list[stuck] = i as u32;
            stuck += usize::from(track.stuck);
        }
        self.stuck_now = stuck;
        self.progressing = progressing;
        self.deadlocked_now = 0;
        self.livelocked_now = 0;
        let jams = if stuck == 0 {
            false
        } else if n <= 64 && self.radius <= PACKED_RADIUS {
            self.find_jams_small(&distance)
        } else {
            self.find_jams(&distance)
        };
        if !jams {
            for &i in &self.flagged {
                self.state[i as usize] = AgentState::Free;
            }
            self.flagged.clear();
            return;
        }
        self.next_flagged.clear();
        for &i in &self.jammed {
            let i = i as usize;
            let new = if t - self.track[i].last_move >= self.window {
                self.deadlocked_now += 1;
                self.agent_deadlock_steps[i] += 1;
                if self.state[i] != AgentState::Deadlocked {
                    self.deadlock_events += 1;
                }
                AgentState::Deadlocked
            } else {
                self.livelocked_now += 1;
                self.agent_livelock_steps[i] += 1;
                AgentState::Livelocked
            };
            self.next_flagged.push((i as u32, new));
        }
        for &i in &self.flagged {
            self.state[i as usize] = AgentState::Free;
        }
        self.flagged.clear();
        for &(i, new) in &self.next_flagged {
            self.state[i as usize] = new;
            self.flagged.push(i);
        }
        self.deadlock_steps += u32::from(self.deadlocked_now > 0);
        self.livelock_steps += u32::from(self.livelocked_now > 0);
    }

    /// Finds the candidates (stuck, someone in their way) and which of
    /// them escape: wait on an agent making progress, or on a candidate
    /// that escapes. The rest are jammed (every agent reachable through "in
    /// the way" links stuck or on its goal). Returns whether any is jammed;
    /// if so `escapes` marks the escaping candidates (to be cleared by the
    /// caller), otherwise it is left all false.
    fn find_jams(&mut self, distance: &impl Fn(usize, (usize, usize)) -> u16) -> bool {
        let packed = self.radius <= PACKED_RADIUS;
        let radius = self.radius;
        let (track, words) = (&self.track[..], &self.rotated[..]);
        let (ways, candidates) = (&mut self.ways, &mut self.candidates);
        candidates.clear();
        ways.clear();
        let mut all_escape = true;
        for &i in &self.stuck_list[..self.stuck_now] {
            let i = i as usize;
            let (cell, di) = (track[i].cell, track[i].dist);
            let start = ways.len();
            // Whether `j` is in `i`'s way (then recorded) and progressing.
            let mut in_way = |j: usize| {
                let closer = distance(i, track[j].cell) < di;
                if closer {
                    ways.push(j as u32);
                }
                closer && track[j].progressing
            };
            // Once `i` waits on an agent making progress, its other in-way
            // agents no longer matter.
            let mut escapes = false;
            if packed {
                let (x0, y0) = rotated(cell);
                let r = radius as u64;
                let low = (x0.wrapping_sub(r) & 0x7f, y0.wrapping_sub(r) & 0x7f);
                'scan: for (k, &words) in words.iter().enumerate() {
                    let mut near = near_lanes(words, low, r);
                    while near != 0 {
                        let j = k * 8 + near.trailing_zeros() as usize / 8;
                        near &= near - 1;
                        // The lanes hold `i` itself, maybe far cells and
                        // unused lanes: check exactly.
                        let Some(b) = track.get(j).map(|other| other.cell) else {
                            break;
                        };
                        if j != i
                            && cell.0.abs_diff(b.0) + cell.1.abs_diff(b.1) <= radius
                            && in_way(j)
                        {
                            escapes = true;
                            break 'scan;
                        }
                    }
                }
            } else {
                for (j, other) in track.iter().enumerate() {
                    let b = other.cell;
                    if j != i && cell.0.abs_diff(b.0) + cell.1.abs_diff(b.1) <= radius && in_way(j)
                    {
                        escapes = true;
                        break;
                    }
                }
            }
            if ways.len() > start {
                candidates.push(Candidate {
                    agent: i as u32,
                    start: start as u32,
                    end: ways.len() as u32,
                    escapes,
                });
                all_escape &= escapes;
            }
        }
        if all_escape {
            return false;
        }
        for c in &self.candidates {
            self.escapes[c.agent as usize] = c.escapes;
        }
        loop {
            let mut changed = false;
            for c in self.candidates.iter_mut().filter(|c| !c.escapes) {
                let ways = &self.ways[c.start as usize..c.end as usize];
                if ways.iter().any(|&j| self.escapes[j as usize]) {
                    c.escapes = true;
                    self.escapes[c.agent as usize] = true;
                    changed = true;
                }
            }
            if !changed {
                break;
            }
        }
        self.jammed.clear();
        for c in &self.candidates {
            self.escapes[c.agent as usize] = false;
            if !c.escapes {
                self.jammed.push(c.agent);
            }
        }
        true
    }

    /// [`Self::find_jams`] for at most 64 agents and a packed radius, on
    /// bit sets: per stuck agent the agents in its way as a mask, then
    /// "escapes" grown to its fixpoint a mask at a time. Fewer branches
    /// that depend on where random agents stand.
    fn find_jams_small(&mut self, distance: &impl Fn(usize, (usize, usize)) -> u16) -> bool {
        let radius = self.radius;
        let r = radius as u64;
        let (track, words) = (&self.track[..], &self.rotated[..]);
        let progressing = self.progressing;
        let (mut candidates, mut escapes) = (0u64, 0u64);
        for &i in &self.stuck_list[..self.stuck_now] {
            let i = i as usize;
            let (cell, di) = (track[i].cell, track[i].dist);
            let (x0, y0) = rotated(cell);
            let low = (x0.wrapping_sub(r) & 0x7f, y0.wrapping_sub(r) & 0x7f);
            let mut near = 0u64;
            for (k, &words) in words.iter().enumerate() {
                // The eight lanes' top bits gathered into one byte.
                let lanes = near_lanes(words, low, r).wrapping_mul(0x0002_0408_1020_4081) >> 56;
                near |= lanes << (8 * k);
            }
            // Unused lanes (beyond the agents) are never set: they hold 0,
            // but may look near; drop them and `i` itself.
            near &= !(1 << i) & (u64::MAX >> (64 - track.len()));
            let mut ways = 0u64;
            while near != 0 {
                let j = near.trailing_zeros() as usize;
                near &= near - 1;
                // Exactly (the lanes may include far cells).
                let b = track[j].cell;
                let within = cell.0.abs_diff(b.0) + cell.1.abs_diff(b.1) <= radius;
                let closer = distance(i, b) < di;
                ways |= u64::from(within & closer) << j;
            }
            self.way_masks[i] = ways;
            candidates |= u64::from(ways != 0) << i;
            escapes |= u64::from(ways & progressing != 0) << i;
        }
        if candidates & !escapes == 0 {
            return false;
        }
        loop {
            let mut grown = escapes;
            let mut open = candidates & !escapes;
            while open != 0 {
                let i = open.trailing_zeros() as usize;
                open &= open - 1;
                grown |= u64::from(self.way_masks[i] & escapes != 0) << i;
            }
            if grown == escapes {
                break;
            }
            escapes = grown;
        }
        self.jammed.clear();
        let mut jammed = candidates & !escapes;
        while jammed != 0 {
            self.jammed.push(jammed.trailing_zeros());
            jammed &= jammed - 1;
        }
        !self.jammed.is_empty()
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
        self.track[agent].stuck
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
