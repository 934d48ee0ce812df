//! PIBT, priority inheritance with backtracking (Okumura et al., IJCAI-19 /
//! AIJ 2022), as a one-step **configuration generator** and as a planner.
//!
//! A *configuration* is one cell per agent. PIBT computes the next
//! configuration from the current one: agents are visited in a priority
//! order; each agent tries its candidate cells (its neighbours and its own
//! cell) in order of increasing distance to its goal and *reserves* the first
//! one that is free at `t + 1`. If the reserved cell is occupied at `t` by an
//! agent `j` that has not decided yet, `j` **inherits** the priority and must
//! move away first (recursively); if `j` cannot, it reports failure
//! (**backtracking**) and the asking agent tries its next candidate. An agent
//! whose candidates all fail stays where it is.
//!
//! # The environment's index order: how the generator respects it
//!
//! The env moves agents one after the other in index order, and a move
//! succeeds only if its target is free *at that moment* (SPEC §2; see
//! [`Rules`]). Under [`Rules::ENV_EXECUTABLE`] (the default) the generator
//! therefore only lets agent `i` take a cell that, at time `t`, is
//!
//! 1. empty, or
//! 2. its own cell (a wait), or
//! 3. held by a **lower-index** agent `j < i` — which must then leave it
//!    (priority inheritance pushes `j` if it has not decided yet). `j` moves
//!    before `i` in the env, so the cell is free when `i`'s turn comes.
//!
//! A cell held by a higher-index agent `j > i` is never a candidate for `i`:
//! if `j` stayed it would be a vertex conflict, and if `j` left, the env
//! would still find `j` there when `i` moves (a *following conflict*). This
//! one rule also excludes swaps (one of the two agents would enter the cell
//! of a higher-index one) and rotations along cycles (some agent of the cycle
//! follows a higher-index one), so every generated step is executed by the
//! env exactly. Every output is checked once more against these rules before
//! it is returned. Under [`Rules::SIMULTANEOUS`] rule 3 holds for any
//! `j ≠ i`, and swaps are excluded explicitly (rotations are allowed, as in
//! SPEC §5).
//!
//! The price of rule 3: a low-index agent cannot push a higher-index agent
//! out of its way within one step; it can only take the cell one step after
//! the other agent left. PIBT alone is incomplete anyway; LaCAM
//! ([`crate::lacam`]) makes the search complete on top of this generator.
//!
//! # Swap
//!
//! PIBT alone cannot make two agents pass each other in a single lane: the
//! one with priority pushes the other ahead of it, deeper into the lane, even
//! when the other's goal lies behind (two agents whose goals in a dead-end
//! aisle are in the wrong order livelock there). The *swap* operation of
//! LaCAM3 (Okumura, AAMAS-24, "Engineering LaCAM*") detects this and turns
//! the push into a pull: agent `i`, whose best cell is held by `j`, checks that
//! pushing `j` ahead along the lane would not let them pass (*swap required*)
//! and that backing away leads to a cell where the lane branches (*swap
//! possible*); if so, `i` tries its candidate cells in reverse order (backing
//! away first) and, having backed away, pulls `j` into its former cell. The
//! pair walks back to the branching cell, where the usual pushes let them
//! pass.
//!
//! Under the env's index order a pull is a *following move*: `j` can enter
//! `i`'s former cell in the same step only if `j > i`. For `j < i`, `i` backs
//! away alone, and at the next step the two stand one cell apart; the swap
//! decision recognises that gap too (`j` beyond `i`'s empty best cell) and
//! pulls `j` into the empty cell, which is free at `t` whatever the order, so
//! the pair keeps moving at full speed.
//!
//! With the swap operation the generator also moves **queues** in a lane
//! under the index order (*waiting chains*): an agent that must leave a
//! lane past a queue pushes its neighbour, which must push the next one,
//! and so on — but where an agent would have to enter the cell of a
//! higher-index one, it cannot do so in the same step, and the whole push
//! fails. If the push fails, an agent that may wait (nobody pushes it, or
//! it was pushed by an agent that waits) waits instead and only asks its
//! neighbour to clear the cell; the neighbour, pushed by a waiting agent,
//! may in turn wait and pass the request on, until the head of the queue
//! moves. The failed attempt is undone first (an undo log of the
//! reservations), so the agents it touched decide afresh.
//!
//! The operation is off by default
//! (the collision shield and lifelong PIBT do not use it) and enabled by
//! [`Generator::with_swap`]; LaCAM and LaCAM* enable it
//! ([`crate::Lacam::swap`]). It only changes which step PIBT proposes first:
//! every step is still checked against the rules, and LaCAM's completeness
//! does not depend on it.
//!
//! # Constraints
//!
//! LaCAM calls the generator with *constraints* "agent `i` goes to cell `v`".
//! Constrained agents are placed first (a constraint breaking the rules makes
//! the call fail), then PIBT moves the others. If the constraints fix every
//! agent, the result is exactly the constrained configuration if it is a
//! legal step and a failure otherwise — the property LaCAM's completeness
//! rests on.
//!
//! ```
//! use buridan_env::Map;
//! use buridan_mapf::{replay_exact, validate_with, Limits, Pibt, Planner, Rules};
//! let map = std::sync::Arc::new(Map::load("rm-2.1").unwrap());
//! let scen = map.scenario.clone().unwrap();
//! let sol = Pibt::default().solve(&map.grid, &scen.starts, &scen.goals, &Limits::default()).unwrap();
//! validate_with(&map.grid, &scen.starts, &scen.goals, &sol.plan, Rules::ENV_EXECUTABLE).unwrap();
//! replay_exact(&map, &scen.starts, &scen.goals, &sol.plan, 1000).unwrap();
//! ```

use buridan_env::{Cell, Grid};

use crate::graph::{distance_table, Topology, NONE};
use crate::limits::{check_instance, goals_reachable, Budget, Limits, SolveError};
use crate::plan::Plan;
use crate::planner::{Planner, Solution};
use crate::rules::Rules;

/// A small deterministic random number generator (xorshift64*) for PIBT's
/// tie-breaking: the same instance always gives the same plan.
#[derive(Debug, Clone)]
pub(crate) struct TieBreaker(u64);

impl TieBreaker {
    pub fn new(seed: u64) -> Self {
        Self(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }

    pub fn next(&mut self) -> u32 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 32) as u32
    }
}

/// How an agent ranks its candidate moves: lower keys are tried first.
/// Classical PIBT ranks by the distance to the goal (the distance tables,
/// `Vec<Vec<u32>>`); the collision shield ([`crate::shield`]) by a learned
/// policy's preference order over the five actions.
pub(crate) trait Preference {
    /// The key of `agent` taking `action` (0 stay, 1 up, 2 right, 3 down,
    /// 4 left), which leads to `cell`.
    fn key(&self, agent: u32, action: usize, cell: u32) -> u32;
}

/// Distance tables `dist[agent][cell]` to each agent's goal.
impl Preference for Vec<Vec<u32>> {
    #[inline]
    fn key(&self, agent: u32, _action: usize, cell: u32) -> u32 {
        self[agent as usize][cell as usize]
    }
}

/// Marks a cell nobody may enter at `t + 1` (being cleared, see
/// [`Generator::clear_way`]).
const BLOCKED: u32 = NONE - 1;

/// A swap decision: pull `partner` into `to`; `wait`: the puller waits
/// (rather than backing away).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Swap {
    pub partner: u32,
    pub to: u32,
    pub wait: bool,
}

/// What the *swap* operation (see [`Generator::with_swap`]) needs to know:
/// each agent's distance table and goal.
#[derive(Clone, Copy)]
pub(crate) struct SwapInfo<'a> {
    dist: &'a [Vec<u32>],
    goals: &'a [u32],
    /// Only these agents start a swap (all when `None`).
    only: Option<&'a [bool]>,
}

/// The one-step configuration generator (see the [module docs](self)).
/// Holds per-cell scratch tables that are reset after every call.
pub(crate) struct Generator<'a> {
    topo: &'a Topology,
    rules: Rules,
    /// Agent at each cell at `t` (or [`NONE`]).
    occ_now: Vec<u32>,
    /// Agent that reserved each cell for `t + 1` (or [`NONE`]).
    occ_next: Vec<u32>,
    /// Each agent's cell at `t + 1` ([`NONE`]: undecided).
    next: Vec<u32>,
    rng: TieBreaker,
    /// Cells written into `occ_next` during this call, to reset.
    touched: Vec<u32>,
    /// The swap operation, if enabled.
    swap: Option<SwapInfo<'a>>,
    /// Writes to `occ_next` and `next` during this call, as (cell, its
    /// previous holder, agent, its previous cell), to undo a failed push.
    undo: Vec<(u32, u32, u32, u32)>,
}

impl<'a> Generator<'a> {
    pub fn new(topo: &'a Topology, rules: Rules, seed: u64) -> Self {
        Self {
            topo,
            rules,
            occ_now: vec![NONE; topo.cells()],
            occ_next: vec![NONE; topo.cells()],
            next: Vec::new(),
            rng: TieBreaker::new(seed),
            touched: Vec::new(),
            swap: None,
            undo: Vec::new(),
        }
    }

    /// Enables the *swap* operation (see [the module docs](self#swap)),
    /// judged with the distance tables `dist` to the agents' `goals`.
    pub fn with_swap(mut self, dist: &'a [Vec<u32>], goals: &'a [u32]) -> Self {
        self.swap = Some(SwapInfo {
            dist,
            goals,
            only: None,
        });
        self
    }

    /// Enables the swap operation for the agents marked in `only` (the
    /// collision shield's stalled agents): only they start a swap.
    pub fn with_swap_for(
        mut self,
        dist: &'a [Vec<u32>],
        goals: &'a [u32],
        only: &'a [bool],
    ) -> Self {
        self.swap = Some(SwapInfo {
            dist,
            goals,
            only: Some(only),
        });
        self
    }

    /// The next configuration after `cur`: agents visited in `order`
    /// (highest priority first), `constraints` `(agent, cell)` placed first;
    /// each agent tries its moves in the order of `pref`'s keys.
    /// Writes it to `out` and returns `true`, or returns `false` when the
    /// constraints cannot be met by a legal step.
    pub fn generate<P: Preference>(
        &mut self,
        pref: &P,
        cur: &[u32],
        order: &[u32],
        constraints: &[(u32, u32)],
        out: &mut Vec<u32>,
    ) -> bool {
        for (i, &c) in cur.iter().enumerate() {
            self.occ_now[c as usize] = i as u32;
        }
        self.next.clear();
        self.next.resize(cur.len(), NONE);
        let ok = self.place(pref, cur, order, constraints);
        let ok = ok && self.legal(cur);
        if ok {
            out.clear();
            out.extend_from_slice(&self.next);
        }
        for &c in cur {
            self.occ_now[c as usize] = NONE;
        }
        for &c in &self.touched {
            self.occ_next[c as usize] = NONE;
        }
        self.touched.clear();
        self.undo.clear();
        ok
    }

    fn reserve(&mut self, agent: u32, cell: u32) {
        let (prev_holder, prev_cell) = (self.occ_next[cell as usize], self.next[agent as usize]);
        self.undo.push((cell, prev_holder, agent, prev_cell));
        self.occ_next[cell as usize] = agent;
        self.next[agent as usize] = cell;
        self.touched.push(cell);
    }

    /// Whether `agent` may enter `cell` (held at `t` by `holder`) under the
    /// rules, ignoring reservations.
    fn may_enter(&self, agent: u32, cell: u32, cur: &[u32]) -> bool {
        let holder = self.occ_now[cell as usize];
        if holder == NONE || holder == agent {
            return true;
        }
        if self.rules.forbid_following {
            return holder < agent;
        }
        // Simultaneous moves: no swap with the holder.
        self.next[holder as usize] != cur[agent as usize]
    }

    fn place<P: Preference>(
        &mut self,
        pref: &P,
        cur: &[u32],
        order: &[u32],
        constraints: &[(u32, u32)],
    ) -> bool {
        for &(i, v) in constraints {
            let (iu, vu) = (i as usize, v as usize);
            if iu >= cur.len()
                || self.next[iu] != NONE
                || !self.topo.moves(cur[iu]).contains(&v)
                || self.occ_next[vu] != NONE
                || !self.may_enter(i, v, cur)
            {
                return false;
            }
            self.reserve(i, v);
        }
        for &i in order {
            if self.next[i as usize] == NONE && !self.pibt(pref, i, cur) {
                return false;
            }
        }
        true
    }

    /// PIBT for `i`: reserve a cell for `t + 1`, pushing undecided holders.
    /// On failure `i` stays (and reports `false` to the agent that pushed it).
    fn pibt<P: Preference>(&mut self, pref: &P, i: u32, cur: &[u32]) -> bool {
        let here = cur[i as usize];
        let mut cands = [(0u32, 0u32, 0u32, NONE); 5];
        let mut k = 0;
        for (action, &v) in self.topo.moves(here).iter().enumerate() {
            if v != NONE {
                let busy = u32::from(self.occ_now[v as usize] != NONE && v != here);
                cands[k] = (pref.key(i, action, v), busy, self.rng.next(), v);
                k += 1;
            }
        }
        let cands = &mut cands[..k];
        cands.sort_unstable();
        // Pushed by an agent that waits for `here` to clear: `i` may wait
        // too (a *waiting chain*, see the module docs).
        let chained = self.swap.is_some() && self.occ_next[here as usize] == BLOCKED;
        // Swap: back away from the best cell and pull the partner along.
        let swap = self
            .swap
            .and_then(|info| self.swap_partner(info, i, cands[0].3, cur));
        let pull = swap.map(|s| (s.partner, s.to));
        match swap {
            Some(Swap { wait: true, .. }) => {
                let stay = cands
                    .iter()
                    .position(|c| c.3 == here)
                    .expect("staying is a move");
                cands[..=stay].rotate_right(1);
            }
            Some(_) => cands.reverse(),
            None => {}
        }
        for (rank, &(_, _, _, v)) in cands.iter().enumerate() {
            if self.occ_next[v as usize] != NONE {
                continue;
            }
            if !self.may_enter(i, v, cur) {
                // Not pushed by anyone (nobody reserved `here`), or in a
                // waiting chain: `i` may wait while it clears its way.
                if self.occ_next[here as usize] == NONE || chained {
                    // Wait on `here` (reserved first, so that nobody pushed
                    // by the clearing comes back to push `i`).
                    let mark = self.undo.len();
                    self.reserve(i, here);
                    if self.clear_way(pref, i, v, cur) {
                        return true;
                    }
                    if chained {
                        self.rollback(mark);
                    } else {
                        // (Agents that failed to clear the way stay decided.)
                        self.occ_next[here as usize] = NONE;
                        self.next[i as usize] = NONE;
                    }
                }
                continue;
            }
            let mark = self.undo.len();
            self.reserve(i, v);
            let j = self.occ_now[v as usize];
            let undecided = j != NONE && j != i && self.next[j as usize] == NONE;
            if undecided && !self.pibt(pref, j, cur) {
                let free = self.occ_next[here as usize];
                if self.swap.is_some() && (free == NONE || chained) {
                    // `j` could not leave: if `i` may wait (nobody pushes
                    // it, or it is in a waiting chain) it waits instead and
                    // lets `j` wait in turn while the agent ahead of it
                    // leaves.
                    self.rollback(mark);
                    self.reserve(i, here);
                    self.block(v);
                    if self.pibt(pref, j, cur) {
                        return true;
                    }
                    self.rollback(mark);
                }
                continue; // j stays on v: try the next candidate
            }
            if let (0, Some((j, to))) = (rank, pull) {
                self.pull(j, to, cur);
            }
            return true;
        }
        // All candidates failed: `i` stays. If someone else reserved `here`
        // meanwhile, the final check rejects the step.
        self.reserve(i, here);
        false
    }

    /// Marks `v` as being cleared (nobody may enter it at `t + 1`).
    fn block(&mut self, v: u32) {
        self.undo.push((v, self.occ_next[v as usize], NONE, NONE));
        self.occ_next[v as usize] = BLOCKED;
        self.touched.push(v);
    }

    /// Undoes the reservations made since the undo log had `mark` entries.
    fn rollback(&mut self, mark: usize) {
        while self.undo.len() > mark {
            let (cell, holder, agent, prev) = self.undo.pop().expect("longer than mark");
            self.occ_next[cell as usize] = holder;
            if agent != NONE {
                self.next[agent as usize] = prev;
            }
        }
    }

    /// Push-then-wait: `i` wants `v`, held by a higher-index agent `j`
    /// that the env moves after `i`. If `j` is undecided it must leave `v`
    /// (nobody may enter `v` at `t + 1`); if it manages, or has already
    /// decided to leave, `i` waits one step and finds `v` free at the next.
    fn clear_way<P: Preference>(&mut self, pref: &P, i: u32, v: u32, cur: &[u32]) -> bool {
        let j = self.occ_now[v as usize];
        if !self.rules.forbid_following || j == NONE || j < i {
            return false;
        }
        if self.next[j as usize] != NONE {
            return self.next[j as usize] != v;
        }
        self.block(v);
        self.pibt(pref, j, cur)
    }

    /// The swap decision for `i`, whose best cell is `best` (see the
    /// [module docs](self#swap)), or `None`. Three situations, tried in turn:
    ///
    /// 1. **adjacent**: `best` is held by an undecided `j`, pushing `j`
    ///    ahead would not let the two pass ([`Generator::swap_required`])
    ///    and backing away leads to a place where they can
    ///    ([`Generator::swap_possible`]): `i` backs away and pulls `j` into
    ///    its cell — in the env only if `j > i`; under the thesis rules a
    ///    lower `j` cannot follow in the same step, `i` backs away alone and
    ///    the two stand one cell apart at the next step;
    /// 2. **one cell apart** (thesis rules): `best` is empty and an undecided
    ///    `j` stands beyond it with the same verdict for `i` on `best`; `j`
    ///    is pulled into `best` (free at `t`, whatever the index order)
    ///    while `i` backs away, so the pair keeps moving at full speed. If
    ///    `best` is where the lane branches, `i` waits instead: the two are
    ///    then adjacent at the branching cell, `j` on it;
    /// 3. **clear**: `i`, about to enter a lane, would be followed by its
    ///    neighbour `k` and pushed ahead although `k` must pass it
    ///    (the swap would be required one step later): `i` steps aside and
    ///    pulls `k` into its cell, so that `k` enters first.
    fn swap_partner(&self, info: SwapInfo<'_>, i: u32, best: u32, cur: &[u32]) -> Option<Swap> {
        let here = cur[i as usize];
        if best == here || info.only.is_some_and(|only| !only[i as usize]) {
            return None;
        }
        let undecided = |j: u32| j != NONE && j != i && self.next[j as usize] == NONE;
        let swap = |partner, to, wait| Some(Swap { partner, to, wait });
        let j = self.occ_now[best as usize];
        if j != NONE {
            if undecided(j)
                && self.swap_required(info, i, j, here, best)
                && self.swap_possible(info, best, here)
            {
                return swap(j, here, false);
            }
        } else if self.rules.forbid_following {
            for &w in &self.topo.moves(best)[1..] {
                if w == NONE || w == here {
                    continue;
                }
                let j = self.occ_now[w as usize];
                if undecided(j)
                    && self.swap_required(info, i, j, best, w)
                    && self.swap_possible(info, best, here)
                {
                    let branching = self.passing_neighbours(info, best).1 >= 3;
                    return swap(j, best, branching);
                }
            }
        }
        for &u in &self.topo.moves(here)[1..] {
            if u == NONE || u == best {
                continue;
            }
            let k = self.occ_now[u as usize];
            if k != NONE
                && self.swap_required(info, k, i, here, best)
                && self.swap_possible(info, best, here)
            {
                return swap(k, here, false);
            }
        }
        None
    }

    /// Moves `j` into `to` if `j` is undecided, `to` is free at `t + 1` and
    /// the rules let `j` enter it (a pull that the env cannot execute is
    /// simply not made).
    fn pull(&mut self, j: u32, to: u32, cur: &[u32]) {
        if self.next[j as usize] == NONE
            && self.occ_next[to as usize] == NONE
            && self.topo.moves(cur[j as usize]).contains(&to)
            && self.may_enter(j, to, cur)
        {
            self.reserve(j, to);
        }
    }

    /// The neighbours of `v` the two agents could use to pass each other:
    /// every neighbour except dead ends where an agent rests on its goal.
    fn passing_neighbours(&self, info: SwapInfo<'_>, v: u32) -> ([u32; 4], usize) {
        let mut out = [NONE; 4];
        let mut n = 0;
        for &u in &self.topo.moves(v)[1..] {
            if u == NONE {
                continue;
            }
            let k = self.occ_now[u as usize];
            let dead_end = self.topo.moves(u)[1..]
                .iter()
                .filter(|&&x| x != NONE)
                .count()
                == 1;
            if dead_end && k != NONE && info.goals[k as usize] == u {
                continue;
            }
            out[n] = u;
            n += 1;
        }
        (out, n)
    }

    /// Whether `pusher` at `vp` and `puller` at `vq` (adjacent) need a swap:
    /// simulate `pusher` pushing `puller` ahead along a single lane while
    /// that brings `pusher` closer to its goal. If the lane branches on the
    /// way, they can pass there (no swap). Otherwise a swap is required if,
    /// at the end (a dead end, or `pusher` no longer gains), `puller` wants
    /// to go back past `pusher` while `pusher` still wants to go on (or
    /// rests on its goal).
    pub(crate) fn swap_required(
        &self,
        info: SwapInfo<'_>,
        pusher: u32,
        puller: u32,
        mut vp: u32,
        mut vq: u32,
    ) -> bool {
        let (dp, dq) = (&info.dist[pusher as usize], &info.dist[puller as usize]);
        while dp[vq as usize] < dp[vp as usize] {
            let (nbrs, n) = self.passing_neighbours(info, vq);
            if n >= 3 {
                return false;
            }
            if n <= 1 {
                break; // a dead end
            }
            let Some(&ahead) = nbrs[..n].iter().find(|&&u| u != vp) else {
                break;
            };
            vp = vq;
            vq = ahead;
        }
        dq[vp as usize] < dq[vq as usize]
            && (dp[vp as usize] == 0 || dp[vq as usize] < dp[vp as usize])
    }

    /// Whether the agent at `puller` can back away from the one at `pusher`
    /// (adjacent), pulling it along a single lane, to a cell where the lane
    /// branches (where the two can pass each other).
    pub(crate) fn swap_possible(
        &self,
        info: SwapInfo<'_>,
        mut pusher: u32,
        mut puller: u32,
    ) -> bool {
        let origin = pusher;
        for _ in 0..self.topo.cells() {
            if puller == origin {
                return false;
            }
            let (nbrs, n) = self.passing_neighbours(info, puller);
            if n >= 3 {
                return true;
            }
            let back = nbrs[..n].iter().find(|&&u| u != pusher);
            match (n, back) {
                (2, Some(&back)) => {
                    pusher = puller;
                    puller = back;
                }
                _ => return false,
            }
        }
        false
    }

    /// The final check of a generated step against the rules.
    fn legal(&self, cur: &[u32]) -> bool {
        let mut seen = Vec::with_capacity(cur.len());
        for (i, (&from, &to)) in cur.iter().zip(&self.next).enumerate() {
            if to == NONE || !self.topo.moves(from).contains(&to) {
                return false;
            }
            seen.push(to);
            if from == to {
                continue;
            }
            let holder = self.occ_now[to as usize];
            if holder != NONE {
                let h = holder as usize;
                let swap = self.next[h] == from;
                let following = self.rules.forbid_following && h > i;
                if swap || following {
                    return false;
                }
            }
        }
        seen.sort_unstable();
        seen.windows(2).all(|w| w[0] != w[1])
    }
}

/// The shared setup of PIBT-based solvers: topology, distance tables,
/// starts and goals as cell indices.
pub(crate) struct Setup {
    pub topo: Topology,
    pub dist: Vec<Vec<u32>>,
    pub starts: Vec<u32>,
    pub goals: Vec<u32>,
}

impl Setup {
    /// Checks the instance (typed errors, unreachable goals → `NoSolution`).
    pub fn new(grid: &Grid, starts: &[Cell], goals: &[Cell]) -> Result<Self, SolveError> {
        check_instance(grid, starts, goals)?;
        if !goals_reachable(grid, starts, goals) {
            return Err(SolveError::NoSolution);
        }
        let topo = Topology::new(grid);
        let dist = goals.iter().map(|&g| distance_table(grid, g)).collect();
        Ok(Self {
            starts: starts.iter().map(|&s| topo.index(s)).collect(),
            goals: goals.iter().map(|&g| topo.index(g)).collect(),
            topo,
            dist,
        })
    }

    /// PIBT's initial priorities: a fraction below 1 growing with the
    /// distance to the goal (farther agents first).
    pub fn initial_priorities(&self) -> Vec<f64> {
        let cells = self.topo.cells() as f64 + 1.0;
        (0..self.starts.len())
            .map(|i| f64::from(self.dist[i][self.starts[i] as usize]) / cells)
            .collect()
    }

    /// PIBT's priority update after reaching `config` (see
    /// [`advance_priorities`]).
    pub fn update_priorities(&self, priorities: &mut [f64], config: &[u32]) {
        advance_priorities(priorities, config, &self.goals);
    }

    /// Agents by decreasing priority (see [`priority_order`]).
    pub fn order(priorities: &[f64]) -> Vec<u32> {
        priority_order(priorities)
    }

    /// The plan visiting `configs` in order, trimmed.
    pub fn plan(&self, configs: &[Vec<u32>]) -> Plan {
        self.topo
            .plan(self.starts.len(), configs.iter().map(Vec::as_slice))
    }
}

/// PIBT's priority update after reaching `config`: +1 for agents not on
/// their `goals`, back to the fractional part (the fixed tie-breaker) on the
/// goal. Agents kept waiting thus overtake those that have arrived.
pub(crate) fn advance_priorities(priorities: &mut [f64], config: &[u32], goals: &[u32]) {
    for ((p, &at), &goal) in priorities.iter_mut().zip(config).zip(goals) {
        if at == goal {
            *p = p.fract();
        } else {
            *p += 1.0;
        }
    }
}

/// Agents by decreasing priority (ties: lower index first).
pub(crate) fn priority_order(priorities: &[f64]) -> Vec<u32> {
    let mut order: Vec<u32> = (0..priorities.len() as u32).collect();
    order.sort_by(|&a, &b| priorities[b as usize].total_cmp(&priorities[a as usize]));
    order
}

/// One step of online PIBT, shared by lifelong PIBT and the collision
/// shield: the next configuration `gen` (a fresh [`Generator`], with the
/// swap operation if the caller wants it) finds after `cur` with agents in
/// `priorities` order, then the priorities advanced towards `goals`.
/// Without constraints every agent can at least stay, so the generator
/// cannot fail; should it ever, everybody stays (a legal step), rather than
/// handing the env an illegal one.
pub(crate) fn online_step<P: Preference>(
    mut gen: Generator<'_>,
    pref: &P,
    cur: &[u32],
    goals: &[u32],
    priorities: &mut [f64],
) -> Vec<u32> {
    let order = priority_order(priorities);
    let mut next = Vec::with_capacity(cur.len());
    let ok = gen.generate(pref, cur, &order, &[], &mut next);
    debug_assert!(ok, "without constraints every agent can at least stay");
    if !ok {
        next = cur.to_vec();
    }
    advance_priorities(priorities, &next, goals);
    next
}

/// PIBT as a one-shot planner: apply the generator step after step until
/// every agent stands on its goal. Fast, but incomplete: agents can
/// livelock, in which case it gives up after `max_steps` steps with
/// [`SolveError::StepLimit`]. It never claims an instance unsolvable unless
/// a goal is unreachable ([`crate::Lacam`] can prove it).
///
/// ```
/// use buridan_env::{Cell, Grid};
/// use buridan_mapf::{Limits, Pibt, Planner, SolveError};
/// // Two agents must swap in a corridor: impossible, PIBT gives up.
/// let grid = Grid::from_rows(&["..."]).unwrap();
/// let (s, g) = ([Cell::new(0, 0), Cell::new(0, 1)], [Cell::new(0, 1), Cell::new(0, 0)]);
/// let pibt = Pibt { max_steps: 50, ..Pibt::default() };
/// let err = pibt.solve(&grid, &s, &g, &Limits::default()).unwrap_err();
/// assert_eq!(err, SolveError::StepLimit { steps: 50 });
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Pibt {
    /// The conflict model (default: env-executable, see the module docs).
    pub rules: Rules,
    /// Steps after which PIBT gives up (default 1000;
    /// [`Limits::max_makespan`] lowers it).
    pub max_steps: usize,
    /// Seed of the tie-breaking between equally good cells.
    pub seed: u64,
    /// The *swap* operation (see the [module docs](self#swap); default
    /// off, as in the collision shield and lifelong PIBT).
    #[serde(default)]
    pub swap: bool,
}

impl Default for Pibt {
    fn default() -> Self {
        Self {
            rules: Rules::default(),
            max_steps: 1000,
            seed: 0,
            swap: false,
        }
    }
}

impl Planner for Pibt {
    fn rules(&self) -> Rules {
        self.rules
    }

    fn name(&self) -> &str {
        if self.rules.forbid_following {
            "pibt"
        } else {
            "pibt-simultaneous"
        }
    }

    fn solve(
        &self,
        grid: &Grid,
        starts: &[Cell],
        goals: &[Cell],
        limits: &Limits,
    ) -> Result<Solution, SolveError> {
        let setup = Setup::new(grid, starts, goals)?;
        let mut budget = Budget::new(limits);
        let max_steps = limits
            .max_makespan
            .map_or(self.max_steps, |m| m.min(self.max_steps));
        let n = starts.len();
        let mut gen = Generator::new(&setup.topo, self.rules, self.seed);
        if self.swap {
            gen = gen.with_swap(&setup.dist, &setup.goals);
        }
        let mut priorities = setup.initial_priorities();
        let mut configs = vec![setup.starts.clone()];
        let mut next = Vec::with_capacity(n);
        let row_bytes = n * 4 + 24;
        while configs.last() != Some(&setup.goals) {
            if configs.len() > max_steps {
                return Err(SolveError::StepLimit { steps: max_steps });
            }
            budget.on_expand(|| configs.len() * row_bytes)?;
            let order = Setup::order(&priorities);
            let cur = configs.last().expect("starts are in");
            if !gen.generate(&setup.dist, cur, &order, &[], &mut next) {
                // Without constraints every agent can at least stay.
                return Err(SolveError::StepLimit {
                    steps: configs.len() - 1,
                });
            }
            budget.generated += 1;
            setup.update_priorities(&mut priorities, &next);
            configs.push(next.clone());
        }
        Ok(Solution {
            plan: setup.plan(&configs),
            stats: budget.stats(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A dead-end aisle `(1, 1..=4)` off a junction `(1, 0)`.
    const AISLE: [&str; 3] = [".@@@@", ".....", ".@@@@"];

    /// One generator step from `starts` towards `goals`, agents in
    /// `order`, with or without the swap operation.
    fn step(
        rows: &[&str],
        starts: &[(usize, usize)],
        goals: &[(usize, usize)],
        order: &[u32],
        swap: bool,
    ) -> Vec<(usize, usize)> {
        let grid = Grid::from_rows(rows).unwrap();
        let cells =
            |v: &[(usize, usize)]| v.iter().map(|&(r, c)| Cell::new(r, c)).collect::<Vec<_>>();
        let setup = Setup::new(&grid, &cells(starts), &cells(goals)).unwrap();
        let mut gen = Generator::new(&setup.topo, Rules::ENV_EXECUTABLE, 0);
        if swap {
            gen = gen.with_swap(&setup.dist, &setup.goals);
        }
        let mut next = Vec::new();
        assert!(gen.generate(&setup.dist, &setup.starts, order, &[], &mut next));
        next.iter()
            .map(|&v| setup.topo.cell(v))
            .map(|c| (c.row, c.col))
            .collect()
    }

    /// A generator with the swap on and every agent of `setup` on its start,
    /// no move chosen yet: the state the swap decisions are asked in.
    fn placed_swap_generator(setup: &Setup) -> Generator<'_> {
        let mut gen = Generator::new(&setup.topo, Rules::ENV_EXECUTABLE, 0)
            .with_swap(&setup.dist, &setup.goals);
        for (i, &v) in setup.starts.iter().enumerate() {
            gen.occ_now[v as usize] = i as u32;
        }
        gen.next = vec![NONE; setup.starts.len()];
        gen
    }

    #[test]
    fn swap_required_and_possible_in_a_dead_end_aisle() {
        let grid = Grid::from_rows(&AISLE).unwrap();
        let c = Cell::new;
        // Agent 0 at (1, 2) bound for the end (1, 4); agent 1 rests on (1, 3).
        let setup = Setup::new(&grid, &[c(1, 2), c(1, 3)], &[c(1, 4), c(1, 3)]).unwrap();
        let gen = placed_swap_generator(&setup);
        let info = gen.swap.unwrap();
        let (a, b, junction) = (setup.starts[0], setup.starts[1], setup.topo.index(c(1, 0)));
        // Pushing 1 to the end leaves it behind its goal: swap required,
        // and backing out reaches the junction: possible.
        assert!(gen.swap_required(info, 0, 1, a, b));
        assert!(gen.swap_possible(info, b, a));
        // Agent 0 below the junction pushing 1 into it: the lane branches
        // there, they can pass without a swap.
        assert!(!gen.swap_required(info, 0, 1, setup.topo.index(c(2, 0)), junction));
        let entrance = setup.topo.index(c(1, 1));
        // Backing into the dead end leads nowhere.
        assert!(!gen.swap_possible(info, a, b));
        // At the junction itself the lane branches.
        assert!(gen.swap_possible(info, entrance, junction));
        let decision = gen.swap_partner(info, 0, b, &setup.starts);
        assert_eq!(
            decision,
            Some(Swap {
                partner: 1,
                to: a,
                wait: false
            })
        );
        // Without a branching cell anywhere (a plain corridor) no swap.
        let line = Grid::from_rows(&["....."]).unwrap();
        let setup = Setup::new(&line, &[c(0, 2), c(0, 3)], &[c(0, 4), c(0, 3)]).unwrap();
        let gen = placed_swap_generator(&setup);
        let info = gen.swap.unwrap();
        assert!(gen.swap_required(info, 0, 1, setup.starts[0], setup.starts[1]));
        assert!(!gen.swap_possible(info, setup.starts[1], setup.starts[0]));
        assert_eq!(
            gen.swap_partner(info, 0, setup.starts[1], &setup.starts),
            None
        );
    }

    #[test]
    fn the_swap_pulls_a_higher_index_agent_out_in_the_same_step() {
        let (s, g) = ([(1, 2), (1, 3)], [(1, 4), (1, 3)]);
        // Without swap agent 0 waits while agent 1 is pushed to the end.
        assert_eq!(step(&AISLE, &s, &g, &[0, 1], false), [(1, 2), (1, 4)]);
        // With it, 0 backs out and pulls 1 (which moves after it) along.
        assert_eq!(step(&AISLE, &s, &g, &[0, 1], true), [(1, 1), (1, 2)]);
    }

    #[test]
    fn a_queue_whose_indices_rise_towards_its_head_moves_from_the_head() {
        // Agent 2 at the end of the aisle must get out past 0 and 1, both
        // resting on their goals. 0 cannot enter 1's cell in the step in
        // which 1 leaves it (1 moves after 0), so pushing the queue fails.
        let (s, g) = ([(1, 3), (1, 2), (1, 4)], [(1, 3), (1, 2), (0, 0)]);
        assert_eq!(
            step(&AISLE, &s, &g, &[2, 0, 1], false),
            [(1, 3), (1, 2), (1, 4)]
        );
        // As a waiting chain: 2 and 0 wait, the head 1 steps out.
        assert_eq!(
            step(&AISLE, &s, &g, &[2, 0, 1], true),
            [(1, 3), (1, 1), (1, 4)]
        );
    }

    #[test]
    fn under_the_index_order_a_lower_index_partner_follows_one_cell_behind() {
        // The same aisle with the indices exchanged: agent 0 rests on
        // (1, 3), agent 1 at (1, 2) is bound for the end.
        let (s, g) = ([(1, 3), (1, 2)], [(1, 3), (1, 4)]);
        // 0 moves before 1 in the env, so it cannot follow in this step:
        // 1 backs out alone.
        assert_eq!(step(&AISLE, &s, &g, &[1, 0], true), [(1, 3), (1, 1)]);
        // One cell apart, 1 keeps backing out and pulls 0 into the gap.
        let s = [(1, 3), (1, 1)];
        assert_eq!(step(&AISLE, &s, &g, &[1, 0], true), [(1, 2), (1, 0)]);
        // Without swap 1 walks back in instead.
        assert_eq!(step(&AISLE, &s, &g, &[1, 0], false), [(1, 3), (1, 2)]);
    }
}
