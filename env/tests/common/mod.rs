//! Helpers shared by the integration tests: tiny hand-made maps and envs.
#![allow(dead_code)]

pub mod author;
pub mod reference_monitor;

use std::sync::Arc;

use buridan_env::{Cell, EnvConfig, GridEnv, Map, Scenario, Starts, StepOutcome};

/// Shorthand for `Cell::new(row, col)`.
pub fn c(row: usize, col: usize) -> Cell {
    Cell::new(row, col)
}

/// Cells from `(row, col)` pairs.
pub fn cells(list: &[(usize, usize)]) -> Vec<Cell> {
    list.iter().map(|&(r, col)| Cell::new(r, col)).collect()
}

/// A map from terrain rows with a fixed scenario.
pub fn map_from_rows(
    rows: &[&str],
    starts: &[(usize, usize)],
    goals: &[(usize, usize)],
) -> Arc<Map> {
    Arc::new(Map {
        name: "hand-made".into(),
        grid: buridan_env::Grid::from_rows(rows).expect("test grid parses"),
        scenario: Some(Scenario {
            starts: cells(starts),
            goals: cells(goals),
        }),
    })
}

/// A config for `agents` agents with fixed starts and the given `t_max`.
pub fn fixed_cfg(agents: usize, t_max: u32) -> EnvConfig {
    EnvConfig {
        agents,
        t_max,
        starts: Starts::Fixed,
        ..EnvConfig::default()
    }
}

/// An env on terrain rows with fixed starts and goals.
pub fn env_on(
    rows: &[&str],
    starts: &[(usize, usize)],
    goals: &[(usize, usize)],
    t_max: u32,
) -> GridEnv {
    let map = map_from_rows(rows, starts, goals);
    GridEnv::new(map, fixed_cfg(starts.len(), t_max)).expect("test env builds")
}

/// Steps and returns the rewards and the outcome.
pub fn step(env: &mut GridEnv, actions: &[u8]) -> (Vec<f32>, StepOutcome) {
    let mut rewards = vec![f32::NAN; env.agents()];
    let out = env.step(actions, &mut rewards).expect("valid step");
    (rewards, out)
}

/// Positions as `(row, col)` pairs.
pub fn pos(env: &GridEnv) -> Vec<(usize, usize)> {
    env.positions().iter().map(|p| (p.row, p.col)).collect()
}
