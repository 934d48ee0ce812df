//! The grid as the solvers see it: `u32` cell indices and a move table.

use buridan_env::{Cell, Grid};

use crate::plan::Plan;

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

    /// The indices of `cells`.
    pub fn indices(&self, cells: &[Cell]) -> Vec<u32> {
        cells.iter().map(|&c| self.index(c)).collect()
    }

    pub fn cell(&self, index: u32) -> Cell {
        let i = index as usize;
        Cell::new(i / self.width, i % self.width)
    }

    /// The plan of `n` agents visiting `configs` (one cell index per agent
    /// each) in order, trimmed after each agent's arrival.
    pub fn plan<'a, I>(&self, n: usize, configs: I) -> Plan
    where
        I: IntoIterator<Item = &'a [u32]>,
        I::IntoIter: Clone,
    {
        let configs = configs.into_iter();
        let paths = (0..n)
            .map(|i| configs.clone().map(|q| self.cell(q[i])).collect())
            .collect();
        Plan::new(paths).trimmed()
    }

    /// Targets of the 5 actions from `cell` ([`NONE`] where impossible).
    #[inline]
    pub fn moves(&self, cell: u32) -> &[u32; 5] {
        &self.moves[cell as usize]
    }

    /// Whether `cell` is free (not a wall).
    #[inline]
    pub fn is_free(&self, cell: u32) -> bool {
        self.moves[cell as usize][0] != NONE
    }

    /// The free cells one move from `cell`, in action order.
    pub fn neighbours(&self, cell: u32) -> impl Iterator<Item = u32> + '_ {
        self.moves[cell as usize][1..]
            .iter()
            .copied()
            .filter(|&u| u != NONE)
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

/// `HashMap` with rustc's Fx hash: the solvers' keys are small integers,
/// and `HashMap`'s default SipHash would dominate the cost of duplicate
/// detection.
pub(crate) type FastMap<K, V> = rustc_hash::FxHashMap<K, V>;
/// `HashSet` with the Fx hash (see [`FastMap`]).
pub(crate) type FastSet<K> = rustc_hash::FxHashSet<K>;
