//! Seeded map generators: mazes, braid mazes, random obstacles and
//! warehouse-like rows of shelves, for training on many layouts of a kind rather than a few
//! fixed ones.
//!
//! A generated map is named by its spec, `FAMILY/HEIGHTxWIDTH[/KEY=VALUE…]/seed=S`,
//! which [`crate::Map::load`] accepts wherever a map id or file is taken
//! (`learner train --map`, `--maps`, `learner eval --map`, Python). The
//! same spec always gives the same grid, and every generated grid's free
//! cells form one 4-connected component, so any start reaches any goal.
//!
//! | family | keys (default) | what varies with the seed |
//! |---|---|---|
//! | `maze` | `density` (0.3), `walls` (8), `straight` (0.8): walls grown as mostly straight random walks, like POGEMA's mazes | the walls |
//! | `braid` | `loops` (0.5): share of the walls a perfect maze keeps that are knocked out (odd sides) | the maze |
//! | `random` | `density` (0.3): chance that a cell is an obstacle | the obstacles |
//! | `warehouse` | `shelf` (10), `gap` (1), `aisle` (3), `margin` (7), `edge` (2), `missing` (0) | which shelves are missing |
//!
//! ```
//! use buridan_env::generate::GeneratedMap;
//! use buridan_env::Map;
//! let spec: GeneratedMap = "maze/19x19/seed=7".parse().unwrap();
//! let grid = spec.grid();
//! assert_eq!((grid.height(), grid.width()), (19, 19));
//! assert_eq!(spec.to_string(), "maze/19x19/seed=7");
//! // Map::load takes the spec as a map name.
//! let map = Map::load("maze/19x19/seed=7").unwrap();
//! assert_eq!(map.name, "maze/19x19/seed=7");
//! assert_eq!(map.grid.walls(), grid.walls());
//! // The defaults of `warehouse` draw POGEMA's 33×46 warehouse.
//! let pogema = "warehouse/33x46/seed=0".parse::<GeneratedMap>().unwrap().grid();
//! assert_eq!(pogema.free_cells().len(), 33 * 46 - 8 * 30);
//! ```

mod braid;
mod maze;
mod random;
mod spec;
mod warehouse;

pub use braid::Braid;
pub use maze::Maze;
pub use random::RandomObstacles;
pub use spec::{Family, GeneratedMap, SpecError, SpecProblem, FAMILIES};
pub use warehouse::Warehouse;

use crate::map::{Cell, Grid};

/// A family of layouts, one per size and seed: the same size and seed
/// give the same grid.
pub trait MapGenerator {
    /// The `height × width` grid drawn for `seed`.
    fn generate(&self, height: usize, width: usize, seed: u64) -> Grid;
}

/// Walls in every free cell outside the largest 4-connected component of
/// free cells (the first in row-major order among equally large ones), so
/// that every free cell reaches every other. The wall mask is row-major,
/// `height × width`.
///
/// ```
/// use buridan_env::generate::keep_largest_component;
/// // Two free cells on the left, one cut off on the right.
/// let mut walls = vec![false, false, true, false];
/// keep_largest_component(1, 4, &mut walls);
/// assert_eq!(walls, [false, false, true, true]);
/// ```
pub fn keep_largest_component(height: usize, width: usize, walls: &mut [bool]) {
    let mut component = vec![usize::MAX; height * width];
    let mut sizes = Vec::new();
    let mut queue = Vec::new();
    for start in 0..height * width {
        if walls[start] || component[start] != usize::MAX {
            continue;
        }
        let id = sizes.len();
        component[start] = id;
        queue.push(start);
        let mut size = 0;
        while let Some(i) = queue.pop() {
            size += 1;
            let cell = Cell::new(i / width, i % width);
            for next in neighbours(cell, height, width) {
                let j = next.row * width + next.col;
                if !walls[j] && component[j] == usize::MAX {
                    component[j] = id;
                    queue.push(j);
                }
            }
        }
        sizes.push(size);
    }
    // The first of the largest: `max_by_key` would take the last.
    let Some(largest) = (0..sizes.len()).rev().max_by_key(|&id| sizes[id]) else {
        return;
    };
    for (wall, id) in walls.iter_mut().zip(component) {
        if id != largest {
            *wall = true;
        }
    }
}

/// The up to four cells next to `cell` inside a `height × width` grid.
fn neighbours(cell: Cell, height: usize, width: usize) -> impl Iterator<Item = Cell> {
    let Cell { row, col } = cell;
    [
        (row > 0).then(|| Cell::new(row - 1, col)),
        (row + 1 < height).then(|| Cell::new(row + 1, col)),
        (col > 0).then(|| Cell::new(row, col - 1)),
        (col + 1 < width).then(|| Cell::new(row, col + 1)),
    ]
    .into_iter()
    .flatten()
}

/// The random stream a generator draws `seed`'s grid from
/// ([`crate::seed::generated_map`]).
fn rng(seed: u64) -> rand_chacha::ChaCha8Rng {
    use rand::SeedableRng;
    rand_chacha::ChaCha8Rng::seed_from_u64(crate::seed::generated_map(seed))
}

#[cfg(test)]
mod tests;
