//! [`ConflictModel`]: which joint moves count as conflicts.
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
//! and the plan falls apart. [`ConflictModel::forbid_following`] (default **on**)
//! adds a third conflict, the **following conflict** "agent `i` enters at
//! `t + 1` the cell that agent `j > i` occupies at `t`". With it every
//! conflict-free plan replays exactly in the environment: by induction over
//! the agents in index order, each target is inside the grid, not a wall,
//! not taken by a lower agent (no vertex conflict) and not still held by a
//! higher agent (no following conflict). It also rules out rotations of
//! three or more agents along a cycle, which the environment cannot
//! execute either. Swaps are already impossible then, but stay listed.
//!
//! # The env's rule sets
//!
//! The env has two rule sets ([`buridan_env::Rules`]), and each maps onto one
//! conflict model (`ConflictModel::from`): **thesis** (sequential moves in index
//! order) onto [`ConflictModel::ENV_EXECUTABLE`], **pogema** (POGEMA's simultaneous
//! moves with soft-collision repair) onto [`ConflictModel::SIMULTANEOUS`]. A plan
//! without vertex and swap conflicts makes POGEMA repair nothing: no move
//! enters a wall, none swaps, no two enter one cell and none enters the cell
//! of an agent that stays, so every valid plan under `SIMULTANEOUS` (following
//! and rotations included) replays exactly under pogema rules. Plans valid
//! under `ENV_EXECUTABLE` are valid under both.

/// The conflict model a planner or the validator uses.
///
/// ```
/// use buridan_mapf::ConflictModel;
/// assert!(ConflictModel::default().forbid_following);
/// assert_eq!(ConflictModel::default(), ConflictModel::ENV_EXECUTABLE);
/// assert!(!ConflictModel::SIMULTANEOUS.forbid_following);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub struct ConflictModel {
    /// Treat "agent `i` enters at `t + 1` the cell agent `j > i` occupies at
    /// `t`" as a conflict, so plans replay exactly in the index-ordered env.
    pub forbid_following: bool,
}

impl ConflictModel {
    /// Pure SPEC §5: vertex and swap conflicts only. Plans may contain
    /// following moves that the environment blocks.
    pub const SIMULTANEOUS: ConflictModel = ConflictModel {
        forbid_following: false,
    };
    /// Vertex, swap and following conflicts: plans replay exactly in the
    /// environment (the default).
    pub const ENV_EXECUTABLE: ConflictModel = ConflictModel {
        forbid_following: true,
    };
}

impl Default for ConflictModel {
    fn default() -> Self {
        Self::ENV_EXECUTABLE
    }
}

impl ConflictModel {
    /// The env rule set that executes exactly the plans valid under this
    /// conflict model (the inverse of `ConflictModel::from`).
    ///
    /// ```
    /// use buridan_mapf::ConflictModel;
    /// assert_eq!(ConflictModel::ENV_EXECUTABLE.rule_set(), buridan_env::Rules::Thesis);
    /// assert_eq!(ConflictModel::SIMULTANEOUS.rule_set(), buridan_env::Rules::Pogema);
    /// ```
    pub fn rule_set(self) -> buridan_env::Rules {
        if self.forbid_following {
            buridan_env::Rules::Thesis
        } else {
            buridan_env::Rules::Pogema
        }
    }
}

/// The conflict model whose valid plans the env's rule set executes exactly
/// (see the [module docs](self)).
///
/// ```
/// use buridan_mapf::ConflictModel;
/// assert_eq!(ConflictModel::from(buridan_env::Rules::Thesis), ConflictModel::ENV_EXECUTABLE);
/// assert_eq!(ConflictModel::from(buridan_env::Rules::Pogema), ConflictModel::SIMULTANEOUS);
/// ```
impl From<buridan_env::Rules> for ConflictModel {
    fn from(rules: buridan_env::Rules) -> Self {
        match rules {
            buridan_env::Rules::Thesis => Self::ENV_EXECUTABLE,
            buridan_env::Rules::Pogema => Self::SIMULTANEOUS,
        }
    }
}
