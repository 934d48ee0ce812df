//! Random obstacles, like POGEMA's random maps.

use rand::Rng;

use super::{keep_largest_component, rng, MapGenerator};
use crate::map::Grid;

/// Each cell an obstacle with probability `density`, independently; then
/// every free cell outside the largest connected region is walled in, so
/// that all free cells connect ([`super::keep_largest_component`]). The
/// walls' share ends somewhat above `density`.
///
/// ```
/// use buridan_env::generate::{MapGenerator, RandomObstacles};
/// let grid = RandomObstacles { density: 0.3 }.generate(20, 20, 0);
/// let walls = 400 - grid.free_cells().len();
/// assert!((100..=160).contains(&walls), "{walls}");
/// assert_eq!(RandomObstacles { density: 0.0 }.generate(3, 3, 5).free_cells().len(), 9);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RandomObstacles {
    /// Chance that a cell is an obstacle.
    pub density: f64,
}

impl Default for RandomObstacles {
    /// Three cells in ten.
    fn default() -> Self {
        RandomObstacles { density: 0.3 }
    }
}

impl MapGenerator for RandomObstacles {
    fn generate(&self, h: usize, w: usize, seed: u64) -> Grid {
        let mut rng = rng(seed);
        let mut walls: Vec<bool> = (0..h * w).map(|_| rng.random_bool(self.density)).collect();
        keep_largest_component(h, w, &mut walls);
        Grid::from_walls(h, w, walls)
    }
}
