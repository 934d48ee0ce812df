//! An AGV's state: where it is, what the dispatcher told it to do, what it
//! carries, and how it last moved.

use super::{TrackPos, EPS};

/// What the dispatcher told an AGV to do next.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Task {
    /// Nothing to do (goal 0).
    Idle,
    /// Fetch a raw product from source `p`'s buffer (goal 4 or 5).
    FetchRaw(usize),
    /// Bring the raw product to unit `p` (goal 1 or 2).
    DropRaw(usize),
    /// Fetch a finished product from unit `p`'s output buffer (goal 1 or 2).
    FetchFinished(usize),
    /// Bring the finished product to the sink (goal 3).
    Deliver,
}

impl Task {
    /// The observation's goal code: 0 none, 1 unit A, 2 unit B, 3 sink,
    /// 4 buffer 1 (source A), 5 buffer 2 (source B).
    ///
    /// ```
    /// use buridan_plant::Task;
    /// assert_eq!((Task::FetchRaw(1).goal_code(), Task::FetchFinished(0).goal_code()), (5, 1));
    /// ```
    pub fn goal_code(self) -> u8 {
        match self {
            Task::Idle => 0,
            Task::DropRaw(p) | Task::FetchFinished(p) => 1 + p as u8,
            Task::Deliver => 3,
            Task::FetchRaw(p) => 4 + p as u8,
        }
    }
}

/// What an AGV carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Load {
    /// Nothing.
    Empty,
    /// An unprocessed product of type `product`, created at step `created`.
    Raw {
        /// Product index (0 = A, 1 = B).
        product: usize,
        /// Step the source produced it.
        created: u32,
    },
    /// A processed product.
    Finished {
        /// Product index.
        product: usize,
        /// Step the source produced it.
        created: u32,
    },
}

/// One AGV's state.
#[derive(Debug, Clone, PartialEq)]
pub struct Agv {
    /// Where it is.
    pub pos: TrackPos,
    /// Its current task (its goal).
    pub task: Task,
    /// What it carries.
    pub load: Load,
    /// Direction of its front on its segment: +1 towards `to`, −1 towards
    /// `from` (the direction it last drove forward).
    pub facing: f64,
    /// Seconds of loading/unloading left; it cannot move while positive.
    pub handling_left: f64,
    /// Signed speed of the last step in m/s: + forward, − backward.
    pub speed: f64,
    /// Consecutive steps it has waited for another AGV on its route.
    pub waiting_steps: u32,
}

impl Agv {
    /// A fresh AGV at `pos`: idle, empty, facing `to`, standing.
    pub(super) fn at(pos: TrackPos) -> Self {
        Self {
            pos,
            task: Task::Idle,
            load: Load::Empty,
            facing: 1.0,
            handling_left: 0.0,
            speed: 0.0,
            waiting_steps: 0,
        }
    }

    /// It is loading or unloading and cannot move.
    pub(super) fn is_handling(&self) -> bool {
        self.handling_left > EPS
    }
}
