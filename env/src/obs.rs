//! Observations and action masks, written into caller-provided flat buffers.
//!
//! # Local observation (CTDE and DTE), per agent
//!
//! `local_obs_dim(R) = (2R+1)² · 5 + 4` floats:
//!
//! | offset | size | content |
//! |---|---|---|
//! | `0` | `(2R+1)² · 5` | window cells row-major, top-left first, the agent at the centre; cell `k` is one-hot over 5 codes at `5k .. 5k+5` |
//! | `(2R+1)²·5` | 1 | own row / (height − 1) |
//! | `+1` | 1 | own column / (width − 1) |
//! | `+2` | 1 | (goal row − own row) / (height − 1) |
//! | `+3` | 1 | (goal column − own column) / (width − 1) |
//!
//! Cell codes ([`write_local_codes`](crate::GridEnv::write_local_codes)):
//! 0 empty, 1 wall or outside the grid, 2 another agent, 3 own goal, 4 another
//! agent's goal; an agent beats a goal. The centre is the agent itself: 3 if it
//! stands on its goal, else 0 (or 4 on another's goal). For R = 2 the
//! observation has 129 floats. (v1.0.0 gave raw (row, col) of position and
//! goal; the normalised goal delta is the improvement SPEC §3 allows.)
//!
//! Action mask, 5 bytes per agent: 1 = legal. Stay is always legal; a move is
//! legal iff the neighbouring cell's code is 0, 3 or 4.
//!
//! # Central observation (CTE)
//!
//! `central_obs_dim(h, w, n) = (1 + 2n) · h · w` floats: plane 0 the walls,
//! plane `1 + i` agent `i`'s cell, plane `1 + n + i` agent `i`'s goal (each a
//! one-hot `h × w` plane, row-major). The v1.0.0 integer codes — 0 empty,
//! 1 wall, 2+2i agent i, 3+2i goal of agent i, agents over goals — come from
//! [`write_central_codes`](crate::GridEnv::write_central_codes). The joint
//! mask is the `5n` per-agent masks in agent order.
//!
//! With any recipe feature on ([`crate::ObsFeatures`]), every agent's local
//! observation (with those features) follows the planes, in agent order:
//! `n · local_obs_dim` more floats. The joint policy then sees what each
//! CTDE agent sees — its way to its goal above all, which a network finds
//! hard to compute from one-hot planes — and the whole grid besides.

use crate::error::EnvError;
use crate::recipe::Feature;
use crate::world::{GridEnv, NUM_ACTIONS};

/// Number of cell codes in the local window.
pub const NUM_LOCAL_CODES: usize = 5;

/// The local cell codes (module documentation above), by name.
pub mod code {
    /// A free cell.
    pub const EMPTY: u8 = 0;
    /// A wall, or outside the grid (the same value as a blocked cell's flag).
    pub const WALL: u8 = 1;
    /// Another agent.
    pub const AGENT: u8 = 2;
    /// The observer's own goal.
    pub const OWN_GOAL: u8 = 3;
    /// Another agent's goal.
    pub const GOAL: u8 = 4;
}

/// The one-hot row of each code.
const ONE_HOT: [[f32; NUM_LOCAL_CODES]; NUM_LOCAL_CODES] = [
    [1.0, 0.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 0.0, 1.0],
];

/// [`ONE_HOT`] padded to 8 rows, for lookups indexed by `code & 7`.
const ONE_HOT_PADDED: [[f32; NUM_LOCAL_CODES]; 8] = [
    ONE_HOT[0],
    ONE_HOT[1],
    ONE_HOT[2],
    ONE_HOT[3],
    ONE_HOT[4],
    [0.0; NUM_LOCAL_CODES],
    [0.0; NUM_LOCAL_CODES],
    [0.0; NUM_LOCAL_CODES],
];

/// Floats in one local observation for sensor range `r`.
///
/// ```
/// assert_eq!(buridan_env::local_obs_dim(2), 129);
/// ```
pub const fn local_obs_dim(sensor_range: usize) -> usize {
    let side = 2 * sensor_range + 1;
    side * side * NUM_LOCAL_CODES + 4
}

/// Floats in the planes of one central observation (all of it without
/// recipe features; [`ObsKind::obs_dim`] counts the features too).
///
/// ```
/// assert_eq!(buridan_env::central_obs_dim(10, 20, 4), 9 * 200);
/// ```
pub const fn central_obs_dim(height: usize, width: usize, agents: usize) -> usize {
    (1 + 2 * agents) * height * width
}

/// Floats every agent's local observation adds to the central one: none
/// without recipe features, else `agents` local observations with them.
///
/// ```
/// use buridan_env::{obs::central_locals_dim, ObsFeatures};
/// assert_eq!(central_locals_dim(4, 2, &ObsFeatures::default()), 0);
/// let path = ObsFeatures { path: true, ..ObsFeatures::default() };
/// assert_eq!(central_locals_dim(4, 2, &path), 4 * 134);
/// ```
pub const fn central_locals_dim(
    agents: usize,
    sensor_range: usize,
    features: &crate::ObsFeatures,
) -> usize {
    if features.is_none() {
        0
    } else {
        agents * featured_local_dim(sensor_range, features)
    }
}

/// Floats of one local observation with `features` appended.
const fn featured_local_dim(sensor_range: usize, features: &crate::ObsFeatures) -> usize {
    local_obs_dim(sensor_range) + features.extra_dim(sensor_range)
}

/// Which observation a policy consumes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ObsKind {
    /// One local observation and a 5-action mask per agent (CTDE, DTE).
    Local,
    /// One central observation and a `5n` joint mask per env (CTE).
    Central,
}

impl ObsKind {
    /// Floats per observation row on `map` with the env settings `cfg`
    /// (agents, sensor range, extra features).
    ///
    /// ```
    /// use buridan_env::{EnvConfig, Map, ObsFeatures, ObsKind};
    /// let map = Map::load("rm-1.1").unwrap();
    /// let cfg = EnvConfig { agents: 2, ..EnvConfig::default() };
    /// assert_eq!(ObsKind::Local.obs_dim(&map, &cfg), 129);
    /// let path = ObsFeatures { path: true, ..ObsFeatures::default() };
    /// let cfg = EnvConfig { features: path, ..cfg };
    /// assert_eq!(ObsKind::Local.obs_dim(&map, &cfg), 134);
    /// // Central: the planes, then both agents' local observations.
    /// let planes = buridan_env::central_obs_dim(map.grid.height(), map.grid.width(), 2);
    /// assert_eq!(ObsKind::Central.obs_dim(&map, &cfg), planes + 2 * 134);
    /// ```
    pub fn obs_dim(self, map: &crate::Map, cfg: &crate::EnvConfig) -> usize {
        match self {
            ObsKind::Local => featured_local_dim(cfg.sensor_range, &cfg.features),
            ObsKind::Central => {
                central_obs_dim(map.grid.height(), map.grid.width(), cfg.agents)
                    + central_locals_dim(cfg.agents, cfg.sensor_range, &cfg.features)
            }
        }
    }

    /// Policy rows per env of `agents` agents: one per agent (local), one
    /// per env (central).
    ///
    /// ```
    /// use buridan_env::ObsKind;
    /// assert_eq!((ObsKind::Local.rows_per_env(4), ObsKind::Central.rows_per_env(4)), (4, 1));
    /// ```
    pub fn rows_per_env(self, agents: usize) -> usize {
        match self {
            ObsKind::Local => agents,
            ObsKind::Central => 1,
        }
    }
}

impl GridEnv {
    /// Floats of one local observation of this env.
    pub fn local_obs_dim(&self) -> usize {
        featured_local_dim(self.config().sensor_range, &self.config().features)
    }

    /// Floats of one central observation of this env (the recipe
    /// features' local observations included).
    pub fn central_obs_dim(&self) -> usize {
        let cfg = self.config();
        central_obs_dim(
            self.map().grid.height(),
            self.map().grid.width(),
            self.agents(),
        ) + central_locals_dim(self.agents(), cfg.sensor_range, &cfg.features)
    }

    /// Writes agent `i`'s window codes, `(2R+1)²` bytes row-major.
    pub fn write_local_codes(&self, agent: usize, out: &mut [u8]) -> Result<(), EnvError> {
        let r = self.config().sensor_range;
        let side = 2 * r + 1;
        EnvError::check_len("window codes", side * side, out.len())?;
        let raw = self.raw();
        for (out_row, cells) in out.chunks_exact_mut(side).zip(raw.window_rows(agent, r)) {
            out_row.copy_from_slice(&raw.shared_code[cells]);
        }
        for (k, code) in self.window_fixups(agent) {
            out[k] = code;
        }
        Ok(())
    }

    /// Writes agent `i`'s local observation (layout in the module docs).
    pub fn write_local_obs(&self, agent: usize, out: &mut [f32]) -> Result<(), EnvError> {
        EnvError::check_len("observation floats", self.local_obs_dim(), out.len())?;
        let side = 2 * self.config().sensor_range + 1;
        let (window, tail) = out.split_at_mut(side * side * NUM_LOCAL_CODES);
        let (tail, mut features) = tail.split_at_mut(4);
        // One 5-float one-hot row per cell, written whole (no memset, no
        // scatter); the usual window sizes get fully unrolled copies.
        match side {
            1 => self.write_shared_window::<1, 5>(agent, window),
            3 => self.write_shared_window::<3, 15>(agent, window),
            5 => self.write_shared_window::<5, 25>(agent, window),
            7 => self.write_shared_window::<7, 35>(agent, window),
            _ => {
                let raw = self.raw();
                let rows = window
                    .chunks_exact_mut(side * NUM_LOCAL_CODES)
                    .zip(raw.window_rows(agent, side / 2));
                for (out_row, cells) in rows {
                    let codes = &raw.shared_code[cells];
                    for (cell, &code) in out_row.chunks_exact_mut(NUM_LOCAL_CODES).zip(codes) {
                        cell.copy_from_slice(&ONE_HOT[code as usize]);
                    }
                }
            }
        }
        for (k, code) in self.window_fixups(agent) {
            window[k * NUM_LOCAL_CODES..(k + 1) * NUM_LOCAL_CODES]
                .copy_from_slice(&ONE_HOT[code as usize]);
        }
        let grid = &self.map().grid;
        let sy = (grid.height().max(2) - 1) as f32;
        let sx = (grid.width().max(2) - 1) as f32;
        let (p, g) = (self.position(agent), self.goal(agent));
        tail[0] = p.row as f32 / sy;
        tail[1] = p.col as f32 / sx;
        tail[2] = (g.row as f32 - p.row as f32) / sy;
        tail[3] = (g.col as f32 - p.col as f32) / sx;
        let sensor_range = self.config().sensor_range;
        for feature in self.config().features.on() {
            let (slot, rest) = features.split_at_mut(feature.dim(sensor_range));
            match feature {
                Feature::Path => self.write_path_feature(agent, slot),
                Feature::Priority => self.write_priority_feature(agent, slot),
                Feature::Pressure => self.write_pressure_feature(agent, slot),
                Feature::Intent => self.write_intent_feature(agent, slot),
                Feature::Order => self.write_order_feature(agent, slot),
            }
            features = rest;
        }
        Ok(())
    }

    /// The priority feature ([`crate::recipe`]): who outranks whom in the
    /// window, and the own urgency.
    fn write_priority_feature(&self, agent: usize, out: &mut [f32]) {
        let side = 2 * self.config().sensor_range + 1;
        let (window, urgency) = out.split_at_mut(side * side);
        self.write_per_neighbour(agent, window, 1, |other, slot| {
            slot[0] = if self.outranks(other, agent) {
                1.0
            } else {
                -1.0
            };
        });
        let t_max = self.config().t_max.max(1) as f32;
        urgency[0] = (self.steps_off_goal(agent) as f32 / t_max).min(1.0);
    }

    /// The pressure feature ([`crate::recipe`]): which neighbours the
    /// observer stands in the way of.
    fn write_pressure_feature(&self, agent: usize, out: &mut [f32]) {
        let raw = self.raw();
        let here = self.position(agent);
        for (slot, &offset) in out.iter_mut().zip(&raw.step_offsets[1..]) {
            let who = usize::from(raw.occupant[raw.pos[agent].wrapping_add_signed(offset)]);
            *slot = if who == 0 {
                0.0
            } else {
                let other = who - 1;
                let there = self.goal_distance(other);
                let via_me = self.goal_distance_at(other, here);
                f32::from(u8::from(via_me < there))
            };
        }
    }

    /// The intent feature ([`crate::recipe`]): the path feature of every
    /// other agent in the window.
    fn write_intent_feature(&self, agent: usize, out: &mut [f32]) {
        self.write_per_neighbour(agent, out, crate::PATH_FEATURE_DIM, |other, slot| {
            self.write_path_feature(other, slot)
        });
    }

    /// The order feature ([`crate::recipe`]): for every other agent in the
    /// window, whether its goal lies on the observer's way and whether the
    /// observer's goal lies on its way.
    fn write_order_feature(&self, agent: usize, out: &mut [f32]) {
        self.write_per_neighbour(agent, out, 2, |other, slot| {
            slot[0] = f32::from(u8::from(self.goal_on_way(agent, other)));
            slot[1] = f32::from(u8::from(self.goal_on_way(other, agent)));
        });
    }

    /// The window features' common walk: `width` floats per window cell
    /// (row-major, as the window), zeros where the cell holds no other
    /// agent, else what `write(other, slot)` puts there.
    fn write_per_neighbour(
        &self,
        agent: usize,
        out: &mut [f32],
        width: usize,
        mut write: impl FnMut(usize, &mut [f32]),
    ) {
        let raw = self.raw();
        let cells = raw
            .window_rows(agent, self.config().sensor_range)
            .flat_map(|row| raw.occupant[row].iter());
        for (slot, &who) in out.chunks_exact_mut(width).zip(cells) {
            match usize::from(who) {
                0 => slot.fill(0.0),
                k if k - 1 == agent => slot.fill(0.0),
                k => write(k - 1, slot),
            }
        }
    }

    /// True if agent `b`'s goal lies on a shortest path from agent `a` to
    /// `a`'s own goal (and is not that goal): `a` must pass `b`'s goal, so
    /// `a`'s goal is the deeper one.
    fn goal_on_way(&self, a: usize, b: usize) -> bool {
        let (goal_a, goal_b) = (self.goal(a), self.goal(b));
        let way = self.goal_distance(a);
        if goal_a == goal_b || way == crate::map::UNREACHABLE {
            return false;
        }
        let to_b = self.goal_distance_at(b, self.position(a));
        let b_to_goal = self.goal_distance_at(a, goal_b);
        to_b != crate::map::UNREACHABLE
            && b_to_goal != crate::map::UNREACHABLE
            && u32::from(to_b) + u32::from(b_to_goal) == u32::from(way)
    }

    /// The path feature ([`crate::recipe`]): which moves lead one step
    /// closer to the goal, and the cost-to-go.
    fn write_path_feature(&self, agent: usize, out: &mut [f32]) {
        let grid = &self.map().grid;
        let p = self.position(agent);
        let here = self.goal_distance(agent);
        for (slot, (dr, dc)) in out.iter_mut().zip(crate::world::MOVE_DELTAS[1..].iter()) {
            let closer = match (p.row.checked_add_signed(*dr), p.col.checked_add_signed(*dc)) {
                (Some(row), Some(col)) if row < grid.height() && col < grid.width() => {
                    let d = self.goal_distance_at(agent, crate::Cell { row, col });
                    d != crate::map::UNREACHABLE && d < here
                }
                _ => false,
            };
            *slot = f32::from(u8::from(closer));
        }
        out[4] = if here == crate::map::UNREACHABLE {
            1.0
        } else {
            here as f32 / (grid.height() + grid.width()) as f32
        };
    }

    /// Writes agent `i`'s action mask, 5 bytes (1 = legal).
    pub fn write_action_mask(&self, agent: usize, out: &mut [u8]) -> Result<(), EnvError> {
        EnvError::check_len("mask bytes", NUM_ACTIONS, out.len())?;
        let raw = self.raw();
        let p = raw.pos[agent];
        out[0] = 1;
        for (legal, &offset) in out.iter_mut().zip(raw.step_offsets).skip(1) {
            // The neighbour is never the agent itself: legal iff its shared
            // code is 0 (empty) or 4 (a goal, possibly the agent's own).
            let q = p.wrapping_add_signed(offset);
            *legal = u8::from(raw.shared_code[q] & 3 == 0);
        }
        Ok(())
    }

    /// Writes agent `i`'s wall mask, 5 bytes: like
    /// [`GridEnv::write_action_mask`] but only walls and the grid's edge
    /// are illegal — a move into a cell another agent holds stays legal
    /// (what a collision shield ranks: PIBT may push that agent away).
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_env::{Cell, EnvConfig, Grid, GridEnv, Map};
    /// let grid = Grid::from_rows(&["...", "..."]).unwrap();
    /// let map = Arc::new(Map { name: "row".into(), grid, scenario: None });
    /// let cfg = EnvConfig { agents: 2, ..EnvConfig::default() };
    /// let mut env = GridEnv::new(map, cfg).unwrap();
    /// env.reset_with(0, &[Cell::new(0, 0), Cell::new(0, 1)], &[Cell::new(0, 2), Cell::new(0, 0)]).unwrap();
    /// let (mut legal, mut open) = ([0u8; 5], [0u8; 5]);
    /// env.write_action_mask(0, &mut legal).unwrap();
    /// env.write_wall_mask(0, &mut open).unwrap();
    /// // stay, up (the edge), right (agent 1's cell), down, left (the edge)
    /// assert_eq!(legal, [1, 0, 0, 1, 0]);
    /// assert_eq!(open, [1, 0, 1, 1, 0]);
    /// ```
    pub fn write_wall_mask(&self, agent: usize, out: &mut [u8]) -> Result<(), EnvError> {
        EnvError::check_len("mask bytes", NUM_ACTIONS, out.len())?;
        let grid = &self.map().grid;
        let p = self.position(agent);
        out[0] = 1;
        for (open, a) in out.iter_mut().zip(0u8..).skip(1) {
            *open = u8::from(grid.neighbour(p, a).is_some_and(|c| !grid.is_wall(c)));
        }
        Ok(())
    }

    /// Writes the central observation: the one-hot planes, then (with
    /// recipe features) every agent's local observation (layout in the
    /// module docs).
    pub fn write_central_obs(&self, out: &mut [f32]) -> Result<(), EnvError> {
        EnvError::check_len(
            "central observation floats",
            self.central_obs_dim(),
            out.len(),
        )?;
        let grid = &self.map().grid;
        let plane = grid.height() * grid.width();
        let n = self.agents();
        let (planes, locals) = out.split_at_mut((1 + 2 * n) * plane);
        planes.fill(0.0);
        for (o, &wall) in planes[..plane].iter_mut().zip(grid.walls()) {
            *o = f32::from(u8::from(wall));
        }
        for i in 0..n {
            planes[(1 + i) * plane + grid.index(self.position(i))] = 1.0;
            planes[(1 + n + i) * plane + grid.index(self.goal(i))] = 1.0;
        }
        for (i, local) in locals.chunks_exact_mut(self.local_obs_dim()).enumerate() {
            self.write_local_obs(i, local)?;
        }
        Ok(())
    }

    /// Writes the v1.0.0 full-grid codes, `h · w` values row-major.
    pub fn write_central_codes(&self, out: &mut [u16]) -> Result<(), EnvError> {
        let grid = &self.map().grid;
        EnvError::check_len("grid codes", grid.height() * grid.width(), out.len())?;
        for (o, &wall) in out.iter_mut().zip(grid.walls()) {
            *o = u16::from(wall);
        }
        for i in 0..self.agents() {
            out[grid.index(self.goal(i))] = 3 + 2 * i as u16;
        }
        for i in 0..self.agents() {
            out[grid.index(self.position(i))] = 2 + 2 * i as u16;
        }
        Ok(())
    }

    /// Writes the joint mask, `5n` bytes in agent order.
    pub fn write_joint_mask(&self, out: &mut [u8]) -> Result<(), EnvError> {
        EnvError::check_len("joint mask bytes", NUM_ACTIONS * self.agents(), out.len())?;
        for (i, chunk) in out.chunks_exact_mut(NUM_ACTIONS).enumerate() {
            self.write_action_mask(i, chunk)?;
        }
        Ok(())
    }

    /// The one-hot floats of the shared codes of `agent`'s window (before
    /// the fix-ups), for a window side `S` known at compile time; `F` = 5·S
    /// floats per window row. Fully unrolled, no bounds checks per cell.
    #[inline(always)]
    fn write_shared_window<const S: usize, const F: usize>(
        &self,
        agent: usize,
        window: &mut [f32],
    ) {
        debug_assert_eq!(F, S * NUM_LOCAL_CODES);
        let raw = self.raw();
        let r = S / 2;
        let mut start = raw.pos[agent] - r * raw.padded_width - r;
        for out_row in window.chunks_exact_mut(F) {
            let out_row: &mut [f32; F] = out_row.try_into().unwrap();
            let codes: &[u8; S] = raw.shared_code[start..start + S].try_into().unwrap();
            for k in 0..S {
                // Shared codes are 0, 1, 2 or 4; `& 7` lets the table lookup
                // go unchecked (rows 5..8 are never used).
                let one_hot = &ONE_HOT_PADDED[(codes[k] & 7) as usize];
                out_row[k * NUM_LOCAL_CODES..(k + 1) * NUM_LOCAL_CODES].copy_from_slice(one_hot);
            }
            start += raw.padded_width;
        }
    }

    /// Where `agent`'s window differs from the shared codes, as (window
    /// cell index, code): the centre is the agent itself (3 on its own goal,
    /// 4 on another's, else 0, never 2), and the agent's own goal reads 3
    /// instead of 4 unless another agent stands on it.
    #[inline(always)]
    fn window_fixups(&self, agent: usize) -> impl Iterator<Item = (usize, u8)> {
        let raw = self.raw();
        let r = self.config().sensor_range;
        let side = 2 * r + 1;
        let centre = r * side + r;
        let centre_code = if raw.pos[agent] == raw.goal_pos[agent] {
            code::OWN_GOAL
        } else if raw.goals_here[raw.pos[agent]] != 0 {
            code::GOAL
        } else {
            code::EMPTY
        };
        let (p, g) = (raw.cells[agent], raw.goal_cells[agent]);
        let dr = g.row as isize - p.row as isize;
        let dc = g.col as isize - p.col as isize;
        let r = r as isize;
        let own_goal = (dr.abs() <= r
            && dc.abs() <= r
            && (dr, dc) != (0, 0)
            && raw.shared_code[raw.goal_pos[agent]] == code::GOAL)
            .then(|| (((dr + r) * side as isize + dc + r) as usize, code::OWN_GOAL));
        std::iter::once((centre, centre_code)).chain(own_goal)
    }
}
