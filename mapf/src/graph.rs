//! The grid as the solvers see it: `u32` cell indices and a move table.

use buridan_env::{Cell, Grid};

/// Marks "no such move" (wall or outside the grid) in [`Topology::moves`].
pub(crate) const NONE: u32 = u32::MAX;

/// Row-major cell indices and, per cell, the target of each of the 5
/// actions (0 stay, 1 up, 2 right, 3 down, 4 left), or [`NONE`].
pub(crate) struct Topology {
    width: usize,
    moves: Vec<[u32; 5]>,
}

impl Topology {
    pub fn new(grid: &Grid) -> Self {
        let cells = grid.height() * grid.width();
        let moves = (0..cells)
            .map(|i| {
                let cell = grid.cell(i);
                let mut m = [NONE; 5];
                if !grid.is_wall(cell) {
                    for (a, slot) in m.iter_mut().enumerate() {
                        if let Some(n) = grid.neighbour(cell, a as u8) {
                            if !grid.is_wall(n) {
                                *slot = grid.index(n) as u32;
                            }
                        }
                    }
                }
                m
            })
            .collect();
        Self {
            width: grid.width(),
            moves,
        }
    }

    pub fn cells(&self) -> usize {
        self.moves.len()
    }

    pub fn index(&self, cell: Cell) -> u32 {
        (cell.row * self.width + cell.col) as u32
    }

    pub fn cell(&self, index: u32) -> Cell {
        let i = index as usize;
        Cell::new(i / self.width, i % self.width)
    }

    /// Targets of the 5 actions from `cell` ([`NONE`] where impossible).
    #[inline]
    pub fn moves(&self, cell: u32) -> &[u32; 5] {
        &self.moves[cell as usize]
    }
}

/// Per-cell Manhattan distances to `goal`.
pub(crate) fn manhattan_table(topo: &Topology, goal: Cell) -> Vec<u32> {
    (0..topo.cells() as u32)
        .map(|i| topo.cell(i).manhattan(goal) as u32)
        .collect()
}

/// Per-cell shortest-path distances to `goal` on the static grid
/// (`1 << 24`, more than any real distance, where unreachable; sums over
/// agents cannot overflow).
pub(crate) fn distance_table(grid: &Grid, goal: Cell) -> Vec<u32> {
    grid.distances_to(goal)
        .iter()
        .map(|&d| {
            if d == buridan_env::map::UNREACHABLE {
                1 << 24
            } else {
                u32::from(d)
            }
        })
        .collect()
}

/// A fast non-cryptographic hasher (the FxHash mixing step) for the
/// solvers' integer keys; `HashMap`'s default SipHash dominates the cost of
/// duplicate detection otherwise.
#[derive(Default, Clone, Copy)]
pub(crate) struct FxHasher {
    hash: u64,
}

const FX_K: u64 = 0x51_7c_c1_b7_27_22_0a_95;

impl std::hash::Hasher for FxHasher {
    #[inline]
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.write_u64(u64::from_le_bytes(word));
        }
    }
    #[inline]
    fn write_u32(&mut self, i: u32) {
        self.write_u64(u64::from(i));
    }
    #[inline]
    fn write_u64(&mut self, i: u64) {
        self.hash = (self.hash.rotate_left(5) ^ i).wrapping_mul(FX_K);
    }
    #[inline]
    fn write_u128(&mut self, i: u128) {
        self.write_u64(i as u64);
        self.write_u64((i >> 64) as u64);
    }
    #[inline]
    fn write_usize(&mut self, i: usize) {
        self.write_u64(i as u64);
    }
    #[inline]
    fn finish(&self) -> u64 {
        // Fold the high bits down: hashbrown takes the bucket from the low
        // bits and the tag from the top 7.
        self.hash ^ (self.hash >> 32)
    }
}

/// `HashMap` with [`FxHasher`].
pub(crate) type FastMap<K, V> =
    std::collections::HashMap<K, V, std::hash::BuildHasherDefault<FxHasher>>;
/// `HashSet` with [`FxHasher`].
pub(crate) type FastSet<K> = std::collections::HashSet<K, std::hash::BuildHasherDefault<FxHasher>>;
