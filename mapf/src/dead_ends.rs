//! Dead-end branches of a layout and the order robots must enter them in.
//!
//! A one-lane aisle closed at one end is filled from the back: a robot
//! whose goal lies nearer the mouth must not enter before every robot bound
//! deeper into the same aisle has passed its goal, or the deeper one can
//! never get by (nobody passes anybody in a one-lane aisle, and backing the
//! whole queue out is a search problem, not a step-by-step one). PIBT and
//! its swap see only one step ahead and livelock there (`mapf/tests/shield.rs`
//! keeps the toy; rm-2.1b's failures through the shield's fallback are
//! this case).
//!
//! The branches are found by peeling leaves: repeatedly remove every cell
//! with at most one neighbour left. What is removed hangs off the rest (the
//! *core*) as trees; each removed cell keeps its *parent* (its neighbour
//! towards the core) and its *depth* (steps to the core). A cell of the core
//! has depth 0. A layout that is a tree altogether keeps its last cell as
//! the core.
//!
//! ```
//! use buridan_env::{Cell, Grid};
//! use buridan_mapf::dead_ends::DeadEnds;
//! // A loop on the left, a dead-end aisle of four cells to the right.
//! let grid = Grid::from_rows(&["..@@@@", "......", "..@@@@"]).unwrap();
//! let aisle = DeadEnds::new(&grid);
//! assert_eq!(aisle.depth(Cell::new(1, 1)), 0); // the loop: core
//! assert_eq!(aisle.depth(Cell::new(1, 2)), 1); // the aisle's mouth
//! assert_eq!(aisle.depth(Cell::new(1, 5)), 4); // its far end
//! // A goal at (1, 3) is passed on the way to (1, 5): its robot waits.
//! assert!(aisle.is_on_the_way(Cell::new(1, 3), Cell::new(1, 5)));
//! assert!(!aisle.is_on_the_way(Cell::new(1, 5), Cell::new(1, 3)));
//! assert!(!aisle.is_on_the_way(Cell::new(1, 1), Cell::new(1, 5))); // core cells never
//! ```

use buridan_env::{Cell, Grid};

use crate::graph::{Topology, NONE};

/// The dead-end branches of a grid (see the [module docs](self)).
pub struct DeadEnds {
    topo: Topology,
    /// Per cell index: the neighbour towards the core ([`NONE`] on the
    /// core and on walls).
    parent: Vec<u32>,
    /// Per cell index: steps to the core (0 on the core and on walls).
    depth: Vec<u32>,
}

impl DeadEnds {
    /// Peels `grid`'s leaves (see the [module docs](self)).
    pub fn new(grid: &Grid) -> Self {
        let topo = Topology::new(grid);
        let n = topo.cells();
        let open: Vec<bool> = (0..n as u32).map(|v| topo.is_free(v)).collect();
        let mut degree: Vec<u32> = (0..n as u32)
            .map(|v| topo.neighbours(v).count() as u32)
            .collect();
        let mut removed = vec![false; n];
        let mut leaves: Vec<u32> = (0..n as u32)
            .filter(|&v| open[v as usize] && degree[v as usize] <= 1)
            .collect();
        let mut order = Vec::new();
        let mut parent = vec![NONE; n];
        while let Some(v) = leaves.pop() {
            let vi = v as usize;
            if removed[vi] {
                continue;
            }
            let rest: Vec<u32> = topo
                .neighbours(v)
                .filter(|&u| !removed[u as usize])
                .collect();
            if rest.is_empty() {
                // The last cell of a tree-shaped component: its core.
                continue;
            }
            removed[vi] = true;
            order.push(v);
            let u = rest[0];
            parent[vi] = u;
            degree[u as usize] -= 1;
            if degree[u as usize] <= 1 {
                leaves.push(u);
            }
        }
        // Depths from the core outwards: parents are removed later than
        // their children, so walk the removal order backwards.
        let mut depth = vec![0; n];
        for &v in order.iter().rev() {
            depth[v as usize] = depth[parent[v as usize] as usize] + 1;
        }
        Self {
            topo,
            parent,
            depth,
        }
    }

    /// Steps from `cell` to the core (0 on the core).
    pub fn depth(&self, cell: Cell) -> u32 {
        self.depth[self.topo.index(cell) as usize]
    }

    /// Whether a robot bound for `goal` passes `on` on its way in from the
    /// core: `on` is a branch cell between `goal` and the core (`goal`
    /// excluded).
    pub fn is_on_the_way(&self, on: Cell, goal: Cell) -> bool {
        self.index_on_the_way(self.topo.index(on), self.topo.index(goal))
    }

    /// [`DeadEnds::depth`] of the cell with index `cell`.
    pub(crate) fn index_depth(&self, cell: u32) -> u32 {
        self.depth[cell as usize]
    }

    pub(crate) fn index_on_the_way(&self, on: u32, goal: u32) -> bool {
        let (d_on, mut d) = (self.depth[on as usize], self.depth[goal as usize]);
        if d_on == 0 || d <= d_on {
            return false;
        }
        let mut v = goal;
        while d > d_on {
            v = self.parent[v as usize];
            d -= 1;
        }
        v == on
    }

    /// The branch cell at depth 1 that `cell` hangs from (the branch's
    /// mouth), or `None` on the core.
    pub(crate) fn mouth(&self, cell: u32) -> Option<u32> {
        let mut v = cell;
        if self.depth[v as usize] == 0 {
            return None;
        }
        while self.depth[v as usize] > 1 {
            v = self.parent[v as usize];
        }
        Some(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_comb_of_aisles_hangs_off_its_spine() {
        // rm-2.1b's shape in small: a two-wide spine, aisles of three.
        let grid = Grid::from_rows(&[".....", "..@@@", "....."]).unwrap();
        let d = DeadEnds::new(&grid);
        for col in 2..5 {
            assert_eq!(d.depth(Cell::new(0, col)), col as u32 - 1);
            assert_eq!(d.depth(Cell::new(2, col)), col as u32 - 1);
        }
        assert_eq!(d.depth(Cell::new(1, 0)), 0);
        let topo = Topology::new(&grid);
        let mouth = d.mouth(topo.index(Cell::new(0, 4)));
        assert_eq!(mouth, Some(topo.index(Cell::new(0, 2))));
        assert_eq!(d.mouth(topo.index(Cell::new(1, 1))), None);
        // Different aisles never wait on each other.
        assert!(!d.is_on_the_way(Cell::new(0, 2), Cell::new(2, 4)));
        assert!(d.is_on_the_way(Cell::new(2, 2), Cell::new(2, 4)));
    }

    #[test]
    fn dead_ends_below_a_loop() {
        // One aisle of two cells below the loop's bottom row.
        let grid = Grid::from_rows(&["...", ".@.", "...", "@.@", "@.@"]).unwrap();
        let grid2 = Grid::from_rows(&["...", ".@.", "...", ".@."]).unwrap();
        let d = DeadEnds::new(&grid);
        assert_eq!(d.depth(Cell::new(3, 1)), 1);
        assert_eq!(d.depth(Cell::new(4, 1)), 2);
        assert!(d.is_on_the_way(Cell::new(3, 1), Cell::new(4, 1)));
        let d2 = DeadEnds::new(&grid2);
        // Two separate one-cell dead ends below the loop's bottom row.
        assert_eq!(d2.depth(Cell::new(3, 0)), 1);
        assert_eq!(d2.depth(Cell::new(3, 2)), 1);
        assert!(!d2.is_on_the_way(Cell::new(3, 0), Cell::new(3, 2)));
    }

    #[test]
    fn a_corridor_alone_keeps_one_core_cell() {
        let grid = Grid::from_rows(&["....", "@@@@"]).unwrap();
        let d = DeadEnds::new(&grid);
        let depths: Vec<u32> = (0..4).map(|c| d.depth(Cell::new(0, c))).collect();
        assert_eq!(depths.iter().filter(|&&x| x == 0).count(), 1, "{depths:?}");
        assert_eq!(depths.iter().max(), Some(&3));
    }
}
