//! The one-step configuration generator: PIBT's priority inheritance and
//! backtracking over a preference order, the waiting chains, and the final
//! check of every step against the rules (see the [module docs](super)).

use crate::graph::{Topology, NONE};
use crate::rules::ConflictModel;

use super::swap::{Swap, SwapInfo};

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

/// Added to a pushed agent's key for a move onto its pusher's way
/// ([`Generator::with_stepping_aside`]): above every key of a preference
/// order (ranks 0–4) and every distance on a grid of fewer than 2²⁴ cells.
const IN_THE_WAY: u32 = 1 << 24;

/// Marks a cell nobody may enter at `t + 1` (being cleared, see
/// [`Generator::clear_way`]).
const BLOCKED: u32 = NONE - 1;

/// The one-step configuration generator (see the [module docs](super)).
/// Holds per-cell scratch tables that are reset after every call.
pub(crate) struct Generator<'a> {
    pub(super) topo: &'a Topology,
    pub(super) rules: ConflictModel,
    /// Agent at each cell at `t` (or [`NONE`]).
    pub(super) occ_now: Vec<u32>,
    /// Agent that reserved each cell for `t + 1` (or [`NONE`]).
    pub(super) occ_next: Vec<u32>,
    /// Each agent's cell at `t + 1` ([`NONE`]: undecided).
    pub(super) next: Vec<u32>,
    rng: TieBreaker,
    /// Cells written into `occ_next` during this call, to reset.
    touched: Vec<u32>,
    /// The swap operation, if enabled.
    pub(super) swap: Option<SwapInfo<'a>>,
    /// Writes to `occ_next` and `next` during this call, as (cell, its
    /// previous holder, agent, its previous cell), to undo a failed push.
    undo: Vec<(u32, u32, u32, u32)>,
    /// Distance tables to each agent's goal where pushed agents step out
    /// of their pusher's way ([`Generator::with_stepping_aside`]).
    aside: Option<&'a [Vec<u32>]>,
}

impl<'a> Generator<'a> {
    pub fn new(topo: &'a Topology, rules: ConflictModel, seed: u64) -> Self {
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
            aside: None,
        }
    }

    /// Pushed agents step out of their pusher's way: an agent pushed by
    /// `p` tries last the moves onto `p`'s way onward (a cell one step
    /// closer to `p`'s goal than its own) that bring it no closer to its
    /// own goal, whatever its preference order says. Pushed ahead along
    /// the pusher's way it is pushed again at the next step, and where the
    /// way runs into a lane it is pushed the lane's length (or, at its
    /// goal by the lane's mouth, steps back onto the goal and is pushed
    /// again, forever); stepping aside at the branching cell lets the
    /// pusher by. `dist[agent][cell]`: the distance tables to the goals.
    pub fn with_stepping_aside(mut self, dist: &'a [Vec<u32>]) -> Self {
        self.aside = Some(dist);
        self
    }

    /// Whether `i`, at `here` and pushed by `by`, would step onto `by`'s
    /// way onward by entering `v` without coming closer to its own goal
    /// (see [`Generator::with_stepping_aside`]).
    fn in_the_way(&self, i: u32, by: u32, here: u32, v: u32) -> bool {
        let Some(dist) = self.aside else {
            return false;
        };
        if by == NONE || v == here {
            return false;
        }
        match (dist.get(by as usize), dist.get(i as usize)) {
            (Some(theirs), Some(mine)) => {
                theirs[v as usize] < theirs[here as usize]
                    && mine[v as usize] >= mine[here as usize]
            }
            _ => false,
        }
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

    pub(super) fn reserve(&mut self, agent: u32, cell: u32) {
        let (prev_holder, prev_cell) = (self.occ_next[cell as usize], self.next[agent as usize]);
        self.undo.push((cell, prev_holder, agent, prev_cell));
        self.occ_next[cell as usize] = agent;
        self.next[agent as usize] = cell;
        self.touched.push(cell);
    }

    /// Whether `agent` may enter `cell` (held at `t` by `holder`) under the
    /// rules, ignoring reservations.
    pub(super) fn may_enter(&self, agent: u32, cell: u32, cur: &[u32]) -> bool {
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
        // LaCAM's constraints: the constrained agents' cells are reserved first.
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
        // Plan in priority order: PIBT from every agent still undecided.
        for &i in order {
            if self.next[i as usize] == NONE && !self.pibt(pref, i, NONE, cur) {
                return false;
            }
        }
        true
    }

    /// PIBT for `i`, pushed by `by` ([`NONE`]: by nobody): reserve a cell
    /// for `t + 1`, pushing undecided holders. On failure `i` stays (and
    /// reports `false` to the agent that pushed it).
    fn pibt<P: Preference>(&mut self, pref: &P, i: u32, by: u32, cur: &[u32]) -> bool {
        let here = cur[i as usize];
        // 1. Candidates: the neighbours and `here`, by preference (moves
        // onto the pusher's way last where agents step aside); ties go to
        // cells free at `t`, then at random.
        let mut cands = [(0u32, 0u32, 0u32, NONE); 5];
        let mut k = 0;
        for (action, &v) in self.topo.moves(here).iter().enumerate() {
            if v != NONE {
                let busy = u32::from(self.occ_now[v as usize] != NONE && v != here);
                let key = pref.key(i, action, v);
                let key = if self.in_the_way(i, by, here, v) {
                    key.saturating_add(IN_THE_WAY)
                } else {
                    key
                };
                cands[k] = (key, busy, self.rng.next(), v);
                k += 1;
            }
        }
        let cands = &mut cands[..k];
        cands.sort_unstable();
        // Pushed by an agent that waits for `here` to clear: `i` may wait
        // too (a *waiting chain*, see the module docs; only under the
        // index order, where it is the only way to move a queue).
        let chains = self.swap.is_some() && self.rules.forbid_following;
        let chained = chains && self.occ_next[here as usize] == BLOCKED;
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
        // 2. Try the candidates in turn, skipping cells reserved for `t + 1`
        // (vertex conflicts) and cells the rules forbid.
        for (rank, &(_, _, _, v)) in cands.iter().enumerate() {
            if self.occ_next[v as usize] != NONE {
                continue;
            }
            if !self.may_enter(i, v, cur) {
                // Not pushed by anyone (nobody reserved `here`), or in a
                // waiting chain: `i` may wait while it clears its way.
                if self.rules.forbid_following && (self.occ_next[here as usize] == NONE || chained)
                {
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
            // 3. Reserve `v`; priority inheritance: its undecided holder `j`
            // must move first.
            let mark = self.undo.len();
            self.reserve(i, v);
            let j = self.occ_now[v as usize];
            let undecided = j != NONE && j != i && self.next[j as usize] == NONE;
            if undecided && !self.pibt(pref, j, i, cur) {
                let free = self.occ_next[here as usize];
                if chains && (free == NONE || chained) {
                    // `j` could not leave: if `i` may wait (nobody pushes
                    // it, or it is in a waiting chain) it waits instead and
                    // lets `j` wait in turn while the agent ahead of it
                    // leaves.
                    self.rollback(mark);
                    self.reserve(i, here);
                    self.block(v);
                    if self.pibt(pref, j, i, cur) {
                        return true;
                    }
                    self.rollback(mark);
                }
                // 4. Backtrack: `j` stays on `v`, try the next candidate.
                continue;
            }
            if let (0, Some((j, to))) = (rank, pull) {
                self.pull(j, to, cur);
            }
            return true;
        }
        // 5. All candidates failed: `i` stays. If someone else reserved `here`
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
        self.pibt(pref, j, i, cur)
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
