//! [`Rules`]: which joint moves count as conflicts.
//!
//! Plans are timed paths executed *simultaneously*: between `t` and `t + 1`
//! every agent moves at once. SPEC §5 forbids two kinds of conflict:
//!
//! - **vertex**: two agents in one cell at one time (agents resting on their
//!   goals after their paths ended included);
//! - **swap** (edge): two agents exchanging their cells in one step.
//!
//! The environment (SPEC §2) instead moves agents **sequentially in index
//! order**, a move succeeding only if its target is free at that moment. A
//! **following move** is agent `i` entering, at `t + 1`, the cell agent `j`
//! occupies at `t` (and leaves during that step). Simultaneously this is
//! fine; in the environment it succeeds only if `j < i` (`j` has already
//! moved out). If `j > i`, `i` finds the cell still occupied and stays put,
//! and the plan falls apart. [`Rules::forbid_following`] (default **on**)
//! adds a third conflict, the **following conflict** "agent `i` enters at
//! `t + 1` the cell that agent `j > i` occupies at `t`". With it every
//! conflict-free plan replays exactly in the environment: by induction over
//! the agents in index order, each target is inside the grid, not a wall,
//! not taken by a lower agent (no vertex conflict) and not still held by a
//! higher agent (no following conflict). It also rules out rotations of
//! three or more agents along a cycle, which the environment cannot
//! execute either. Swaps are already impossible then, but stay listed.

/// The conflict model a planner or the validator uses.
///
/// ```
/// use buridan_mapf::Rules;
/// assert!(Rules::default().forbid_following);
/// assert_eq!(Rules::default(), Rules::ENV_EXECUTABLE);
/// assert!(!Rules::SIMULTANEOUS.forbid_following);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub struct Rules {
    /// Treat "agent `i` enters at `t + 1` the cell agent `j > i` occupies at
    /// `t`" as a conflict, so plans replay exactly in the index-ordered env.
    pub forbid_following: bool,
}

impl Rules {
    /// Pure SPEC §5: vertex and swap conflicts only. Plans may contain
    /// following moves that the environment blocks.
    pub const SIMULTANEOUS: Rules = Rules {
        forbid_following: false,
    };
    /// Vertex, swap and following conflicts: plans replay exactly in the
    /// environment (the default).
    pub const ENV_EXECUTABLE: Rules = Rules {
        forbid_following: true,
    };
}

impl Default for Rules {
    fn default() -> Self {
        Self::ENV_EXECUTABLE
    }
}
