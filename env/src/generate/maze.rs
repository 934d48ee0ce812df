//! Mazes of wall segments, like POGEMA's maze maps: walls grown as random
//! walks along the odd rows and columns, mostly straight, leaving
//! corridors one cell wide where agents meet head-on.

use rand::seq::IndexedRandom;
use rand::Rng;

use super::{keep_largest_component, rng, MapGenerator};
use crate::map::Grid;

/// Walls grown from posts: the cells with two odd coordinates.
///
/// 1. The wall budget is `density` of all cells; each wall's share is
///    the budget over `walls`.
/// 2. Each wall starts on a free post drawn at random and walks from
///    post to post (two cells at a time, walling in the cell between),
///    only ever onto a post that is not a wall yet: it keeps its
///    direction with probability `straight` when that post is open, and
///    otherwise turns to another open one drawn at random. It stops when
///    it has walled in its share of cells or no post next to it is open;
///    walls are grown until the budget is spent (or as many walls as
///    there are posts, beyond `walls`, have been tried: a lattice that
///    takes no more).
///    So every wall is a tree of posts that touches no other wall and no
///    border (the border rows and columns hold no posts), and the free
///    cells stay one region.
/// 3. As a guard, free cells cut off from the largest region would be
///    walled in ([`super::keep_largest_component`]).
///
/// ```
/// use buridan_env::generate::{MapGenerator, Maze};
/// let grid = Maze::default().generate(19, 19, 0);
/// let walls = 19 * 19 - grid.free_cells().len();
/// assert!((80..=150).contains(&walls), "{walls}");
/// assert_eq!(Maze { density: 0.0, ..Maze::default() }.generate(9, 9, 0).free_cells().len(), 81);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Maze {
    /// Share of the cells the walls take (a budget: the post lattice
    /// holds at most about 45 %).
    pub density: f64,
    /// How many walls share the budget (more if some stop early).
    pub walls: usize,
    /// Chance that a wall keeps its direction at a post.
    pub straight: f64,
}

impl Default for Maze {
    /// Close to POGEMA's mazes: 19×19 maps of that kind have about 30 %
    /// walls, grown as a few mostly straight walls.
    fn default() -> Self {
        Maze {
            density: 0.3,
            walls: 8,
            straight: 0.8,
        }
    }
}

/// The four directions as (row, column) steps.
const DIRECTIONS: [(isize, isize); 4] = [(-1, 0), (0, 1), (1, 0), (0, -1)];

impl MapGenerator for Maze {
    fn generate(&self, h: usize, w: usize, seed: u64) -> Grid {
        let mut rng = rng(seed);
        let mut walls = vec![false; h * w];
        let posts: Vec<(usize, usize)> = (1..h)
            .step_by(2)
            .flat_map(|r| (1..w).step_by(2).map(move |c| (r, c)))
            .collect();
        // 1. The budget.
        let budget = (self.density * (h * w) as f64).round() as usize;
        let share = budget.div_ceil(self.walls.max(1));
        if posts.is_empty() || share == 0 {
            return Grid::from_walls(h, w, walls);
        }
        // A post two cells from `(r, c)` in direction `d`, if inside.
        let step = |(r, c): (usize, usize), (dr, dc): (isize, isize)| {
            let (r2, c2) = (r as isize + 2 * dr, c as isize + 2 * dc);
            (r2 >= 0 && c2 >= 0 && (r2 as usize) < h && (c2 as usize) < w)
                .then_some((r2 as usize, c2 as usize))
        };
        let wall_in = |walls: &mut Vec<bool>, (r, c): (usize, usize)| {
            let new = !walls[r * w + c];
            walls[r * w + c] = true;
            usize::from(new)
        };
        // 2. The walks: each step reaches a post that is no wall yet.
        let mut total = 0;
        for _ in 0..self.walls + posts.len() {
            if total >= budget {
                break;
            }
            let mut at = *posts.choose(&mut rng).expect("posts is not empty");
            if walls[at.0 * w + at.1] {
                continue;
            }
            let mut heading = *DIRECTIONS.choose(&mut rng).expect("four directions");
            let mut placed = wall_in(&mut walls, at);
            while placed < share {
                let open = |walls: &[bool], d| step(at, d).filter(|&(r, c)| !walls[r * w + c]);
                if open(&walls, heading).is_none() || !rng.random_bool(self.straight) {
                    let turns: Vec<(isize, isize)> = DIRECTIONS
                        .into_iter()
                        .filter(|&d| d != heading && open(&walls, d).is_some())
                        .collect();
                    match turns.choose(&mut rng) {
                        Some(&d) => heading = d,
                        None if open(&walls, heading).is_some() => {}
                        None => break,
                    }
                }
                let next = open(&walls, heading).expect("the heading reaches an open post");
                let between = ((at.0 + next.0) / 2, (at.1 + next.1) / 2);
                placed += wall_in(&mut walls, between) + wall_in(&mut walls, next);
                at = next;
            }
            total += placed;
        }
        // 3. One region.
        keep_largest_component(h, w, &mut walls);
        Grid::from_walls(h, w, walls)
    }
}
