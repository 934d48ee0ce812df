//! CBS's low level: space-time A* for one agent under vertex and edge
//! constraints.
//!
//! States are `(cell, t)`, `g = t` (a wait costs 1 like a move), the
//! heuristic is a per-cell table (Manhattan or true distance, both
//! admissible and consistent). The agent rests on its goal after arriving,
//! so a path may only end at a time later than every vertex constraint on
//! the goal cell. After the last constrained time `T_c` the future no longer
//! depends on the clock, so states `(cell, t > T_c)` are merged into
//! `(cell, T_c + 1)`: the search space is finite (cells × (T_c + 2)) and an
//! unreachable constrained goal ends the search instead of looping.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use crate::graph::{FastMap, FastSet, Topology, NONE};
use crate::limits::{Budget, SolveError};

/// The constraints on one agent.
#[derive(Debug, Clone, Default)]
pub(crate) struct Constraints {
    /// `(cell, t)`: not at `cell` at time `t`.
    vertex: FastSet<(u32, u32)>,
    /// `(from, to, t)`: not moving `from → to` in step `t → t + 1`.
    edge: FastSet<(u32, u32, u32)>,
    /// `cell → t0`: not at `cell` at any time `t ≥ t0` (a cell another
    /// agent rests on for good; prioritized planning).
    blocked_from: FastMap<u32, u32>,
    /// Latest time any constraint mentions (vertex `t`, edge `t + 1`).
    last_t: u32,
    /// Latest vertex constraint time on the goal cell.
    goal_last: Option<u32>,
    goal: u32,
}

impl Constraints {
    pub fn new(goal: u32) -> Self {
        Self {
            goal,
            ..Self::default()
        }
    }

    pub fn add_vertex(&mut self, cell: u32, t: u32) {
        self.vertex.insert((cell, t));
        self.last_t = self.last_t.max(t);
        if cell == self.goal {
            self.goal_last = Some(self.goal_last.map_or(t, |g| g.max(t)));
        }
    }

    pub fn add_edge(&mut self, from: u32, to: u32, t: u32) {
        self.edge.insert((from, to, t));
        self.last_t = self.last_t.max(t + 1);
    }

    /// Not at `cell` at `t0` or any later time. On the agent's own goal it
    /// makes arriving impossible (the agent could not rest there).
    pub fn add_blocked_from(&mut self, cell: u32, t0: u32) {
        let from = self.blocked_from.entry(cell).or_insert(t0);
        *from = (*from).min(t0);
        self.last_t = self.last_t.max(t0);
    }

    /// Whether the agent may stand on `cell` at `t`.
    #[inline]
    fn allows(&self, cell: u32, t: u32) -> bool {
        !self.vertex.contains(&(cell, t)) && self.blocked_from.get(&cell).is_none_or(|&t0| t < t0)
    }

    /// Whether the agent may arrive on its goal at `t` and rest there.
    #[inline]
    fn may_rest_on_goal_from(&self, t: u32) -> bool {
        self.goal_last.is_none_or(|g| t > g) && !self.blocked_from.contains_key(&self.goal)
    }
}

/// What the low level asks of the other agents' paths: where and when the
/// agent may stand, which moves it may make, and from when it may rest on
/// its goal. [`Constraints`] answers from explicit sets (CBS, prioritized
/// planning); [`crate::lns`] from a table of the other agents' paths.
pub(crate) trait Obstacles {
    /// Whether the agent may stand on `cell` at `t`.
    fn allows(&self, cell: u32, t: u32) -> bool;
    /// Whether the agent may move `from → to` (`from != to`) in step
    /// `t → t + 1`, its cells at both times allowed.
    fn allows_move(&self, from: u32, to: u32, t: u32) -> bool;
    /// Whether the agent may arrive on its goal at `t` and rest there.
    fn may_rest_on_goal_from(&self, t: u32) -> bool;
    /// The latest time anything constrains (after it, the future no longer
    /// depends on the clock).
    fn last_t(&self) -> u32;
}

impl Obstacles for Constraints {
    #[inline]
    fn allows(&self, cell: u32, t: u32) -> bool {
        Constraints::allows(self, cell, t)
    }

    #[inline]
    fn allows_move(&self, from: u32, to: u32, t: u32) -> bool {
        !self.edge.contains(&(from, to, t))
    }

    #[inline]
    fn may_rest_on_goal_from(&self, t: u32) -> bool {
        Constraints::may_rest_on_goal_from(self, t)
    }

    fn last_t(&self) -> u32 {
        self.last_t
    }
}

/// A conflict avoidance table: how many other agents stand on a cell at a
/// time (clamped to the others' horizon, after which they all rest). Used
/// only to break ties between equally short paths.
pub(crate) struct Cat {
    occ: FastMap<(u32, u32), u16>,
    horizon: u32,
}

impl Cat {
    /// The table of all `paths` except `agent`'s.
    pub fn new(paths: &[impl AsRef<[u32]>], agent: usize) -> Self {
        let horizon = paths
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != agent)
            .map(|(_, p)| p.as_ref().len() as u32 - 1)
            .max()
            .unwrap_or(0);
        let mut occ = FastMap::default();
        for (j, p) in paths.iter().enumerate() {
            if j == agent {
                continue;
            }
            let p = p.as_ref();
            for t in 0..=horizon {
                let cell = p[(t as usize).min(p.len() - 1)];
                *occ.entry((cell, t)).or_insert(0) += 1;
            }
        }
        Self { occ, horizon }
    }

    fn at(&self, cell: u32, t: u32) -> u32 {
        self.occ
            .get(&(cell, t.min(self.horizon)))
            .map_or(0, |&c| u32::from(c))
    }

    /// Conflicts of moving `from → to` in step `t → t + 1`: agents on `to`
    /// at `t + 1`, plus one if `to` is taken at `t` (a swap or following move).
    fn cost(&self, from: u32, to: u32, t: u32) -> u32 {
        self.at(to, t + 1) + u32::from(from != to && self.at(to, t) > 0)
    }
}

/// The low level's answer.
pub(crate) enum LowResult {
    /// Cells at times `0..=arrival`, ending on the goal.
    Path(Vec<u32>),
    /// No path; `capped` if the makespan cap cut the search.
    NoPath { capped: bool },
}

#[derive(Clone, Copy)]
struct LNode {
    cell: u32,
    parent: u32,
}

/// Bytes per stored low-level node (node, `seen` entry, heap entry).
const LOW_NODE_BYTES: usize = 12 + 20 + 16;

/// Space-time A* from `start` to `goal` under `cons`, with heuristic table
/// `h`; no path may end later than `cap`. With a [`Cat`], ties between
/// equally short paths go to the one with fewer conflicts. Its nodes count
/// against the memory limit beside what `budget` holds.
#[allow(clippy::too_many_arguments)]
pub(crate) fn space_time_astar(
    topo: &Topology,
    start: u32,
    goal: u32,
    h: &[u32],
    cons: &impl Obstacles,
    cat: Option<&Cat>,
    cap: Option<usize>,
    budget: &mut Budget,
) -> Result<LowResult, SolveError> {
    if !cons.allows(start, 0) {
        return Ok(LowResult::NoPath { capped: false });
    }
    let merge_after = cons.last_t() + 1;
    let key = |cell: u32, t: u32| (cell, t.min(merge_after));
    let mut nodes = vec![LNode {
        cell: start,
        parent: NONE,
    }];
    // Best (t, conflicts) per state key.
    let mut seen: FastMap<(u32, u32), (u32, u32)> = FastMap::default();
    seen.insert(key(start, 0), (0, 0));
    // Max-heap on (−f, −conflicts, t, id): lowest f, then fewest conflicts,
    // then latest t (deepest), then newest.
    let mut open = BinaryHeap::new();
    open.push((Reverse(h[start as usize]), Reverse(0u32), 0u32, 0u32));
    let mut capped = false;
    while let Some((_, Reverse(conflicts), t, id)) = open.pop() {
        let node = nodes[id as usize];
        if seen[&key(node.cell, t)] < (t, conflicts) {
            continue; // reached earlier (or as early with fewer conflicts)
        }
        budget.low_expanded += 1;
        if budget.low_expanded & 4095 == 0 {
            budget.check_time()?;
            budget.check_memory(nodes.len() * LOW_NODE_BYTES)?;
        }
        if node.cell == goal && cons.may_rest_on_goal_from(t) {
            let mut path = Vec::with_capacity(t as usize + 1);
            let mut k = id;
            while k != NONE {
                path.push(nodes[k as usize].cell);
                k = nodes[k as usize].parent;
            }
            path.reverse();
            return Ok(LowResult::Path(path));
        }
        let nt = t + 1;
        if cap.is_some_and(|c| nt as usize > c) {
            capped = true;
            continue;
        }
        for &to in topo.moves(node.cell) {
            if to == NONE
                || !cons.allows(to, nt)
                || (to != node.cell && !cons.allows_move(node.cell, to, t))
            {
                continue;
            }
            let nc = conflicts + cat.map_or(0, |c| c.cost(node.cell, to, t));
            let k = key(to, nt);
            match seen.get(&k) {
                Some(&best) if best <= (nt, nc) => continue,
                _ => {}
            }
            seen.insert(k, (nt, nc));
            let nid = nodes.len() as u32;
            nodes.push(LNode {
                cell: to,
                parent: id,
            });
            open.push((Reverse(nt + h[to as usize]), Reverse(nc), nt, nid));
        }
    }
    Ok(LowResult::NoPath { capped })
}
