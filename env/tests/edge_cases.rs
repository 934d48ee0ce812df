//! Corner cases that once hung or panicked.

mod common;

use std::sync::mpsc;
use std::sync::Arc;
use std::time::Duration;

use buridan_env::map::UNREACHABLE;
use buridan_env::{Cell, EnvConfig, EnvError, Grid, GridEnv, Map, Scenario, Starts};

/// Runs `f` on a thread and fails if it does not return within 10 s.
fn within_10s<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    rx.recv_timeout(Duration::from_secs(10))
        .expect("did not finish within 10 s (hang)")
}

#[test]
fn lifelong_needs_a_free_cell_beyond_the_agents_goals() {
    // One free cell, one agent standing on its goal: after arrival no other
    // cell could become its new goal. This must be a typed error, not a hang.
    let result = within_10s(|| {
        let map = common::map_from_rows(&["@.@"], &[(0, 1)], &[(0, 1)]);
        let cfg = EnvConfig {
            lifelong: true,
            ..common::fixed_cfg(1, 10)
        };
        GridEnv::new(map, cfg).map(|mut env| env.step(&[0], &mut [0.0]))
    });
    assert_eq!(
        result.err(),
        Some(EnvError::TooFewFreeCells {
            map: "hand-made".into(),
            free: 1,
            agents: 1,
            needed: 2
        })
    );
    // Two agents on a two-cell grid, both home at the start.
    let result = within_10s(|| {
        let map = common::map_from_rows(&[".."], &[(0, 0), (0, 1)], &[(0, 0), (0, 1)]);
        let cfg = EnvConfig {
            lifelong: true,
            ..common::fixed_cfg(2, 10)
        };
        let mut env = GridEnv::new(map.clone(), common::fixed_cfg(2, 10)).unwrap();
        // Not lifelong: fine, terminates at once.
        assert!(env.step(&[0, 0], &mut [0.0; 2]).unwrap().terminated);
        GridEnv::new(map, cfg).err()
    });
    assert!(
        matches!(result, Some(EnvError::TooFewFreeCells { needed: 3, .. })),
        "{result:?}"
    );
    // With one spare cell it works: goals hop between the free cells.
    let stats = within_10s(|| {
        let map = common::map_from_rows(&["..."], &[(0, 0), (0, 1)], &[(0, 0), (0, 1)]);
        let cfg = EnvConfig {
            lifelong: true,
            ..common::fixed_cfg(2, 10)
        };
        let mut env = GridEnv::new(map, cfg).unwrap();
        env.step(&[0, 0], &mut [0.0; 2]).unwrap();
        env.stats()
    });
    assert_eq!(stats.goals_reached, 2);
}

#[test]
fn goal_distances_longer_than_u16_saturate_instead_of_overflowing() {
    let within = within_10s(|| {
        let width = 70_000;
        let grid = Grid::from_walls(1, width, vec![false; width]);
        let d = grid.distances_to(Cell::new(0, 0));
        assert_eq!(d[1], 1);
        assert_eq!(d[65_534], 65_534);
        assert!(
            d[width - 1] < UNREACHABLE,
            "reachable cells never read as unreachable"
        );
        assert!(d.iter().all(|&x| x != UNREACHABLE));
        let map = Arc::new(Map {
            name: "long".into(),
            grid,
            scenario: Some(Scenario {
                starts: vec![Cell::new(0, width - 1)],
                goals: vec![Cell::new(0, 0)],
            }),
        });
        let cfg = EnvConfig {
            agents: 1,
            starts: Starts::Fixed,
            ..EnvConfig::default()
        };
        let mut env = GridEnv::new(map, cfg).unwrap();
        env.step(&[4], &mut [0.0]).unwrap();
        env.goal_distance(0)
    });
    assert!(within < UNREACHABLE);
}
