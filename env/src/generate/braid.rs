//! Braid mazes: a perfect maze of one-cell corridors between pillars with
//! some of its walls knocked out, so that corridors form loops.

use rand::seq::SliceRandom;
use rand::Rng;

use super::{rng, MapGenerator};
use crate::map::Grid;

/// A braid maze of one-cell corridors (on a grid of odd height and width).
///
/// 1. The cells with two even coordinates are free rooms; the cells with
///    two odd coordinates are pillars (walls).
/// 2. Every other cell is a wall slot between two neighbouring rooms.
///    Randomised Kruskal knocks out slots, in a shuffled order, wherever
///    they join two rooms not yet connected: a perfect maze, a spanning
///    tree of the rooms.
/// 3. Each slot still standing is then knocked out with probability
///    `loops`, which adds cycles (0: a perfect maze; 1: an open lattice of
///    pillars).
///
/// ```
/// use buridan_env::generate::{Braid, MapGenerator};
/// let perfect = Braid { loops: 0.0 }.generate(5, 5, 1);
/// // 9 rooms joined by a tree of 8 open slots; 4 pillars and 4 slots stay walls.
/// assert_eq!(perfect.free_cells().len(), 9 + 8);
/// let open = Braid { loops: 1.0 }.generate(5, 5, 1);
/// assert_eq!(open.free_cells().len(), 25 - 4);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Braid {
    /// Chance that a wall slot the perfect maze keeps is knocked out.
    pub loops: f64,
}

impl Default for Braid {
    /// Half the standing walls knocked out.
    fn default() -> Self {
        Braid { loops: 0.5 }
    }
}

impl MapGenerator for Braid {
    fn generate(&self, h: usize, w: usize, seed: u64) -> Grid {
        let mut rng = rng(seed);
        // 1. Rooms free, everything else a wall for now.
        let mut walls: Vec<bool> = (0..h * w)
            .map(|i| (i / w) % 2 == 1 || (i % w) % 2 == 1)
            .collect();
        // 2. The slots between two rooms: one odd coordinate, one even.
        let mut slots: Vec<usize> = (0..h * w)
            .filter(|&i| ((i / w) % 2 == 1) != ((i % w) % 2 == 1))
            .collect();
        slots.shuffle(&mut rng);
        let mut rooms = UnionFind::new(h * w);
        let mut standing = Vec::new();
        for slot in slots {
            let (a, b) = if (slot / w) % 2 == 1 {
                (slot - w, slot + w)
            } else {
                (slot - 1, slot + 1)
            };
            if rooms.union(a, b) {
                walls[slot] = false;
            } else {
                standing.push(slot);
            }
        }
        // 3. Loops.
        for slot in standing {
            if rng.random_bool(self.loops) {
                walls[slot] = false;
            }
        }
        Grid::from_walls(h, w, walls)
    }
}

/// Disjoint sets of cells, by index, with path halving.
struct UnionFind {
    parent: Vec<usize>,
}

impl UnionFind {
    fn new(n: usize) -> Self {
        Self {
            parent: (0..n).collect(),
        }
    }

    fn find(&mut self, mut i: usize) -> usize {
        while self.parent[i] != i {
            self.parent[i] = self.parent[self.parent[i]];
            i = self.parent[i];
        }
        i
    }

    /// Joins the sets of `a` and `b`; false if they were one already.
    fn union(&mut self, a: usize, b: usize) -> bool {
        let (ra, rb) = (self.find(a), self.find(b));
        self.parent[ra] = rb;
        ra != rb
    }
}
