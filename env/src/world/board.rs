//! The padded board: the per-cell arrays a step reads and writes.
//!
//! The grid is surrounded by a border of blocked cells as wide as the sensor
//! range, so that a move's target and an observation window never need a
//! bounds check. Cells are addressed by their *padded index*
//! ([`Board::padded`]).

use crate::map::{Cell, Grid};
use crate::obs::code;

use super::NUM_ACTIONS;

/// Sentinel for "no agent" in the per-cell arrays.
pub(super) const NOBODY: u16 = 0;

/// Per padded cell: walls, which agent stands there, whose goal it is, and
/// the code the observation encoders read; plus the padded index offset of
/// each action.
#[derive(Debug, Clone)]
pub(super) struct Board {
    /// Padding around the grid, = sensor range, so windows need no bounds checks.
    pad: usize,
    /// Columns of the padded board.
    pub(super) padded_width: usize,
    /// Per padded cell: 1 wall or outside, 0 free.
    pub(super) blocked: Vec<u8>,
    /// Per padded cell: agent index + 1, or 0.
    pub(super) occupant: Vec<u16>,
    /// Per padded cell: how many agents have it as their goal (more than
    /// one only where goals may be shared, [`super::GridEnv::reset_with_sequences`]).
    pub(super) goals_here: Vec<u16>,
    /// Per padded cell, the local code as any agent *not* involved sees it:
    /// 1 wall or outside, 2 agent, 4 goal, 0 empty (agent over goal). An
    /// observer's window is these codes with two fix-ups: its own cell and
    /// its own goal (see `obs.rs`). Kept in step with `occupant` and
    /// `goals_here` by the methods below.
    pub(super) shared_code: Vec<u8>,
    /// Padded index offset of each action's move.
    pub(super) step_offsets: [isize; NUM_ACTIONS],
}

impl Board {
    /// The board of `grid` with padding `pad` (at least 1), no agents and
    /// no goals on it.
    pub(super) fn new(grid: &Grid, pad: usize) -> Self {
        let (h, w) = (grid.height(), grid.width());
        let padded_width = w + 2 * pad;
        let mut blocked = vec![1u8; (h + 2 * pad) * padded_width];
        for r in 0..h {
            for c in 0..w {
                blocked[(r + pad) * padded_width + c + pad] =
                    u8::from(grid.is_wall(Cell::new(r, c)));
            }
        }
        let cells = blocked.len();
        let pw = padded_width as isize;
        Self {
            pad,
            padded_width,
            shared_code: blocked.clone(),
            blocked,
            occupant: vec![NOBODY; cells],
            goals_here: vec![0; cells],
            step_offsets: [0, -pw, 1, pw, -1],
        }
    }

    /// Number of padded cells.
    pub(super) fn len(&self) -> usize {
        self.blocked.len()
    }

    /// The padded index of a cell of the grid.
    #[inline]
    pub(super) fn padded(&self, cell: Cell) -> usize {
        (cell.row + self.pad) * self.padded_width + cell.col + self.pad
    }

    /// Whether an agent may move into padded cell `p` now: inside the grid,
    /// not a wall, nobody there.
    #[inline(always)]
    pub(super) fn is_open(&self, p: usize) -> bool {
        self.blocked[p] == 0 && self.occupant[p] == NOBODY
    }

    /// The agent standing on padded cell `p` has left it.
    #[inline(always)]
    pub(super) fn leave(&mut self, p: usize) {
        self.occupant[p] = NOBODY;
        self.shared_code[p] = if self.goals_here[p] != 0 {
            code::GOAL
        } else {
            code::EMPTY
        };
    }

    /// Agent `agent` has entered padded cell `p` (free until now).
    #[inline(always)]
    pub(super) fn enter(&mut self, agent: usize, p: usize) {
        self.occupant[p] = agent as u16 + 1;
        self.shared_code[p] = code::AGENT;
    }

    /// Agent `agent` has moved from padded cell `from` to the open cell `to`.
    #[inline(always)]
    pub(super) fn move_agent(&mut self, agent: usize, from: usize, to: usize) {
        self.occupant[from] = NOBODY;
        self.occupant[to] = agent as u16 + 1;
        self.shared_code[from] = if self.goals_here[from] != 0 {
            code::GOAL
        } else {
            code::EMPTY
        };
        self.shared_code[to] = code::AGENT;
    }

    /// Takes one agent's goal off padded cell `old` and puts it on `new`.
    pub(super) fn move_goal(&mut self, old: usize, new: usize) {
        self.goals_here[old] = self.goals_here[old].saturating_sub(1);
        self.refresh_code(old);
        self.goals_here[new] += 1;
        self.refresh_code(new);
    }

    /// Takes an agent standing on padded cell `pos` with its goal on `goal`
    /// off the board, leaving the codes of both cells to be refreshed. A
    /// reset takes every agent off, so `goal` is nobody's goal afterwards.
    pub(super) fn remove_agent(&mut self, pos: usize, goal: usize) {
        self.occupant[pos] = NOBODY;
        self.goals_here[goal] = 0;
        self.shared_code[pos] = self.blocked[pos];
        self.shared_code[goal] = self.blocked[goal];
    }

    /// Puts agent `agent` on padded cell `pos` with its goal on `goal`,
    /// leaving the codes of both cells to be refreshed (once every agent is
    /// placed).
    pub(super) fn place_agent(&mut self, agent: usize, pos: usize, goal: usize) {
        self.occupant[pos] = agent as u16 + 1;
        self.goals_here[goal] += 1;
    }

    /// Recomputes the shared code of padded cell `p` from the cell arrays.
    pub(super) fn refresh_code(&mut self, p: usize) {
        self.shared_code[p] = if self.blocked[p] != 0 {
            code::WALL
        } else if self.occupant[p] != NOBODY {
            code::AGENT
        } else if self.goals_here[p] != 0 {
            code::GOAL
        } else {
            code::EMPTY
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::Map;

    fn board(pad: usize) -> (Board, Grid) {
        let map = Map::load("rm-1.1").unwrap();
        (Board::new(&map.grid, pad), map.grid)
    }

    #[test]
    fn padding_is_blocked_and_indices_match_cells() {
        let (b, grid) = board(2);
        assert_eq!(b.padded_width, grid.width() + 4);
        assert_eq!(b.len(), (grid.height() + 4) * (grid.width() + 4));
        assert!(b.blocked[..2 * b.padded_width].iter().all(|&x| x == 1));
        for r in 0..grid.height() {
            for c in 0..grid.width() {
                let cell = Cell::new(r, c);
                let p = b.padded(cell);
                assert_eq!(b.blocked[p] == 1, grid.is_wall(cell));
                assert_eq!(b.shared_code[p], b.blocked[p]);
                assert_eq!(b.is_open(p), !grid.is_wall(cell));
                // Each action's offset is its move on the grid.
                for (a, (dr, dc)) in super::super::MOVE_DELTAS.iter().enumerate() {
                    let (nr, nc) = (r as isize + dr + 2, c as isize + dc + 2);
                    let q = nr as usize * b.padded_width + nc as usize;
                    assert_eq!(p.wrapping_add_signed(b.step_offsets[a]), q);
                }
            }
        }
    }

    #[test]
    fn codes_follow_agents_and_goals() {
        let (mut b, grid) = board(1);
        let free = grid.free_cells();
        let (p, g, q) = (b.padded(free[0]), b.padded(free[1]), b.padded(free[2]));
        b.place_agent(0, p, g);
        b.refresh_code(p);
        b.refresh_code(g);
        assert_eq!(
            (b.shared_code[p], b.shared_code[g]),
            (code::AGENT, code::GOAL)
        );
        assert!(!b.is_open(p) && b.is_open(g));
        // Onto its goal and off again.
        b.leave(p);
        b.enter(0, g);
        assert_eq!((b.occupant[p], b.occupant[g]), (NOBODY, 1));
        assert_eq!(
            (b.shared_code[p], b.shared_code[g]),
            (code::EMPTY, code::AGENT)
        );
        b.leave(g);
        assert_eq!(b.shared_code[g], code::GOAL);
        b.enter(0, p);
        // The goal moves; the old cell is plain floor again.
        b.move_goal(g, q);
        assert_eq!((b.goals_here[g], b.goals_here[q]), (0, 1));
        assert_eq!(
            (b.shared_code[g], b.shared_code[q]),
            (code::EMPTY, code::GOAL)
        );
        // One sequential move does what leaving and entering do.
        let mut c = b.clone();
        c.leave(p);
        c.enter(0, g);
        b.move_agent(0, p, g);
        assert_eq!((&b.occupant, &b.shared_code), (&c.occupant, &c.shared_code));
        assert_eq!(b.shared_code[p], code::EMPTY);
        b.move_agent(0, g, p);
        assert_eq!(b.shared_code[g], code::EMPTY);
        b.remove_agent(p, q);
        assert_eq!((b.occupant[p], b.goals_here[q]), (NOBODY, 0));
        assert_eq!(
            (b.shared_code[p], b.shared_code[q]),
            (b.blocked[p], b.blocked[q])
        );
    }
}
