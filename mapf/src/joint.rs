//! What the two joint-state searches, MA-A* and OD-A*, keep alike: the
//! packed hash key of a joint state, the memory its index holds, and the
//! plan read back along a parent chain.

use std::hash::Hash;

use crate::graph::{FastMap, Topology, NONE};
use crate::limits::SolveError;
use crate::plan::Plan;

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

/// Bytes held by a search's node index with keys of `key_len` cells, from
/// its allocated capacity (a hash table slot is a `(K, u32)` pair plus a
/// control byte).
pub(crate) fn index_bytes<K: JointKey>(index: &FastMap<K, u32>, key_len: usize) -> usize {
    index.capacity() * (std::mem::size_of::<(K, u32)>() + 1) * 8 / 7
        + index.len() * K::heap_bytes(key_len)
}

/// The plan read back from node `goal` to the root by `parent`: the joint
/// states (`n` cells of node `k` at `states[k * n..(k + 1) * n]`) of the
/// nodes `keep` accepts, root first.
pub(crate) fn chain_plan(
    topo: &Topology,
    n: usize,
    states: &[u32],
    goal: u32,
    parent: impl Fn(u32) -> u32,
    keep: impl Fn(u32) -> bool,
) -> Plan {
    let mut chain = Vec::new();
    let mut id = goal;
    while id != NONE {
        if keep(id) {
            chain.push(id);
        }
        id = parent(id);
    }
    chain.reverse();
    topo.plan(
        n,
        chain
            .iter()
            .map(|&k| &states[k as usize * n..(k as usize + 1) * n]),
    )
}

/// A search over joint states, run with one kind of [`JointKey`].
pub(crate) trait JointSearch {
    /// Searches from the joint state `start`.
    fn run<K: JointKey>(&mut self, start: &[u32]) -> Result<Plan, SolveError>;
}

/// Runs `search` from `start` with keys of `key_len` cells of `bits` bits
/// each: packed into a `u128` where they fit, a boxed slice otherwise.
pub(crate) fn run_keyed(
    search: &mut impl JointSearch,
    start: &[u32],
    key_len: usize,
    bits: u32,
) -> Result<Plan, SolveError> {
    if key_len as u32 * bits <= 128 {
        search.run::<u128>(start)
    } else {
        search.run::<Box<[u32]>>(start)
    }
}
