//! One-lane corridors of a layout and the rule that keeps robots from
//! meeting head-on in them.
//!
//! Two robots that enter a one-lane corridor from opposite ends meet inside
//! it, and one of them must back out the whole way it came: on rm-2.1's
//! block layout (the long rows between the blocks are one lane) this is
//! where a policy through the shield loses most of its steps against a
//! planner, which sends one of the two around the block or lets it wait at
//! the corridor's end. PIBT, seeing one step ahead, only notices once they
//! stand face to face.
//!
//! A *lane* is a maximal chain of *lane cells*: free cells with at most two
//! free neighbours that are not part of a 2 × 2 block of free cells (a room's
//! corner has two neighbours but a way around it). Each lane has two ends;
//! beyond an end lies the cell a robot enters the lane from, or nothing where
//! the lane is a dead end. A ring of lane cells without any other cell has no
//! ends and is no lane here.
//!
//! ```
//! use buridan_env::{Cell, Grid};
//! use buridan_mapf::lanes::Lanes;
//! // Two open columns joined by a one-lane row of four cells.
//! let grid = Grid::from_rows(&[".@@@@.", "......", ".@@@@."]).unwrap();
//! let lanes = Lanes::new(&grid);
//! assert_eq!(lanes.lane_of(Cell::new(1, 2)), lanes.lane_of(Cell::new(1, 4)));
//! assert!(lanes.lane_of(Cell::new(1, 2)).is_some());
//! assert_eq!(lanes.lane_of(Cell::new(1, 0)), None); // a junction
//! let lane = lanes.lane_of(Cell::new(1, 3)).unwrap();
//! assert_eq!(lanes.len(lane), 4);
//! let ends = lanes.entrances(lane); // in no particular order
//! assert!(ends.contains(&Some(Cell::new(1, 0))) && ends.contains(&Some(Cell::new(1, 5))));
//! ```

use buridan_env::{Cell, Grid};

use crate::graph::{Topology, NONE};

/// The one-lane corridors of a grid (see the [module docs](self)).
pub struct Lanes {
    topo: Topology,
    /// Per cell index: its lane ([`NONE`] off the lanes).
    lane: Vec<u32>,
    /// Per cell index: its place along its lane, 0 at the lane's first end.
    place: Vec<u32>,
    /// Per lane: the cells a robot enters it from at its first and its
    /// second end ([`NONE`] where the lane is closed).
    entrances: Vec<[u32; 2]>,
    /// Per lane: its number of cells.
    len: Vec<u32>,
}

impl Lanes {
    /// Finds `grid`'s lanes (see the [module docs](self)).
    pub fn new(grid: &Grid) -> Self {
        let topo = Topology::new(grid);
        let n = topo.cells();
        let open = |r: i64, c: i64| {
            r >= 0
                && c >= 0
                && (r as usize) < grid.height()
                && (c as usize) < grid.width()
                && !grid.is_wall(Cell::new(r as usize, c as usize))
        };
        let in_open_square = |v: u32| {
            let cell = topo.cell(v);
            let (r, c) = (cell.row as i64, cell.col as i64);
            [(-1, -1), (-1, 0), (0, -1), (0, 0)]
                .iter()
                .any(|&(dr, dc)| (0..2).all(|i| (0..2).all(|j| open(r + dr + i, c + dc + j))))
        };
        let is_lane_cell: Vec<bool> = (0..n as u32)
            .map(|v| topo.is_free(v) && topo.neighbours(v).count() <= 2 && !in_open_square(v))
            .collect();
        // Each lane cell once: a lane's or a ring's.
        let mut seen = vec![false; n];
        let mut lane = vec![NONE; n];
        let mut place = vec![0; n];
        let mut entrances = Vec::new();
        let mut len = Vec::new();
        for start in 0..n as u32 {
            if !is_lane_cell[start as usize] || seen[start as usize] {
                continue;
            }
            // Walk to one end, then collect the chain from that end to the
            // other; a walk that comes back to `start` is a ring.
            let step = |from: u32, at: u32| {
                topo.neighbours(at)
                    .find(|&u| u != from && is_lane_cell[u as usize])
            };
            let (mut prev, mut at, mut ring) = (NONE, start, false);
            while let Some(next) = step(prev, at) {
                if next == start {
                    ring = true;
                    break;
                }
                (prev, at) = (at, next);
            }
            if ring {
                // Mark the ring's cells so the scan skips them; no lane.
                let (mut prev, mut at) = (NONE, start);
                loop {
                    seen[at as usize] = true;
                    match step(prev, at) {
                        Some(next) if next != start => (prev, at) = (at, next),
                        _ => break,
                    }
                }
                continue;
            }
            let id = len.len() as u32;
            let first = at;
            let mut chain = vec![first];
            let (mut prev, mut at) = (NONE, first);
            while let Some(next) = step(prev, at) {
                chain.push(next);
                (prev, at) = (at, next);
            }
            // The entrances: the cells off the lane beside its two ends (a
            // one-cell lane has both beside its only cell).
            let exits = |v: u32| topo.neighbours(v).filter(|&u| !is_lane_cell[u as usize]);
            let last = *chain.last().expect("a chain holds its first cell");
            let head = exits(first).next().unwrap_or(NONE);
            let tail = exits(last)
                .nth(usize::from(chain.len() == 1))
                .unwrap_or(NONE);
            for (k, &v) in chain.iter().enumerate() {
                seen[v as usize] = true;
                lane[v as usize] = id;
                place[v as usize] = k as u32;
            }
            entrances.push([head, tail]);
            len.push(chain.len() as u32);
        }
        Self {
            topo,
            lane,
            place,
            entrances,
            len,
        }
    }

    /// The lane `cell` lies in, if any.
    pub fn lane_of(&self, cell: Cell) -> Option<u32> {
        self.lane_index(self.topo.index(cell))
    }

    /// The number of cells of `lane`.
    pub fn len(&self, lane: u32) -> u32 {
        self.len[lane as usize]
    }

    /// The cells a robot enters `lane` from, one per end, in no
    /// particular order (`None` where the lane is closed).
    pub fn entrances(&self, lane: u32) -> [Option<Cell>; 2] {
        self.entrances[lane as usize].map(|v| (v != NONE).then(|| self.topo.cell(v)))
    }

    pub(crate) fn lane_index(&self, v: u32) -> Option<u32> {
        let l = self.lane[v as usize];
        (l != NONE).then_some(l)
    }

    pub(crate) fn place(&self, v: u32) -> u32 {
        self.place[v as usize]
    }

    pub(crate) fn entrance_indices(&self, lane: u32) -> [u32; 2] {
        self.entrances[lane as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lanes(rows: &[&str]) -> Lanes {
        Lanes::new(&Grid::from_rows(rows).unwrap())
    }

    #[test]
    fn an_open_room_has_no_lanes() {
        let room = lanes(&["....", "....", "...."]);
        for r in 0..3 {
            for c in 0..4 {
                assert_eq!(room.lane_of(Cell::new(r, c)), None, "({r}, {c})");
            }
        }
    }

    #[test]
    fn a_dead_end_aisle_is_a_lane_closed_at_its_far_end() {
        // A 2 x 2 square on the left, an aisle of four cells to the right.
        let aisle = lanes(&["..@@@@", "......"]);
        let lane = aisle.lane_of(Cell::new(1, 5)).unwrap();
        assert_eq!(aisle.len(lane), 4);
        let ends = aisle.entrances(lane);
        assert!(ends.contains(&Some(Cell::new(1, 1))), "{ends:?}");
        assert!(ends.contains(&None), "{ends:?}");
        assert_eq!(aisle.lane_of(Cell::new(1, 1)), None);
    }

    #[test]
    fn a_bend_stays_one_lane_and_a_ring_is_none() {
        // An L-shaped lane between two rooms' doors.
        let bend = lanes(&["..@@@", "...@@", "@@.@@", "@@...", "@@@.."]);
        let a = bend.lane_of(Cell::new(2, 2)).unwrap();
        assert_eq!(bend.lane_of(Cell::new(3, 2)), Some(a));
        // A ring of lane cells alone: no entrance, no lane.
        let ring = lanes(&["...", ".@.", "..."]);
        assert_eq!(ring.lane_of(Cell::new(0, 1)), None);
        // A door between two rooms: a lane of one cell, entered from
        // either side.
        let door = lanes(&["..@..", ".....", "..@.."]);
        let d = door.lane_of(Cell::new(1, 2)).unwrap();
        assert_eq!(door.len(d), 1);
        let ends = door.entrances(d);
        assert!(ends.contains(&Some(Cell::new(1, 1))), "{ends:?}");
        assert!(ends.contains(&Some(Cell::new(1, 3))), "{ends:?}");
    }
}
