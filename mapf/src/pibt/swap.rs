//! LaCAM3's *swap* operation for the generator (see the
//! [module docs](super#swap)): when two agents must pass each other in a
//! lane, the one with priority backs away and pulls the other along.

use crate::graph::NONE;

use super::generator::Generator;

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
    /// Agents that are never pulled (none when empty): see
    /// [`Generator::for_eviction`].
    held: &'a [bool],
    /// No swap one cell apart when the cell ahead is the agent's own goal
    /// in the open: see [`Generator::for_eviction`].
    open_goals: bool,
}

impl<'a> Generator<'a> {
    /// Enables the *swap* operation (see [the module docs](super#swap)),
    /// judged with the distance tables `dist` to the agents' `goals`.
    pub fn with_swap(mut self, dist: &'a [Vec<u32>], goals: &'a [u32]) -> Self {
        self.swap = Some(SwapInfo {
            dist,
            goals,
            only: None,
            held: &[],
            open_goals: false,
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
            held: &[],
            open_goals: false,
        });
        self
    }

    /// The swaps of the collision shield's dead-end eviction. The agents
    /// marked in `held` (those the dead-end order keeps waiting outside a
    /// branch) are nobody's partner: nobody pulls them, and nobody waits
    /// or backs away for them (a pull would drag one towards the mouth it
    /// waits away from, and it would step back the next step). And an
    /// agent whose next cell is its own goal starts no swap with a partner
    /// one cell beyond it where both cells branch (three or more passing
    /// neighbours each): in the open the partner walks round the goal, and
    /// waiting for it there only trades places back and forth. Without the
    /// swap operation this does nothing.
    pub fn for_eviction(mut self, held: &'a [bool]) -> Self {
        if let Some(info) = &mut self.swap {
            info.held = held;
            info.open_goals = true;
        }
        self
    }

    /// The swap decision for `i`, whose best cell is `best` (see the
    /// [module docs](super#swap)), or `None`. Three situations, tried in turn:
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
    pub(super) fn swap_partner(
        &self,
        info: SwapInfo<'_>,
        i: u32,
        best: u32,
        cur: &[u32],
    ) -> Option<Swap> {
        let here = cur[i as usize];
        if best == here || info.only.is_some_and(|only| !only[i as usize]) {
            return None;
        }
        let held = |j: u32| info.held.get(j as usize).copied().unwrap_or(false);
        let undecided = |j: u32| j != NONE && j != i && self.next[j as usize] == NONE && !held(j);
        let swap = |partner, to, wait| Some(Swap { partner, to, wait });
        let j = self.occ_now[best as usize];
        if j != NONE {
            if undecided(j)
                && self.swap_required(info, i, j, here, best)
                && self.swap_possible(info, best, here)
            {
                return swap(j, here, false);
            }
        } else if self.rules.forbid_following && !self.open_goal(info, i, here, best) {
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
                && !held(k)
                && self.swap_required(info, k, i, here, best)
                && self.swap_possible(info, best, here)
            {
                return swap(k, here, false);
            }
        }
        None
    }

    /// Whether `best`, the next cell of agent `i` at `here`, is its own
    /// goal with both cells branching, where [`Generator::for_eviction`]
    /// starts no swap one cell apart.
    fn open_goal(&self, info: SwapInfo<'_>, i: u32, here: u32, best: u32) -> bool {
        info.open_goals
            && info.dist[i as usize][best as usize] == 0
            && self.passing_neighbours(info, here).1 >= 3
            && self.passing_neighbours(info, best).1 >= 3
    }

    /// Moves `j` into `to` if `j` is undecided, `to` is free at `t + 1` and
    /// the rules let `j` enter it (a pull that the env cannot execute is
    /// simply not made).
    pub(super) fn pull(&mut self, j: u32, to: u32, cur: &[u32]) {
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
}

#[cfg(test)]
mod tests {
    use buridan_env::{Cell, Grid};

    use super::*;
    use crate::pibt::Setup;
    use crate::rules::ConflictModel;
    use crate::Problem;

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
        let setup = setup_of(rows, starts, goals);
        step_with(ConflictModel::ENV_EXECUTABLE, &setup, order, swap)
    }

    /// One generator step on `setup` under the conflict model `rules`
    /// (see [`step`]).
    fn step_with(
        rules: ConflictModel,
        setup: &Setup,
        order: &[u32],
        swap: bool,
    ) -> Vec<(usize, usize)> {
        let mut gen = Generator::new(&setup.topo, rules, 0);
        if swap {
            gen = gen.with_swap(&setup.dist, &setup.goals);
        }
        generate(gen, setup, order)
    }

    /// The step `gen` generates on `setup` with agents in `order`, as
    /// `(row, column)` pairs.
    fn generate(mut gen: Generator<'_>, setup: &Setup, order: &[u32]) -> Vec<(usize, usize)> {
        let mut next = Vec::new();
        assert!(gen.generate(&setup.dist, &setup.starts, order, &[], &mut next));
        next.iter()
            .map(|&v| setup.topo.cell(v))
            .map(|c| (c.row, c.col))
            .collect()
    }

    /// The instance on the grid `rows` from `starts` to `goals`, as
    /// `(row, column)` pairs.
    fn setup_of(rows: &[&str], starts: &[(usize, usize)], goals: &[(usize, usize)]) -> Setup {
        let grid = Grid::from_rows(rows).unwrap();
        let cells =
            |v: &[(usize, usize)]| v.iter().map(|&(r, c)| Cell::new(r, c)).collect::<Vec<_>>();
        Setup::new(Problem::new(&grid, &cells(starts), &cells(goals))).unwrap()
    }

    /// A generator with the swap on and every agent of `setup` on its start,
    /// no move chosen yet: the state the swap decisions are asked in.
    fn placed_swap_generator(setup: &Setup) -> Generator<'_> {
        let mut gen = Generator::new(&setup.topo, ConflictModel::ENV_EXECUTABLE, 0)
            .with_swap(&setup.dist, &setup.goals);
        for (i, &v) in setup.starts.iter().enumerate() {
            gen.occ_now[v as usize] = i as u32;
        }
        gen.next = vec![NONE; setup.starts.len()];
        gen
    }

    #[test]
    fn swap_required_and_possible_in_a_dead_end_aisle() {
        let c = Cell::new;
        // Agent 0 at (1, 2) bound for the end (1, 4); agent 1 rests on (1, 3).
        let setup = setup_of(&AISLE, &[(1, 2), (1, 3)], &[(1, 4), (1, 3)]);
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
        let setup = setup_of(&["....."], &[(0, 2), (0, 3)], &[(0, 4), (0, 3)]);
        let gen = placed_swap_generator(&setup);
        let info = gen.swap.unwrap();
        assert!(gen.swap_required(info, 0, 1, setup.starts[0], setup.starts[1]));
        assert!(!gen.swap_possible(info, setup.starts[1], setup.starts[0]));
        assert_eq!(
            gen.swap_partner(info, 0, setup.starts[1], &setup.starts),
            None
        );
    }

    /// One generator step with the swap of the shield's eviction
    /// ([`Generator::for_eviction`]) or the plain one.
    fn eviction_step(
        setup: &Setup,
        order: &[u32],
        held: &[bool],
        evict: bool,
    ) -> Vec<(usize, usize)> {
        let mut gen = Generator::new(&setup.topo, ConflictModel::ENV_EXECUTABLE, 0)
            .with_swap(&setup.dist, &setup.goals);
        if evict {
            gen = gen.for_eviction(held);
        }
        generate(gen, setup, order)
    }

    #[test]
    fn under_eviction_an_agent_steps_onto_its_goal_in_the_open() {
        // An open room: agent 0 one step left of its goal (0, 2); agent 1
        // below that goal, bound for 0's cell, must pass through it.
        let rows = ["....", "....", "...."];
        let setup = setup_of(&rows, &[(0, 1), (1, 2)], &[(0, 2), (0, 1)]);
        // The plain swap has 0 wait and pulls 1 onto 0's goal: the two
        // then trade places back and forth.
        assert_eq!(eviction_step(&setup, &[0, 1], &[], false), [(0, 1), (0, 2)]);
        // Under eviction 0 steps onto its goal; 1 walks round it.
        let next = eviction_step(&setup, &[0, 1], &[], true);
        assert_eq!(next[0], (0, 2));
        // In an aisle (no branching at the goal) the swap stays.
        let setup = setup_of(&AISLE, &[(1, 2), (1, 3)], &[(1, 4), (1, 3)]);
        assert_eq!(
            eviction_step(&setup, &[0, 1], &[], true),
            eviction_step(&setup, &[0, 1], &[], false)
        );
    }

    #[test]
    fn under_eviction_a_held_agent_is_nobody_s_swap_partner() {
        // The aisle's swap of the first test: agent 0 backs out and pulls
        // agent 1 resting on (1, 3) along.
        let setup = setup_of(&AISLE, &[(1, 2), (1, 3)], &[(1, 4), (1, 3)]);
        assert_eq!(eviction_step(&setup, &[0, 1], &[], true), [(1, 1), (1, 2)]);
        // Held (the dead-end order keeps it waiting), 1 is pulled by
        // nobody: 0 pushes it deeper as PIBT would.
        assert_eq!(
            eviction_step(&setup, &[0, 1], &[false, true], true),
            [(1, 2), (1, 4)]
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

    #[test]
    fn under_simultaneous_rules_any_partner_follows_in_the_same_step() {
        let sim = ConflictModel::SIMULTANEOUS;
        // Agent 0 rests on (1, 3), agent 1 at (1, 2) is bound for the end:
        // 1 backs out and pulls the lower-index 0 along at once.
        let pair = setup_of(&AISLE, &[(1, 3), (1, 2)], &[(1, 3), (1, 4)]);
        assert_eq!(step_with(sim, &pair, &[1, 0], true), [(1, 2), (1, 1)]);
        // Without swap 1 pushes 0 to the end of the aisle.
        assert_eq!(step_with(sim, &pair, &[1, 0], false), [(1, 4), (1, 3)]);
        // A queue whose indices rise towards its head moves in one step by
        // plain pushes (following is legal): no waiting chain.
        let queue = setup_of(&AISLE, &[(1, 3), (1, 2), (1, 4)], &[(1, 3), (1, 2), (0, 0)]);
        let next = step_with(sim, &queue, &[2, 0, 1], true);
        assert_eq!(next[2], (1, 3));
    }
}
