//! The episodes recorded from the dissertation author's environment (v1.0.0),
//! `tests/data/author-env-v1.0.0-traces.json.gz` (format in `tests/parity.rs`).

use std::collections::BTreeMap;
use std::io::Read;
use std::path::PathBuf;
use std::sync::{Arc, OnceLock};

use buridan_env::{Cell, EnvConfig, GridEnv, Map, Starts, NUM_ACTIONS};

/// Sensor range of the recorded env: 5×5 windows.
pub const SENSOR_RANGE: usize = 2;
/// Side of the recorded windows.
pub const SIDE: usize = 2 * SENSOR_RANGE + 1;
/// `T_max` of the recorded env.
pub const T_MAX: u32 = 100;

/// One recorded episode.
#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Episode {
    pub map: String,
    pub agents: usize,
    pub starts: Vec<[usize; 2]>,
    pub goals: Vec<[usize; 2]>,
    pub steps: Vec<Step>,
}

/// One recorded step.
#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Step {
    pub masks_before: Vec<[u8; NUM_ACTIONS]>,
    pub codes0_before: [[u8; SIDE]; SIDE],
    pub actions: Vec<u8>,
    pub positions: Vec<[usize; 2]>,
    pub rewards: Vec<f32>,
    pub terminated: bool,
    pub truncated: bool,
}

fn trace_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/author-env-v1.0.0-traces.json.gz")
}

/// All 48 recorded episodes, parsed once.
pub fn episodes() -> &'static [Episode] {
    static EPISODES: OnceLock<Vec<Episode>> = OnceLock::new();
    EPISODES.get_or_init(|| {
        let file = std::fs::File::open(trace_path()).expect("parity trace file");
        let mut json = String::new();
        flate2::read::GzDecoder::new(file)
            .read_to_string(&mut json)
            .expect("parity trace decompresses");
        serde_json::from_str(&json).expect("parity trace parses")
    })
}

/// Cells from `[row, col]` pairs.
pub fn cells(list: &[[usize; 2]]) -> Vec<Cell> {
    list.iter().map(|&[r, c]| Cell::new(r, c)).collect()
}

fn maps() -> &'static BTreeMap<String, Arc<Map>> {
    static MAPS: OnceLock<BTreeMap<String, Arc<Map>>> = OnceLock::new();
    MAPS.get_or_init(|| {
        episodes()
            .iter()
            .map(|e| {
                let map = Map::load(&e.map).expect("bundled map");
                (e.map.clone(), Arc::new(map))
            })
            .collect()
    })
}

/// An env on the episode's map, reset to the recorded starts and goals.
pub fn env_for(ep: &Episode) -> GridEnv {
    let cfg = EnvConfig {
        agents: ep.agents,
        t_max: T_MAX,
        starts: Starts::Random,
        sensor_range: SENSOR_RANGE,
        ..EnvConfig::default()
    };
    let mut env = GridEnv::new(maps()[&ep.map].clone(), cfg).expect("env builds");
    env.reset_with(0, &cells(&ep.starts), &cells(&ep.goals))
        .expect("recorded starts and goals are valid");
    env
}
