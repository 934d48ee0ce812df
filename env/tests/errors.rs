//! Typed errors, never panics: malformed maps and scenarios, bad
//! configurations, bad actions and buffers.

mod common;

use std::path::PathBuf;
use std::sync::Arc;

use buridan_env::map::{parse_map, parse_scen};
use buridan_env::{EnvConfig, EnvError, Grid, GridEnv, Map, MapError, ObsKind, Starts, VecEnv};
use common::{c, env_on, map_from_rows};

/// The line of a parse error (and checks the file name).
fn parse_line(err: MapError, file: &str) -> usize {
    match err {
        MapError::Parse { file: f, line, .. } => {
            assert_eq!(f, file);
            line
        }
        other => panic!("expected a parse error, got {other:?}"),
    }
}

fn map_err_line(text: &str) -> (usize, String) {
    let err = parse_map("t.map", text).unwrap_err();
    let msg = err.to_string();
    (parse_line(err, "t.map"), msg)
}

// ---------------------------------------------------------------- .map

#[test]
fn missing_header_is_reported_on_line_1() {
    let (line, msg) = map_err_line("....\n....\n");
    assert_eq!(line, 1);
    assert!(msg.contains("unexpected header line"), "{msg}");
}

#[test]
fn missing_map_line_is_reported_after_the_last_line() {
    let (line, msg) = map_err_line("type octile\nheight 2\nwidth 2\n");
    assert_eq!(line, 4);
    assert!(msg.contains("missing 'map' line"), "{msg}");
    let (line, _) = map_err_line("");
    assert_eq!(line, 1);
}

#[test]
fn missing_height_or_width_is_reported_on_the_map_line() {
    let (line, msg) = map_err_line("type octile\nwidth 2\nmap\n..\n");
    assert_eq!(line, 3);
    assert!(msg.contains("no 'height'"), "{msg}");
    let (line, msg) = map_err_line("type octile\nheight 1\n\nmap\n..\n");
    assert_eq!(line, 4);
    assert!(msg.contains("no 'width'"), "{msg}");
}

#[test]
fn bad_height_or_width_is_reported_on_its_line() {
    for bad in ["height x", "height 0", "height -3", "height", "height 2.5"] {
        let text = format!("type octile\n{bad}\nwidth 2\nmap\n..\n..\n");
        let (line, msg) = map_err_line(&text);
        assert_eq!(line, 2, "{bad}");
        assert!(msg.contains("'height' needs a positive integer"), "{msg}");
    }
    let (line, msg) = map_err_line("type octile\nheight 2\nwidth zero\nmap\n..\n..\n");
    assert_eq!(line, 3);
    assert!(msg.contains("'width'"), "{msg}");
}

#[test]
fn huge_dimensions_are_refused_without_allocating() {
    let (line, msg) = map_err_line("type octile\nheight 100000\nwidth 100000\nmap\n");
    assert_eq!(line, 4);
    assert!(msg.contains("too large"), "{msg}");
}

#[test]
fn short_or_long_row_is_reported_on_its_line() {
    let (line, msg) = map_err_line("type octile\nheight 3\nwidth 3\nmap\n...\n..\n...\n");
    assert_eq!(line, 6);
    assert!(msg.contains("grid row has 2 cells, width is 3"), "{msg}");
    let (line, _) = map_err_line("type octile\nheight 2\nwidth 3\nmap\n....\n...\n");
    assert_eq!(line, 5);
}

#[test]
fn missing_rows_are_reported_after_the_last_row() {
    let (line, msg) = map_err_line("type octile\nheight 3\nwidth 2\nmap\n..\n..\n");
    assert_eq!(line, 7);
    assert!(msg.contains("expected 3 grid rows, found 2"), "{msg}");
}

#[test]
fn unknown_character_is_reported_with_line_and_column() {
    let (line, msg) = map_err_line("type octile\nheight 2\nwidth 3\nmap\n...\n.x.\n");
    assert_eq!(line, 6);
    assert!(
        msg.ends_with("unknown terrain character 'x' in column 2"),
        "{msg}"
    );
    assert_eq!(msg, "t.map:6: unknown terrain character 'x' in column 2");
}

#[test]
fn extra_content_is_reported_on_its_line() {
    let (line, msg) = map_err_line("type octile\nheight 1\nwidth 2\nmap\n..\n\n..\n");
    assert_eq!(line, 7);
    assert!(msg.contains("extra content"), "{msg}");
    // Trailing blank lines are fine.
    assert!(parse_map("t.map", "type octile\nheight 1\nwidth 2\nmap\n..\n\n\n").is_ok());
}

#[test]
fn all_movingai_terrain_and_crlf_are_accepted() {
    let g = parse_map(
        "t.map",
        "type octile\r\nheight 1\r\nwidth 7\r\nmap\r\n.GS@OTW\r\n",
    )
    .unwrap();
    assert_eq!(g.walls(), [false, false, false, true, true, true, true]);
    // Any header order, blank lines in the header.
    let g = parse_map("t.map", "width 2\n\nheight 1\ntype octile\nmap\n.@\n").unwrap();
    assert_eq!((g.height(), g.width()), (1, 2));
}

#[test]
fn grid_from_rows_reports_ragged_rows() {
    let err = Grid::from_rows(&["...", ".."]).unwrap_err();
    assert_eq!(parse_line(err, "<rows>"), 6);
    assert!(Grid::from_rows(&[]).is_err());
}

// ---------------------------------------------------------------- .scen

fn grid() -> Grid {
    Grid::from_rows(&["..@.", "...."]).unwrap()
}

fn scen_err_line(text: &str) -> (usize, String) {
    let err = parse_scen("t.scen", text, &grid()).unwrap_err();
    let msg = err.to_string();
    (parse_line(err, "t.scen"), msg)
}

const GOOD: &str = "0\tt.map\t4\t2\t0\t0\t3\t1\t4";

#[test]
fn good_scen_parses() {
    let s = parse_scen(
        "t.scen",
        &format!("version 1\n{GOOD}\n0\tt.map\t4\t2\t3\t0\t0\t1\t4\n"),
        &grid(),
    )
    .unwrap();
    assert_eq!(s.starts, [c(0, 0), c(0, 3)]);
    assert_eq!(s.goals, [c(1, 3), c(1, 0)]);
    // Space-separated fields are accepted too.
    let s = parse_scen("t.scen", "version 1\n0 t.map 4 2 0 0 3 1 4\n", &grid()).unwrap();
    assert_eq!(s.starts, [c(0, 0)]);
}

#[test]
fn scen_without_version_line() {
    let (line, msg) = scen_err_line(&format!("{GOOD}\n"));
    assert_eq!(line, 1);
    assert!(msg.contains("version 1"), "{msg}");
    let (line, _) = scen_err_line("");
    assert_eq!(line, 1);
    let (line, _) = scen_err_line(&format!("\n\n{GOOD}\n"));
    assert_eq!(line, 3);
}

#[test]
fn scen_wrong_field_count() {
    let (line, msg) = scen_err_line(&format!("version 1\n{GOOD}\n0\tt.map\t4\t2\t0\t0\t3\t1\n"));
    assert_eq!(line, 3);
    assert!(msg.contains("expected 9 fields"), "{msg}");
    assert!(msg.contains("got 8"), "{msg}");
    let (line, _) = scen_err_line(&format!("version 1\n{GOOD}\t7\n"));
    assert_eq!(line, 2);
}

#[test]
fn scen_start_or_goal_on_a_wall() {
    let (line, msg) = scen_err_line("version 1\n0\tt.map\t4\t2\t2\t0\t3\t1\t4\n");
    assert_eq!(line, 2);
    assert!(msg.contains("start x=2 y=0 is on a wall"), "{msg}");
    let (line, msg) = scen_err_line(&format!(
        "version 1\n{GOOD}\n{GOOD}\n0\tt.map\t4\t2\t0\t0\t2\t0\t4\n"
    ));
    assert_eq!(line, 4);
    assert!(msg.contains("goal x=2 y=0 is on a wall"), "{msg}");
}

#[test]
fn scen_cell_outside_the_grid() {
    let (line, msg) = scen_err_line("version 1\n0\tt.map\t4\t2\t4\t0\t3\t1\t4\n");
    assert_eq!(line, 2);
    assert!(msg.contains("start x=4 y=0 is outside"), "{msg}");
    let (line, msg) = scen_err_line("version 1\n0\tt.map\t4\t2\t0\t0\t0\t2\t4\n");
    assert_eq!(line, 2);
    assert!(msg.contains("goal x=0 y=2 is outside"), "{msg}");
}

#[test]
fn scen_for_other_dimensions() {
    let (line, msg) = scen_err_line(&format!(
        "version 1\n{GOOD}\n0\tt.map\t2\t4\t0\t0\t1\t1\t2\n"
    ));
    assert_eq!(line, 3);
    assert!(
        msg.contains("scenario is for a 2x4 map, the map is 4x2"),
        "{msg}"
    );
}

#[test]
fn scen_non_numeric_field() {
    let (line, msg) = scen_err_line("version 1\n0\tt.map\t4\t2\tzero\t0\t3\t1\t4\n");
    assert_eq!(line, 2);
    assert!(msg.contains("x 'zero'"), "{msg}");
    let (line, _) = scen_err_line("version 1\n0\tt.map\t4\t2\t-1\t0\t3\t1\t4\n");
    assert_eq!(line, 2);
}

// ---------------------------------------------------------- files and ids

/// A fresh directory under the system temp dir.
fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("buridan-env-test-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn map_file_with_scen_beside_it() {
    let dir = temp_dir("load");
    let map_path = dir.join("corridor.map");
    std::fs::write(
        &map_path,
        "type octile\nheight 2\nwidth 5\nmap\n..@..\n.....\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("corridor.scen"),
        "version 1\n0\tcorridor.map\t5\t2\t0\t0\t4\t0\t6\n0\tcorridor.map\t5\t2\t4\t1\t0\t1\t4\n",
    )
    .unwrap();
    let map = Map::load(map_path.to_str().unwrap()).unwrap();
    assert_eq!(map.name, "corridor");
    assert_eq!((map.grid.height(), map.grid.width()), (2, 5));
    let scen = map.scenario.clone().unwrap();
    assert_eq!(scen.starts, [c(0, 0), c(1, 4)]);
    assert_eq!(scen.goals, [c(0, 4), c(1, 0)]);
    // It runs as an env with fixed starts.
    let cfg = EnvConfig {
        agents: 2,
        starts: Starts::Fixed,
        ..EnvConfig::default()
    };
    let env = GridEnv::new(Arc::new(map), cfg).unwrap();
    assert_eq!(env.positions(), [c(0, 0), c(1, 4)]);

    // Without a .scen: no scenario, random starts still work, fixed ones do not.
    let lone = dir.join("lone.map");
    std::fs::write(&lone, "type octile\nheight 1\nwidth 4\nmap\n....\n").unwrap();
    let map = Arc::new(Map::from_file(&lone).unwrap());
    assert!(map.scenario.is_none());
    let random = EnvConfig {
        agents: 2,
        ..EnvConfig::default()
    };
    assert!(GridEnv::new(map.clone(), random.clone()).is_ok());
    assert_eq!(
        GridEnv::new(
            map.clone(),
            EnvConfig {
                starts: Starts::Fixed,
                ..random
            }
        )
        .unwrap_err(),
        EnvError::NotEnoughFixedAgents {
            map: "lone".into(),
            available: 0,
            requested: 2
        }
    );
    // A scenario from another file.
    let other = dir.join("other.scen");
    std::fs::write(&other, "version 1\n0\tlone.map\t4\t1\t3\t0\t0\t0\t3\n").unwrap();
    let map = Map::from_file(&lone)
        .unwrap()
        .with_scenario_file(&other)
        .unwrap();
    assert_eq!(map.scenario.unwrap().starts, [c(0, 3)]);

    // Errors in files name the file and the line.
    let bad = dir.join("bad.map");
    std::fs::write(&bad, "type octile\nheight 2\nwidth 2\nmap\n..\n.?\n").unwrap();
    let err = Map::load(bad.to_str().unwrap()).unwrap_err();
    assert_eq!(parse_line(err, &bad.display().to_string()), 6);
    let bad_scen_map = dir.join("badscen.map");
    std::fs::write(&bad_scen_map, "type octile\nheight 1\nwidth 2\nmap\n.@\n").unwrap();
    std::fs::write(
        dir.join("badscen.scen"),
        "version 1\n0\tm\t2\t1\t1\t0\t0\t0\t1\n",
    )
    .unwrap();
    let err = Map::load(bad_scen_map.to_str().unwrap()).unwrap_err();
    assert_eq!(
        parse_line(err, &dir.join("badscen.scen").display().to_string()),
        2
    );
    // Missing scenario file given explicitly: an I/O error.
    let err = Map::from_file(&lone)
        .unwrap()
        .with_scenario_file(&dir.join("nope.scen"))
        .unwrap_err();
    assert!(matches!(err, MapError::Io { .. }), "{err:?}");
    let err = Map::from_file(&dir.join("nope.map")).unwrap_err();
    assert!(matches!(err, MapError::Io { .. }), "{err:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn unknown_map_id_or_missing_file() {
    for name in ["rm-9.9", "no/such/file.map", ""] {
        match Map::load(name) {
            Err(MapError::UnknownMap { name: n, known }) => {
                assert_eq!(n, name);
                assert!(
                    known.contains("rm-1.1") && known.contains("rm-3.1b"),
                    "{known}"
                );
            }
            other => panic!("{name}: {other:?}"),
        }
    }
    // A directory is not a map file either.
    let dir = temp_dir("dir");
    assert!(matches!(
        Map::load(dir.to_str().unwrap()),
        Err(MapError::UnknownMap { .. })
    ));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn all_17_bundled_models_load() {
    assert_eq!(buridan_env::REFERENCE_MODELS.len(), 17);
    for m in buridan_env::REFERENCE_MODELS {
        let map = Map::load(m.id).unwrap();
        let scen = map.scenario.unwrap();
        assert!(
            !scen.starts.is_empty() && scen.starts.len() == scen.goals.len(),
            "{}",
            m.id
        );
    }
}

// ------------------------------------------------------------ env errors

#[test]
fn too_few_free_cells_for_random_starts() {
    // 3 free cells cannot hold 2 distinct starts and 2 distinct goals.
    let map = map_from_rows(&["..@."], &[], &[]);
    let cfg = EnvConfig {
        agents: 2,
        ..EnvConfig::default()
    };
    assert_eq!(
        GridEnv::new(map.clone(), cfg).unwrap_err(),
        EnvError::TooFewFreeCells {
            map: "hand-made".into(),
            free: 3,
            agents: 2,
            needed: 4
        }
    );
    // 4 free cells are enough.
    let map = map_from_rows(&["...."], &[], &[]);
    assert!(GridEnv::new(
        map,
        EnvConfig {
            agents: 2,
            ..EnvConfig::default()
        }
    )
    .is_ok());
    // A bundled model with too many agents.
    let map = Arc::new(Map::load("rm-1.1").unwrap());
    let err = VecEnv::new(
        map,
        EnvConfig {
            agents: 6,
            ..EnvConfig::default()
        },
        2,
        ObsKind::Local,
        1,
    )
    .err()
    .expect("6 agents do not fit rm-1.1");
    assert!(
        matches!(
            err,
            EnvError::TooFewFreeCells {
                free: 10,
                needed: 12,
                ..
            }
        ),
        "{err:?}"
    );
}

#[test]
fn fixed_starts_with_too_few_scenario_agents() {
    let map = Arc::new(Map::load("rm-1.1").unwrap());
    let cfg = EnvConfig {
        agents: 3,
        starts: Starts::Fixed,
        ..EnvConfig::default()
    };
    assert_eq!(
        GridEnv::new(map.clone(), cfg.clone()).unwrap_err(),
        EnvError::NotEnoughFixedAgents {
            map: "rm-1.1".into(),
            available: 2,
            requested: 3
        }
    );
    // Fewer agents than the scenario holds take its first lines.
    let env = GridEnv::new(map, EnvConfig { agents: 1, ..cfg }).unwrap();
    assert_eq!(env.positions(), [c(1, 1)]);
}

#[test]
fn reset_with_bad_cells() {
    let mut env = env_on(&[".@.", "..."], &[(0, 0), (1, 0)], &[(1, 2), (0, 2)], 100);
    let starts = [c(0, 0), c(1, 0)];
    let goals = [c(1, 2), c(0, 2)];
    assert_eq!(
        env.reset_with(0, &[c(0, 0), c(0, 1)], &goals),
        Err(EnvError::BadCell {
            agent: 1,
            which: "start",
            row: 0,
            col: 1,
            problem: "a wall"
        })
    );
    assert_eq!(
        env.reset_with(0, &starts, &[c(2, 0), c(0, 2)]),
        Err(EnvError::BadCell {
            agent: 0,
            which: "goal",
            row: 2,
            col: 0,
            problem: "outside the grid"
        })
    );
    assert_eq!(
        env.reset_with(0, &[c(1, 1), c(1, 1)], &goals),
        Err(EnvError::SharedCell {
            first: 0,
            second: 1,
            which: "start",
            row: 1,
            col: 1
        })
    );
    assert_eq!(
        env.reset_with(0, &starts[..1], &goals),
        Err(EnvError::WrongLength {
            what: "starts",
            expected: 2,
            got: 1
        })
    );
    assert_eq!(
        env.reset_with(0, &starts, &[c(1, 2)]),
        Err(EnvError::WrongLength {
            what: "goals",
            expected: 2,
            got: 1
        })
    );
    // Nothing changed, and a good reset still works.
    assert_eq!(env.positions(), starts);
    env.reset_with(4, &[c(1, 1), c(0, 0)], &[c(0, 2), c(1, 0)])
        .unwrap();
    assert_eq!(env.positions(), [c(1, 1), c(0, 0)]);
    assert_eq!(env.episode(), 4);
    // A fixed scenario with a start on a wall surfaces as BadCell from new().
    let map = map_from_rows(&[".@."], &[(0, 1)], &[(0, 0)]);
    assert!(matches!(
        GridEnv::new(map, common::fixed_cfg(1, 10)),
        Err(EnvError::BadCell { which: "start", .. })
    ));
}

#[test]
fn invalid_action_changes_nothing() {
    let mut env = env_on(&["...."], &[(0, 0), (0, 3)], &[(0, 1), (0, 2)], 100);
    let mut rewards = [7.0f32, 7.0];
    let before = (env.positions(), env.t(), env.stats());
    assert_eq!(
        env.step(&[2, 5], &mut rewards),
        Err(EnvError::InvalidAction {
            agent: 1,
            action: 5
        })
    );
    assert_eq!(
        env.step(&[255, 0], &mut rewards),
        Err(EnvError::InvalidAction {
            agent: 0,
            action: 255
        })
    );
    assert_eq!((env.positions(), env.t(), env.stats()), before);
    assert_eq!(rewards, [7.0, 7.0]);
    assert_eq!(env.monitor().deadlocked(), 0);
    // The env still works normally afterwards.
    assert_eq!(common::step(&mut env, &[2, 0]).0, [0.5, 0.0]);
}

fn wl<T>(what: &'static str, expected: usize, got: usize) -> Result<T, EnvError> {
    Err(EnvError::WrongLength {
        what,
        expected,
        got,
    })
}

#[test]
fn wrong_buffer_lengths() {
    let mut env = env_on(&["...."], &[(0, 0), (0, 3)], &[(0, 1), (0, 2)], 100);
    assert_eq!(env.step(&[0], &mut [0.0; 2]), wl("actions", 2, 1));
    assert_eq!(env.step(&[0, 0, 0], &mut [0.0; 2]), wl("actions", 2, 3));
    assert_eq!(env.step(&[0, 0], &mut [0.0; 3]), wl("rewards", 2, 3));
    assert_eq!(env.t(), 0);
    assert_eq!(
        env.write_local_obs(0, &mut [0.0; 128]),
        wl("observation floats", 129, 128)
    );
    assert_eq!(
        env.write_local_codes(0, &mut [0; 24]),
        wl("window codes", 25, 24)
    );
    assert_eq!(
        env.write_action_mask(0, &mut [0; 4]),
        wl("mask bytes", 5, 4)
    );
    assert_eq!(
        env.write_joint_mask(&mut [0; 5]),
        wl("joint mask bytes", 10, 5)
    );
    assert_eq!(
        env.write_central_obs(&mut [0.0; 19]),
        wl("central observation floats", 20, 19)
    );
    assert_eq!(env.write_central_codes(&mut [0; 5]), wl("grid codes", 4, 5));
}

#[test]
fn invalid_configurations() {
    let map = Arc::new(Map::load("rm-2.1").unwrap());
    for cfg in [
        EnvConfig {
            agents: 0,
            ..EnvConfig::default()
        },
        EnvConfig {
            t_max: 0,
            ..EnvConfig::default()
        },
        EnvConfig {
            sensor_range: 17,
            ..EnvConfig::default()
        },
        EnvConfig {
            stall_window: 0,
            ..EnvConfig::default()
        },
    ] {
        assert!(
            matches!(
                GridEnv::new(map.clone(), cfg.clone()),
                Err(EnvError::InvalidConfig(_))
            ),
            "{cfg:?}"
        );
        assert!(matches!(
            VecEnv::new(map.clone(), cfg, 1, ObsKind::Local, 1),
            Err(EnvError::InvalidConfig(_))
        ));
    }
    assert_eq!("fixed".parse::<Starts>(), Ok(Starts::Fixed));
    assert_eq!("deterministic".parse::<Starts>(), Ok(Starts::Fixed));
    assert_eq!("random".parse::<Starts>(), Ok(Starts::Random));
    assert!("sometimes".parse::<Starts>().is_err());
}
