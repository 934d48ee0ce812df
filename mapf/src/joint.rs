//! What the two joint-state searches, MA-A* and OD-A*, keep alike: the
//! packed hash key of a joint state, the arena of nodes and their memory,
//! the plan read back along a parent chain, and the solve around a search.

use std::collections::BinaryHeap;
use std::hash::Hash;

use buridan_env::Cell;

use crate::graph::{FastMap, Topology, NONE};
use crate::limits::{Budget, SolveError};
use crate::plan::Plan;
use crate::planner::Solution;

/// A joint state as a hash key (OD-A*'s with the next agent appended).
pub(crate) trait JointKey: Hash + Eq {
    fn pack(cells: &[u32], bits: u32) -> Self;
    /// Heap bytes owned by a key of `n` cells beyond `size_of::<Self>()`.
    fn heap_bytes(n: usize) -> usize;
}

impl JointKey for u128 {
    fn pack(cells: &[u32], bits: u32) -> Self {
        cells
            .iter()
            .fold(0u128, |acc, &c| (acc << bits) | u128::from(c))
    }
    fn heap_bytes(_: usize) -> usize {
        0
    }
}

impl JointKey for Box<[u32]> {
    fn pack(cells: &[u32], _: u32) -> Self {
        cells.into()
    }
    fn heap_bytes(n: usize) -> usize {
        4 * n + 16
    }
}

/// The nodes a joint search has generated, its open list and its budget:
/// node `k` with record `nodes[k]` stands on the cells
/// `states[k * n..(k + 1) * n]`.
pub(crate) struct Arena<'a, N, E: Ord> {
    /// Agents.
    pub n: usize,
    pub states: Vec<u32>,
    pub nodes: Vec<N>,
    pub open: BinaryHeap<E>,
    pub budget: &'a mut Budget,
}

impl<'a, N, E: Ord> Arena<'a, N, E> {
    /// An empty arena for `n` agents.
    pub fn new(n: usize, budget: &'a mut Budget) -> Self {
        Self {
            n,
            states: Vec::new(),
            nodes: Vec::new(),
            open: BinaryHeap::new(),
            budget,
        }
    }

    /// The cells of node `id`.
    pub fn cells(&self, id: u32) -> &[u32] {
        let (n, k) = (self.n, id as usize);
        &self.states[k * n..(k + 1) * n]
    }

    /// Bytes held by the arena and by `index` (keys of `key_len` cells),
    /// from the allocated capacities (a hash table slot is a `(K, u32)`
    /// pair plus a control byte).
    pub fn bytes<K: JointKey>(&self, index: &FastMap<K, u32>, key_len: usize) -> usize {
        self.states.capacity() * 4
            + self.nodes.capacity() * std::mem::size_of::<N>()
            + self.open.capacity() * std::mem::size_of::<E>()
            + index.capacity() * (std::mem::size_of::<(K, u32)>() + 1) * 8 / 7
            + index.len() * K::heap_bytes(key_len)
    }

    /// The plan read back from node `goal` to the root by `parent`: the
    /// cells of the nodes `keep` accepts, root first.
    pub fn plan(
        &self,
        topo: &Topology,
        goal: u32,
        parent: impl Fn(&N) -> u32,
        keep: impl Fn(&N) -> bool,
    ) -> Plan {
        let mut chain = Vec::new();
        let mut id = goal;
        while id != NONE {
            let node = &self.nodes[id as usize];
            if keep(node) {
                chain.push(id);
            }
            id = parent(node);
        }
        chain.reverse();
        topo.plan(self.n, chain.iter().map(|&k| self.cells(k)))
    }
}

/// A search over joint states, run with one kind of [`JointKey`].
pub(crate) trait JointSearch {
    /// Searches from the joint state `start`.
    fn run<K: JointKey>(&mut self, start: &[u32]) -> Result<Plan, SolveError>;
    /// The budget the search runs on.
    fn budget(&self) -> &Budget;
}

/// Runs `search` from `starts` with keys of `key_len` cells of `bits` bits
/// each (packed into a `u128` where they fit, a boxed slice otherwise):
/// the plan and the effort it took.
pub(crate) fn solve_keyed(
    search: &mut impl JointSearch,
    topo: &Topology,
    starts: &[Cell],
    key_len: usize,
    bits: u32,
) -> Result<Solution, SolveError> {
    let start = topo.indices(starts);
    let plan = if key_len as u32 * bits <= 128 {
        search.run::<u128>(&start)
    } else {
        search.run::<Box<[u32]>>(&start)
    }?;
    Ok(Solution {
        plan,
        stats: search.budget().stats(),
    })
}
