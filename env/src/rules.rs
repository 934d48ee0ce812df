//! The rule sets: how one joint action becomes the agents' next cells.
//!
//! - [`Rules::Thesis`] (the default): agents move **one after another in
//!   index order**; a move succeeds iff its target is inside the grid, not a
//!   wall and free at that moment (SPEC §2). Applied in place by
//!   [`crate::GridEnv::step`], the env's hot path.
//! - [`Rules::Pogema`]: POGEMA 1.4.0 with `collision_system: soft` and
//!   `on_target: nothing`, the rules of the field's published benchmark
//!   results. All agents move **at once** and invalid moves are repaired
//!   into waits by [`resolve_simultaneous`].
//!
//! Everything else — agents staying on the map on their goals (and free to
//! leave), success when all stand on their goals at once after some step
//! `≤ T_max`, rewards and observations — is shared. The per-agent cost
//! ([`crate::GridEnv::cost`]) follows POGEMA's definition under both.

use std::fmt;
use std::str::FromStr;

/// `T_max` of the thesis rules when a configuration does not set it.
pub const THESIS_T_MAX: u32 = 100;
/// `T_max` of the POGEMA rules when a configuration does not set it (the
/// benchmark's `max_episode_steps`).
pub const POGEMA_T_MAX: u32 = 128;

/// Which rule set moves the agents; chosen in [`crate::EnvConfig::rules`],
/// written `"thesis"` or `"pogema"` in files and on command lines.
///
/// ```
/// use buridan_env::Rules;
/// assert_eq!("pogema".parse::<Rules>().unwrap(), Rules::Pogema);
/// assert_eq!(Rules::default().to_string(), "thesis");
/// assert_eq!(Rules::Pogema.default_t_max(), 128);
/// ```
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, Default, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum Rules {
    /// The dissertation's rules: sequential moves in index order.
    #[default]
    Thesis,
    /// POGEMA 1.4.0, soft collisions: simultaneous moves, repaired into waits.
    Pogema,
}

impl Rules {
    /// Every rule set, in a stable order.
    pub const ALL: [Rules; 2] = [Rules::Thesis, Rules::Pogema];

    /// The name used in files and on command lines.
    pub fn name(self) -> &'static str {
        match self {
            Rules::Thesis => "thesis",
            Rules::Pogema => "pogema",
        }
    }

    /// `T_max` when a configuration file leaves it out: 100 (the
    /// dissertation's) for thesis, 128 (the benchmark's) for pogema.
    pub fn default_t_max(self) -> u32 {
        match self {
            Rules::Thesis => THESIS_T_MAX,
            Rules::Pogema => POGEMA_T_MAX,
        }
    }
}

impl fmt::Display for Rules {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A rule-set name that is neither `thesis` nor `pogema`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown rules '{0}': expected 'thesis' or 'pogema'")]
pub struct UnknownRules(pub String);

impl FromStr for Rules {
    type Err = UnknownRules;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Rules::ALL
            .into_iter()
            .find(|r| r.name() == s)
            .ok_or_else(|| UnknownRules(s.to_string()))
    }
}

/// Sentinel for "no agent" in [`SimultaneousScratch::claim`].
const NOBODY: u16 = 0;

/// Reusable buffers of [`resolve_simultaneous`], so that a step allocates
/// nothing.
#[derive(Debug, Clone, Default)]
pub struct SimultaneousScratch {
    /// Per cell: index + 1 of the one mover allowed to enter it, or 0. All
    /// zero between calls (only claimed cells are reset).
    claim: Vec<u16>,
    /// The cells with a claim this step.
    claimed: Vec<usize>,
    /// Agents that turned into waits and whose followers are not yet checked.
    stack: Vec<u16>,
}

impl SimultaneousScratch {
    /// Buffers for a grid of `cells` cells (indices `0..cells`).
    pub fn new(cells: usize) -> Self {
        Self {
            claim: vec![NOBODY; cells],
            claimed: Vec::new(),
            stack: Vec::new(),
        }
    }
}

/// POGEMA's soft-collision repair: writes each agent's cell after the step
/// into `target` and returns how many requested moves became waits.
///
/// Cells are indices into `blocked` and `occupant` (any layout whose
/// neighbours differ by `offsets[action]` and whose outside is blocked, like
/// the env's padded grid); `pos[i]` is agent `i`'s cell, `occupant[c]` its
/// index + 1 (0 = empty) and `actions[i]` ∈ `0..5` in the env's order (0
/// stay, 1 up, 2 right, 3 down, 4 left). The repairs, in POGEMA's order:
///
/// 1. a move into a wall or off the grid is a wait;
/// 2. two agents swapping along one edge both wait;
/// 3. of several agents entering one cell, the lowest index goes on, the
///    others wait;
/// 4. a move into a cell whose occupant waits is a wait, repeated until no
///    such move is left (so waits cascade back along chains).
///
/// Whatever survives moves: following into a cell vacated in the same step
/// and rotations of three or more agents are allowed. POGEMA 1.4.0 computes
/// the same result with per-cell lists, a reversed sweep and recursive
/// reverts (`Pogema.move_agents`); the traces in `tests/data/pogema/` check
/// the two agree step for step.
///
/// # Panics
/// If a slice is shorter than `pos` (agents) or `blocked` (cells) says, or
/// an action is outside `0..5`: the env validates both before calling.
pub fn resolve_simultaneous(
    pos: &[usize],
    actions: &[u8],
    offsets: &[isize; 5],
    blocked: &[u8],
    occupant: &[u16],
    target: &mut [usize],
    scratch: &mut SimultaneousScratch,
) -> u32 {
    let n = pos.len();
    let mut blocked_moves = 0;
    // 1. Walls and the outside.
    for i in 0..n {
        let from = pos[i];
        let action = actions[i];
        target[i] = from;
        if action == 0 {
            continue;
        }
        let to = from.wrapping_add_signed(offsets[action as usize]);
        if blocked[to] == 0 {
            target[i] = to;
        } else {
            blocked_moves += 1;
        }
    }
    // 2. Swaps: the occupant of my target moves into my cell.
    for i in 0..n {
        let to = target[i];
        if to == pos[i] {
            continue;
        }
        let j = occupant[to];
        if j != NOBODY && target[j as usize - 1] == pos[i] {
            target[i] = pos[i];
            target[j as usize - 1] = to;
            blocked_moves += 2;
        }
    }
    // 3. Contested cells: the first (lowest-index) claim wins.
    for i in 0..n {
        let to = target[i];
        if to == pos[i] {
            continue;
        }
        if scratch.claim[to] == NOBODY {
            scratch.claim[to] = i as u16 + 1;
            scratch.claimed.push(to);
        } else {
            target[i] = pos[i];
            blocked_moves += 1;
        }
    }
    // 4. Cascade: whoever claimed the cell of a waiting agent waits too.
    // Every wait is pushed once, so this is linear in the agents.
    scratch
        .stack
        .extend((0..n).filter(|&i| target[i] == pos[i]).map(|i| i as u16));
    while let Some(w) = scratch.stack.pop() {
        let c = scratch.claim[pos[w as usize]];
        if c == NOBODY {
            continue;
        }
        let m = c as usize - 1;
        if m != w as usize && target[m] != pos[m] {
            target[m] = pos[m];
            blocked_moves += 1;
            scratch.stack.push(m as u16);
        }
    }
    for &cell in &scratch.claimed {
        scratch.claim[cell] = NOBODY;
    }
    scratch.claimed.clear();
    blocked_moves
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A corridor of `len` free cells framed by walls, as a 3-row grid
    /// `len + 2` wide: corridor cell k is at index `len + 3 + k`.
    fn corridor(len: usize) -> (Vec<u8>, [isize; 5]) {
        let w = len + 2;
        let mut blocked = vec![1; 3 * w];
        blocked[w + 1..2 * w - 1].fill(0);
        (blocked, [0, -(w as isize), 1, w as isize, -1])
    }

    /// Resolves agents at corridor cells `cells`; returns their cells after.
    fn run(len: usize, cells: &[usize], actions: &[u8]) -> (Vec<usize>, u32) {
        let (blocked, offsets) = corridor(len);
        let pos: Vec<usize> = cells.iter().map(|&k| len + 3 + k).collect();
        let mut occupant = vec![0; blocked.len()];
        for (i, &p) in pos.iter().enumerate() {
            occupant[p] = i as u16 + 1;
        }
        let mut target = vec![0; pos.len()];
        let mut scratch = SimultaneousScratch::new(blocked.len());
        let b = resolve_simultaneous(
            &pos,
            actions,
            &offsets,
            &blocked,
            &occupant,
            &mut target,
            &mut scratch,
        );
        assert!(scratch.claim.iter().all(|&c| c == NOBODY), "claims reset");
        (target.iter().map(|&p| p - len - 3).collect(), b)
    }

    #[test]
    fn a_chain_behind_a_wall_waits_entirely() {
        // Agents 0, 1, 2 fill the corridor and push left, into the frame.
        let (target, blocked) = run(3, &[0, 1, 2], &[4, 4, 4]);
        assert_eq!(target, vec![0, 1, 2]);
        assert_eq!(blocked, 3);
    }

    #[test]
    fn a_chain_follows_its_head_into_free_space() {
        let (target, blocked) = run(4, &[1, 2, 3], &[4, 4, 4]);
        assert_eq!(target, vec![0, 1, 2]);
        assert_eq!(blocked, 0);
    }

    #[test]
    fn up_and_down_leave_the_corridor_into_walls() {
        let (target, blocked) = run(2, &[0, 1], &[1, 3]);
        assert_eq!((target, blocked), (vec![0, 1], 2));
    }

    #[test]
    fn the_names_round_trip() {
        for rules in Rules::ALL {
            assert_eq!(rules.name().parse::<Rules>(), Ok(rules));
        }
        assert_eq!(
            "POGEMA".parse::<Rules>(),
            Err(UnknownRules("POGEMA".into()))
        );
    }
}
