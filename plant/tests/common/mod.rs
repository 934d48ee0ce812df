//! A small hand-checkable plant for the tests.
//!
//! ```text
//!                    unit_a (20,10)
//!                      | ua 10 m
//! src_a (0,0) --s1 20 m-- m (20,0) --s2 20 m-- src_b (40,0)
//!                      | ub 10 m   \ sk 15 m (sink), sd 8 m (siding d)
//!                    unit_b (20,-10)
//! ```
#![allow(dead_code)]

use std::sync::Arc;

use buridan_plant::{Plant, PlantConfig, PlantEnv, TrackPos};

/// The test plant's text with `initial_a`/`initial_b` products in the
/// source buffers, T_max `t_max` and deadlocks after `deadlock_after`.
pub fn corridor_text(initial_a: u32, initial_b: u32, t_max: u32, deadlock_after: u32) -> String {
    format!(
        r#"
id = "corridor"
starts = ["s2", "s1"]

[agv]
length = 1.0
speed = 1.0
handling_time = 2.0

[episode]
t_max = {t_max}
deadlock_after = {deadlock_after}

[[nodes]]
id = "src_a"
x = 0.0
y = 0.0
[[nodes]]
id = "m"
x = 20.0
y = 0.0
[[nodes]]
id = "src_b"
x = 40.0
y = 0.0
[[nodes]]
id = "unit_a"
x = 20.0
y = 10.0
[[nodes]]
id = "unit_b"
x = 20.0
y = -10.0
[[nodes]]
id = "sink"
x = 30.0
y = 10.0
[[nodes]]
id = "d"
x = 25.0
y = -5.0

[[segments]]
id = "s1"
from = "src_a"
to = "m"
[[segments]]
id = "s2"
from = "m"
to = "src_b"
[[segments]]
id = "ua"
from = "m"
to = "unit_a"
[[segments]]
id = "ub"
from = "m"
to = "unit_b"
[[segments]]
id = "sk"
from = "m"
to = "sink"
length = 15.0
[[segments]]
id = "sd"
from = "m"
to = "d"
length = 8.0

[[products]]
id = "A"
source = {{ node = "src_a", capacity = 4, initial = {initial_a}, interarrival = 1000000.0 }}
unit = {{ node = "unit_a", input_capacity = 2, output_capacity = 2, process_time = 10.0 }}

[[products]]
id = "B"
source = {{ node = "src_b", capacity = 4, initial = {initial_b}, interarrival = 1000000.0 }}
unit = {{ node = "unit_b", input_capacity = 2, output_capacity = 2, process_time = 10.0 }}

[sink]
node = "sink"
"#
    )
}

/// The corridor plant.
pub fn corridor(initial_a: u32, initial_b: u32, t_max: u32, deadlock_after: u32) -> Arc<Plant> {
    let text = corridor_text(initial_a, initial_b, t_max, deadlock_after);
    Arc::new(Plant::from_toml_str(&text, "corridor.toml").expect("the test plant is valid"))
}

/// An env of the corridor plant with `agents` AGVs.
pub fn env(plant: &Arc<Plant>, agents: usize) -> PlantEnv {
    PlantEnv::new(
        plant.clone(),
        PlantConfig {
            agents,
            ..PlantConfig::default()
        },
    )
    .expect("valid config")
}

/// Position on segment `id` at `offset`.
pub fn at(plant: &Plant, id: &str, offset: f64) -> TrackPos {
    TrackPos {
        segment: plant.segment_index(id).expect("known segment"),
        offset,
    }
}

/// Asserts two floats agree to 1e-9.
#[track_caller]
pub fn close(got: f64, want: f64) {
    assert!((got - want).abs() < 1e-9, "got {got}, want {want}");
}
