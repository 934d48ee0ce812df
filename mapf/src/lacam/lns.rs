//! Large neighbourhood search (LNS) that shortens a conflict-free plan:
//! MAPF-LNS (Li, Chen, Harabor, Stuckey and Koenig, IJCAI-21), the
//! refinement that lacam3 runs beside LaCAM* ("Engineering LaCAM*",
//! Okumura, AAMAS-24). [`LacamStar`](super::LacamStar) uses it once its own
//! search stops paying off ([`LacamStar::lns`](super::LacamStar::lns)).
//!
//! The plan's paths live in a [`PathTable`] (who stands where at each
//! time, who rests on which goal for good). One iteration:
//!
//! 1. **Choose a neighbourhood**: up to [`NEIGHBOURHOOD`] agents by one of
//!    three rules, drawn in proportion to how much each has shortened the
//!    plan lately (adaptive LNS):
//!    - *agent-based*: the agent delayed most over its shortest path (not
//!      one chosen lately) and the agents standing on a shortest path of
//!      its at the times it would pass there;
//!    - *map-based*: the agents crossing an intersection (a cell with more
//!      than two free neighbours) and the cells around it;
//!    - *random*: agents drawn uniformly.
//! 2. **Destroy**: their paths leave the table.
//! 3. **Repair**: in a random order each gets the shortest path
//!    (space-time A*, [`crate::lowlevel`]) around every path in the table,
//!    then joins it: prioritized planning over the neighbourhood, with the
//!    same conflicts as [`crate::Prioritized`] under the conflict model.
//! 4. **Accept** the new paths if their sum of costs is lower than the old
//!    ones'; otherwise restore the old paths.
//!
//! **Within a makespan cap.** With [`Instance::cap`] set, every replanned
//! path ends within the cap, and a plan whose paths do not all fit yet is
//! first *repaired*: the agent-based rule starts from the agent that
//! arrives last, and a neighbourhood that held a path over the cap is
//! accepted once all its paths are replanned (fewer paths over the cap),
//! whatever their cost. Once every path fits, the sum of costs decides.
//!
//! Every path in the table respects every other, so the plan stays
//! conflict-free (and replays exactly in the env under the conflict
//! model's rule set) after every iteration.

use std::time::Duration;

use crate::graph::{Topology, NONE};
use crate::limits::Budget;
use crate::lowlevel::{space_time_astar, LowResult, Obstacles};
use crate::pibt::TieBreaker;

/// Agents per neighbourhood (MAPF-LNS's default).
pub(crate) const NEIGHBOURHOOD: usize = 8;

/// Reaction of the rule weights to the last iteration (adaptive LNS).
const REACTION: f64 = 0.1;

/// Every agent's timed path (cells at times `0..=arrival`), as a table.
pub(crate) struct PathTable {
    cells: usize,
    /// `occ[t * cells + cell]`: the agent on `cell` at `t`, or [`NONE`].
    occ: Vec<u32>,
    /// Time layers in `occ`.
    horizon: usize,
    /// `rest[cell]`: the agent resting on `cell` for good and from when.
    rest: Vec<(u32, u32)>,
}

impl PathTable {
    fn new(cells: usize) -> Self {
        Self {
            cells,
            occ: Vec::new(),
            horizon: 0,
            rest: vec![(NONE, 0); cells],
        }
    }

    /// Who stands on `cell` at `t` (walking or resting), or [`NONE`].
    #[inline]
    fn occupant(&self, cell: u32, t: u32) -> u32 {
        let t = t as usize;
        if t < self.horizon {
            let a = self.occ[t * self.cells + cell as usize];
            if a != NONE {
                return a;
            }
        }
        match self.rest[cell as usize] {
            (a, from) if a != NONE && t >= from as usize => a,
            _ => NONE,
        }
    }

    fn insert(&mut self, agent: u32, path: &[u32]) {
        if path.len() > self.horizon {
            self.occ.resize(path.len() * self.cells, NONE);
            self.horizon = path.len();
        }
        for (t, &c) in path.iter().enumerate() {
            self.occ[t * self.cells + c as usize] = agent;
        }
        let goal = *path.last().expect("a path has a start");
        self.rest[goal as usize] = (agent, path.len() as u32 - 1);
    }

    fn remove(&mut self, agent: u32, path: &[u32]) {
        for (t, &c) in path.iter().enumerate() {
            let slot = &mut self.occ[t * self.cells + c as usize];
            if *slot == agent {
                *slot = NONE;
            }
        }
        let goal = *path.last().expect("a path has a start");
        if self.rest[goal as usize].0 == agent {
            self.rest[goal as usize] = (NONE, 0);
        }
    }
}

/// The table as one agent sees it while it replans: the other agents'
/// paths as moving obstacles (its own path is out of the table).
struct View<'a> {
    table: &'a PathTable,
    agent: u32,
    goal: u32,
    forbid_following: bool,
    /// The latest time the agent may not stand on its goal.
    goal_last: Option<u32>,
}

impl<'a> View<'a> {
    fn new(table: &'a PathTable, agent: u32, goal: u32, forbid_following: bool) -> Self {
        let mut view = Self {
            table,
            agent,
            goal,
            forbid_following,
            goal_last: None,
        };
        view.goal_last = (0..=table.horizon as u32 + 1)
            .rev()
            .find(|&t| !view.allows(goal, t));
        view
    }
}

impl Obstacles for View<'_> {
    #[inline]
    fn allows(&self, cell: u32, t: u32) -> bool {
        if self.table.occupant(cell, t) != NONE {
            return false;
        }
        if self.forbid_following {
            // A higher agent left `cell` in the step before: entering it
            // now would follow that agent, which the env blocks.
            if t > 0 {
                let j = self.table.occupant(cell, t - 1);
                if j != NONE && j > self.agent {
                    return false;
                }
            }
            // A lower agent enters `cell` in the next step: it would
            // follow this agent, which the env blocks.
            let j = self.table.occupant(cell, t + 1);
            if j != NONE && j < self.agent {
                return false;
            }
        }
        true
    }

    #[inline]
    fn allows_move(&self, from: u32, to: u32, t: u32) -> bool {
        // No swap with the agent on `to`.
        let j = self.table.occupant(to, t);
        j == NONE || self.table.occupant(from, t + 1) != j
    }

    #[inline]
    fn may_rest_on_goal_from(&self, t: u32) -> bool {
        let taken = self.table.rest[self.goal as usize].0;
        (taken == NONE || taken == self.agent) && self.goal_last.is_none_or(|g| t > g)
    }

    fn last_t(&self) -> u32 {
        self.table.horizon as u32 + 1
    }
}

/// The neighbourhood rules (step 1).
#[derive(Clone, Copy)]
enum Rule {
    AgentBased,
    MapBased,
    Random,
}

const RULES: [Rule; 3] = [Rule::AgentBased, Rule::MapBased, Rule::Random];

/// What [`refine`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct LnsStats {
    /// Iterations run.
    pub iterations: u64,
    /// Iterations whose new paths were kept.
    pub accepted: u64,
}

/// The instance an LNS works on.
pub(crate) struct Instance<'a> {
    pub topo: &'a Topology,
    /// Distance tables to each agent's goal.
    pub dist: &'a [Vec<u32>],
    pub starts: &'a [u32],
    pub goals: &'a [u32],
    pub forbid_following: bool,
    /// No replanned path may end later than this; paths that already do
    /// are repaired first (see the [module docs](self)).
    pub cap: Option<usize>,
}

impl Instance<'_> {
    /// Whether `path` ends after the cap.
    fn over_cap(&self, path: &[u32]) -> bool {
        self.cap.is_some_and(|c| path.len() - 1 > c)
    }
}

/// Shortens `paths` (each agent's cells at times `0..=arrival`, together
/// conflict-free) by LNS until `budget`'s CPU clock reaches `until` or its
/// time limit; returns how many iterations ran. The paths stay
/// conflict-free; the number of paths over the cap never grows, nor, once
/// it is zero, their sum of costs.
pub(crate) fn refine(
    inst: &Instance<'_>,
    paths: &mut [Vec<u32>],
    budget: &mut Budget,
    until: Duration,
    seed: u64,
) -> LnsStats {
    let n = paths.len();
    let mut stats = LnsStats::default();
    if n == 0 {
        return stats;
    }
    let mut table = PathTable::new(inst.topo.cells());
    for (i, p) in paths.iter().enumerate() {
        table.insert(i as u32, p);
    }
    let intersections: Vec<u32> = (0..inst.topo.cells() as u32)
        .filter(|&c| inst.topo.is_free(c) && inst.topo.neighbours(c).count() > 2)
        .collect();
    let mut lns = Lns {
        inst,
        rng: TieBreaker::new(seed ^ 0x1A5),
        weights: [1.0; 3],
        tabu: vec![false; n],
        tabu_count: 0,
        intersections,
    };
    let k = NEIGHBOURHOOD.min(n);
    let mut old: Vec<(u32, Vec<u32>)> = Vec::with_capacity(k);
    let mut order: Vec<u32> = Vec::with_capacity(k);
    while budget.cpu_elapsed() < until && budget.check_time().is_ok() {
        stats.iterations += 1;
        // 1. Choose a neighbourhood.
        let r = lns.pick_rule();
        let chosen = match RULES[r] {
            Rule::AgentBased => lns.agent_based(&table, paths, k),
            Rule::MapBased => lns.map_based(&table, k),
            Rule::Random => Vec::new(),
        };
        let chosen = lns.fill_randomly(chosen, n, k);
        // 2. Destroy.
        old.clear();
        for &a in &chosen {
            table.remove(a, &paths[a as usize]);
            old.push((a, std::mem::take(&mut paths[a as usize])));
        }
        let old_cost: usize = old.iter().map(|(_, p)| p.len() - 1).sum();
        let old_over = old.iter().filter(|(_, p)| inst.over_cap(p)).count();
        // 3. Repair, in a random order.
        order.clear();
        order.extend_from_slice(&chosen);
        lns.shuffle(&mut order);
        let mut new_cost = 0;
        let mut repaired = true;
        for &a in &order {
            let i = a as usize;
            let view = View::new(&table, a, inst.goals[i], inst.forbid_following);
            let found = space_time_astar(
                inst.topo,
                inst.starts[i],
                inst.goals[i],
                &inst.dist[i],
                &view,
                None,
                inst.cap,
                budget,
            );
            match found {
                Ok(LowResult::Path(p)) if old_over > 0 || new_cost + p.len() - 1 < old_cost => {
                    new_cost += p.len() - 1;
                    table.insert(a, &p);
                    paths[i] = p;
                }
                _ => {
                    repaired = false;
                    break;
                }
            }
        }
        // 4. Accept or restore.
        // Replanned paths fit the cap: a repair counts for much.
        let gain = if repaired {
            old_cost.saturating_sub(new_cost) + 10 * old_over
        } else {
            0
        };
        if repaired {
            stats.accepted += 1;
        } else {
            for &a in &chosen {
                let p = &mut paths[a as usize];
                if !p.is_empty() {
                    table.remove(a, p);
                }
            }
            for (a, p) in old.drain(..) {
                table.insert(a, &p);
                paths[a as usize] = p;
            }
        }
        lns.weights[r] = (1.0 - REACTION) * lns.weights[r] + REACTION * gain as f64;
    }
    end_when_all_arrive(paths, inst.goals);
    stats
}

/// Cuts every path at the first time all agents stand on their goals: an
/// env ends the episode there, while a path that passes its goal earlier
/// and comes back later would count until its last arrival.
fn end_when_all_arrive(paths: &mut [Vec<u32>], goals: &[u32]) {
    let at = |p: &[u32], t: usize| p[t.min(p.len() - 1)];
    let horizon = paths.iter().map(Vec::len).max().unwrap_or(0);
    let first = (0..horizon).find(|&t| paths.iter().zip(goals).all(|(p, &g)| at(p, t) == g));
    if let Some(t) = first {
        for p in paths.iter_mut() {
            p.truncate(t + 1);
        }
    }
}

/// The neighbourhood rules' state.
struct Lns<'a> {
    inst: &'a Instance<'a>,
    rng: TieBreaker,
    /// Adaptive weights of [`RULES`].
    weights: [f64; 3],
    /// Agents chosen lately by the agent-based rule.
    tabu: Vec<bool>,
    tabu_count: usize,
    intersections: Vec<u32>,
}

impl Lns<'_> {
    fn uniform(&mut self, n: usize) -> usize {
        self.rng.next() as usize % n
    }

    fn shuffle(&mut self, xs: &mut [u32]) {
        for i in (1..xs.len()).rev() {
            let j = self.uniform(i + 1);
            xs.swap(i, j);
        }
    }

    /// A rule index, drawn in proportion to the weights.
    fn pick_rule(&mut self) -> usize {
        let total: f64 = self.weights.iter().sum();
        if total <= 0.0 {
            return self.uniform(RULES.len());
        }
        let mut x = f64::from(self.rng.next()) / 4_294_967_296.0 * total;
        for (r, w) in self.weights.iter().enumerate() {
            if x < *w {
                return r;
            }
            x -= w;
        }
        RULES.len() - 1
    }

    /// The most delayed agent not chosen lately, and the agents on one of
    /// its shortest paths when it would pass.
    fn agent_based(&mut self, table: &PathTable, paths: &[Vec<u32>], k: usize) -> Vec<u32> {
        let inst = self.inst;
        let delay =
            |i: usize| (paths[i].len() - 1) - inst.dist[i][inst.starts[i] as usize] as usize;
        // Over the cap first (the last to arrive), then the most delayed.
        let pick = (0..paths.len())
            .filter(|&i| !self.tabu[i] && delay(i) > 0)
            .max_by_key(|&i| {
                let over = inst.over_cap(&paths[i]);
                (over, if over { paths[i].len() } else { delay(i) })
            });
        let Some(a) = pick else {
            self.tabu.fill(false);
            self.tabu_count = 0;
            return Vec::new();
        };
        self.tabu[a] = true;
        self.tabu_count += 1;
        if self.tabu_count * 2 >= paths.len() {
            self.tabu.fill(false);
            self.tabu_count = 0;
        }
        let mut chosen = vec![a as u32];
        let (goal, dist) = (inst.goals[a], &inst.dist[a]);
        let (mut cell, mut t) = (inst.starts[a], 0u32);
        while chosen.len() < k {
            for tt in [t, t + 1] {
                let j = table.occupant(cell, tt);
                if j != NONE && !chosen.contains(&j) && chosen.len() < k {
                    chosen.push(j);
                }
            }
            if cell == goal {
                break;
            }
            let d = dist[cell as usize];
            let next: Vec<u32> = inst
                .topo
                .neighbours(cell)
                .filter(|&c| dist[c as usize] < d)
                .collect();
            if next.is_empty() {
                break;
            }
            cell = next[self.uniform(next.len())];
            t += 1;
        }
        chosen
    }

    /// The agents that cross a random intersection, then the cells around
    /// it, breadth-first.
    fn map_based(&mut self, table: &PathTable, k: usize) -> Vec<u32> {
        if self.intersections.is_empty() {
            return Vec::new();
        }
        let pick = self.uniform(self.intersections.len());
        let start = self.intersections[pick];
        let mut chosen = Vec::new();
        let mut seen = vec![start];
        let mut queue = std::collections::VecDeque::from([start]);
        while let Some(cell) = queue.pop_front() {
            for t in 0..table.horizon as u32 {
                let j = table.occupant(cell, t);
                if j != NONE && !chosen.contains(&j) {
                    chosen.push(j);
                    if chosen.len() >= k {
                        return chosen;
                    }
                }
            }
            for c in self.inst.topo.neighbours(cell) {
                if !seen.contains(&c) && seen.len() < 64 {
                    seen.push(c);
                    queue.push_back(c);
                }
            }
        }
        chosen
    }

    /// `chosen` filled up to `k` distinct agents with random ones.
    fn fill_randomly(&mut self, mut chosen: Vec<u32>, n: usize, k: usize) -> Vec<u32> {
        while chosen.len() < k {
            let a = self.uniform(n) as u32;
            if !chosen.contains(&a) {
                chosen.push(a);
            }
        }
        chosen
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::graph::distance_table;
    use crate::limits::Limits;
    use crate::{validate_with, ConflictModel, Plan};
    use buridan_env::{Cell, Grid};

    /// A 5×5 open grid; four agents going down their own columns.
    struct Columns {
        grid: Grid,
        starts: Vec<Cell>,
        goals: Vec<Cell>,
        topo: Topology,
        dist: Vec<Vec<u32>>,
        s: Vec<u32>,
        g: Vec<u32>,
    }

    impl Columns {
        fn new() -> Self {
            let grid = Grid::from_rows(&["....."; 5]).unwrap();
            let starts: Vec<Cell> = (0..4).map(|c| Cell::new(0, c)).collect();
            let goals: Vec<Cell> = (0..4).map(|c| Cell::new(4, c)).collect();
            let topo = Topology::new(&grid);
            let dist = goals.iter().map(|&g| distance_table(&grid, g)).collect();
            let s = topo.indices(&starts);
            let g = topo.indices(&goals);
            Self {
                grid,
                starts,
                goals,
                topo,
                dist,
                s,
                g,
            }
        }

        /// Agent `i` waits `waits[i]` steps on its start, then goes
        /// straight down to its goal.
        fn straight_down(&self, waits: [usize; 4]) -> Vec<Vec<u32>> {
            (0..4)
                .map(|i| {
                    let mut p = vec![self.s[i]; waits[i] + 1];
                    let mut c = self.s[i];
                    while c != self.g[i] {
                        let d = &self.dist[i];
                        c = self
                            .topo
                            .neighbours(c)
                            .find(|&x| d[x as usize] < d[c as usize])
                            .unwrap();
                        p.push(c);
                    }
                    p
                })
                .collect()
        }

        fn instance(&self, forbid_following: bool, cap: Option<usize>) -> Instance<'_> {
            Instance {
                topo: &self.topo,
                dist: &self.dist,
                starts: &self.s,
                goals: &self.g,
                forbid_following,
                cap,
            }
        }
    }

    #[test]
    fn within_a_cap_a_plan_too_long_is_repaired_first() {
        let cols = Columns::new();
        // Agent 3 waits 15 steps before its 4 moves: makespan 19.
        let mut paths = cols.straight_down([0, 0, 0, 15]);
        assert_eq!(paths.iter().map(|p| p.len() - 1).max(), Some(19));
        let inst = cols.instance(true, Some(10));
        let mut budget = Budget::new(&Limits::default());
        refine(&inst, &mut paths, &mut budget, Duration::from_millis(50), 0);
        assert!(paths.iter().all(|p| p.len() - 1 <= 10), "{paths:?}");
    }

    #[test]
    fn paths_end_when_every_agent_stands_on_its_goal() {
        // Agent 0 passes its goal (cell 1) at t = 1 and is back at t = 3;
        // agent 1 arrives at t = 1.
        let mut paths = vec![vec![0, 1, 2, 1], vec![5, 6]];
        end_when_all_arrive(&mut paths, &[1, 6]);
        assert_eq!(paths, vec![vec![0, 1], vec![5, 6]]);
        // Never all at once before the end: nothing is cut.
        let mut paths = vec![vec![0, 1, 2, 1], vec![5, 5, 5, 6]];
        end_when_all_arrive(&mut paths, &[1, 6]);
        assert_eq!(paths, vec![vec![0, 1, 2, 1], vec![5, 5, 5, 6]]);
    }

    #[test]
    fn refining_a_plan_with_detours_shortens_it_and_keeps_it_valid() {
        let cols = Columns::new();
        for model in [ConflictModel::ENV_EXECUTABLE, ConflictModel::SIMULTANEOUS] {
            // A valid but wasteful plan: agents move one after another
            // (SoC 4 + 9 + 14 + 19).
            let mut paths = cols.straight_down([0, 5, 10, 15]);
            let before: usize = paths.iter().map(|p| p.len() - 1).sum();
            let to_plan = |paths: &[Vec<u32>]| {
                Plan::new(
                    paths
                        .iter()
                        .map(|p| p.iter().map(|&c| cols.topo.cell(c)).collect())
                        .collect(),
                )
            };
            let (grid, starts, goals) = (&cols.grid, &cols.starts, &cols.goals);
            validate_with(grid, starts, goals, &to_plan(&paths), model).unwrap();
            let inst = cols.instance(model.forbid_following, None);
            let mut budget = Budget::new(&Limits::default());
            let stats = refine(&inst, &mut paths, &mut budget, Duration::from_millis(50), 0);
            let after: usize = paths.iter().map(|p| p.len() - 1).sum();
            assert!(stats.iterations > 0 && stats.accepted > 0, "{stats:?}");
            assert_eq!((before, after), (46, 16));
            validate_with(grid, starts, goals, &to_plan(&paths), model).unwrap();
        }
    }
}
