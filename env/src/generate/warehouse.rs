//! Warehouse-like layouts: rows of shelves with aisles between them and
//! open ends, like POGEMA's warehouse.

use rand::Rng;

use super::{keep_largest_component, rng, MapGenerator};
use crate::map::Grid;

/// Rows of one-cell-deep shelves. Across the grid: `margin` free columns
/// at each end, then blocks of `shelf` shelf cells with `gap` free columns
/// between blocks. Down the grid: `edge` free rows at the top and bottom,
/// then shelf rows with `aisle` free rows between them. As many blocks
/// and shelf rows as fit; what is left over widens the margins and edges
/// (the extra one at the bottom or right). Each block is left out with
/// probability `missing` (the only thing the seed draws). Free cells cut
/// off from the rest (only possible without edges, as between the blocks
/// of a one-row grid) are walled in ([`super::keep_largest_component`]).
///
/// ```
/// use buridan_env::generate::{MapGenerator, Warehouse};
/// let small = Warehouse { shelf: 3, gap: 1, aisle: 1, margin: 1, edge: 1, missing: 0.0 };
/// let rows: Vec<String> = (0..7)
///     .map(|r| (0..9).map(|c| if small.generate(7, 9, 0).is_wall(buridan_env::Cell::new(r, c)) { '@' } else { '.' }).collect())
///     .collect();
/// assert_eq!(rows, [".........", ".@@@.@@@.", ".........", ".@@@.@@@.", ".........", ".@@@.@@@.", "........."]);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Warehouse {
    /// Shelf cells per block.
    pub shelf: usize,
    /// Free columns between two blocks of a row.
    pub gap: usize,
    /// Free rows between two shelf rows.
    pub aisle: usize,
    /// Free columns at the left and right ends (at least).
    pub margin: usize,
    /// Free rows at the top and bottom (at least).
    pub edge: usize,
    /// Chance that a block is left out.
    pub missing: f64,
}

impl Default for Warehouse {
    /// POGEMA's warehouse proportions: blocks of 10 shelves one column
    /// apart, three-row aisles, seven free columns at each end for the
    /// robots' start areas and two free rows at the top and bottom.
    fn default() -> Self {
        Warehouse {
            shelf: 10,
            gap: 1,
            aisle: 3,
            margin: 7,
            edge: 2,
            missing: 0.0,
        }
    }
}

impl Warehouse {
    /// How many shelf rows and blocks per row fit in `height × width`:
    /// `(rows, blocks)`, each 0 when none fits.
    ///
    /// ```
    /// assert_eq!(buridan_env::generate::Warehouse::default().fits(33, 46), (8, 3));
    /// ```
    pub fn fits(&self, height: usize, width: usize) -> (usize, usize) {
        (
            count(height, 2 * self.edge, 1, self.aisle),
            count(width, 2 * self.margin, self.shelf, self.gap),
        )
    }
}

/// How many items of `size` with `between` free cells between neighbours
/// fit in `length` minus `ends`.
fn count(length: usize, ends: usize, size: usize, between: usize) -> usize {
    match length.checked_sub(ends) {
        Some(room) if room >= size => (room + between) / (size + between),
        _ => 0,
    }
}

/// Where the first of `n` items of `size`, `between` apart, starts when
/// they are centred in `length` (the odd cell left over goes after them).
fn first(length: usize, n: usize, size: usize, between: usize) -> usize {
    let used = n * size + n.saturating_sub(1) * between;
    (length - used) / 2
}

impl MapGenerator for Warehouse {
    fn generate(&self, h: usize, w: usize, seed: u64) -> Grid {
        let mut rng = rng(seed);
        let mut walls = vec![false; h * w];
        let (rows, blocks) = self.fits(h, w);
        let top = first(h, rows, 1, self.aisle);
        let left = first(w, blocks, self.shelf, self.gap);
        for k in 0..rows {
            let row = top + k * (self.aisle + 1);
            for b in 0..blocks {
                if rng.random_bool(self.missing) {
                    continue;
                }
                let col = left + b * (self.shelf + self.gap);
                walls[row * w + col..row * w + col + self.shelf].fill(true);
            }
        }
        keep_largest_component(h, w, &mut walls);
        Grid::from_walls(h, w, walls)
    }
}
