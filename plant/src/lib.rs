//! The production-logistics AGV plant of the dissertation as a native
//! multi-agent env beside the grid worlds, behind the same
//! [`buridan_env::BatchedEnv`] interface.
//!
//! - [`plant`]: plant files (TOML) and the validated [`Plant`]; two are
//!   bundled: `dissertation` and the larger `hall`.
//! - [`env`]: [`PlantEnv`], one episode: kinematics, contact and collision
//!   rules, sources, units, sink, dispatcher, rewards, deadlock detector.
//! - [`vec_env`]: [`PlantVecEnv`], a batch with auto-reset.
//! - [`kpi`]: [`Kpis`], what an episode achieved.
//! - [`controllers`]: the reservation and random baselines.
//!
//! # The model's choices
//!
//! The dissertation ("Evaluation with an external Simulation Software")
//! fixes the elements, observation, actions, rewards and T_max; it is silent
//! on the rest, which this crate chooses as follows (all but the rules are
//! parameters of the plant file):
//!
//! - **Layout.** The figure of the dissertation's plant is not available;
//!   `dissertation` is a reconstruction from its text (see the file's
//!   header): one single-lane main line, station spurs and sidings as dead
//!   ends. Node coordinates in metres.
//! - **Kinematics.** AGVs are points with a body `agv.length` (1 m) long
//!   and drive `agv.speed` (1 m/s, Plant Simulation's default) at once, no
//!   acceleration. Forward follows the shortest route to the goal; backward
//!   reverses away from it, into dead-end sidings at junctions. Loading or
//!   unloading takes `agv.handling_time` (2 s). See [`env`].
//! - **Contact and collisions.** AGVs never overlap: a move stops at the
//!   first touch (track distance = body length). Stopped by an AGV driving
//!   towards it, the mover has collided (−1, "to the oncoming AGV"); stopped
//!   by one standing or driving away, it is merely blocked.
//! - **Starts.** Agent i starts on segment `starts[i]` at a uniformly
//!   random offset at least one body length from its ends (the
//!   dissertation: agent i always starts on track i).
//! - **Stations.** Sources produce with fixed or exponential gaps
//!   (`interarrival`, `arrivals`), start with `initial` products, and pause
//!   while their buffer (`capacity`, 8) is full. A unit processes one
//!   product at a time (`process_time`) from its input buffer into its
//!   output buffer (capacities 2); a finished product waits in the unit
//!   while the output buffer is full. A unit is *working* (status 1) while
//!   it processes; otherwise it costs −0.01 per step to every AGV. The sink
//!   takes everything.
//! - **Dispatching.** An idle, empty AGV gets the nearest unclaimed finished
//!   product in a unit's output buffer, else the nearest unclaimed raw
//!   product whose unit has input room for it counting products already on
//!   their way (so no AGV waits at a full unit), else nothing (goal 0). A
//!   loaded AGV's goal is its product's unit (raw) or the sink (finished).
//!   Goal codes: 0 none, 1 unit A, 2 unit B, 3 sink, 4 buffer 1 (source A),
//!   5 buffer 2 (source B).
//! - **Observation.** Local rows: agent id, status of units A and B, buffer
//!   counts of sources A and B, x, y, speed (signed, m/s), goal code,
//!   carrying flag, remaining route length (m, −1 without goal) — raw, or
//!   scaled to about [0, 1] with [`PlantConfig::normalize`]. Central rows:
//!   the 4 plant values, then the 6 AGV values per AGV. Masks: hold always;
//!   forward with a goal not yet reached; backward unless at a dead end; all
//!   only hold while handling. Other AGVs mask nothing.
//! - **Deadlocks.** A cycle of AGVs each waiting for the next (touching it
//!   on its route ahead) for `episode.deadlock_after` (10) steps.
//! - **Episodes** end only at `t_max` (truncation); nothing terminates them.
//!
//! ```
//! use std::sync::Arc;
//! use buridan_plant::{controllers::ReservationController, Plant, PlantConfig, PlantEnv};
//! let plant = Arc::new(Plant::load("dissertation").unwrap()); // or a path to a plant file
//! let mut env = PlantEnv::new(plant, PlantConfig { agents: 2, seed: 1, ..Default::default() }).unwrap();
//! let mut controller = ReservationController::new(2);
//! let (mut actions, mut rewards) = ([0u8; 2], [0.0f32; 2]);
//! while !env.is_over() {
//!     controller.actions(&env, &mut actions).unwrap();
//!     env.step(&actions, &mut rewards).unwrap();
//! }
//! let kpis = env.kpis();
//! assert!(kpis.deliveries > 0 && kpis.collisions == 0);
//! ```

#![warn(missing_docs)]

pub mod controllers;
pub mod env;
pub mod error;
pub mod kpi;
pub mod plant;
pub mod vec_env;

pub use env::{
    Agv, Load, PlantConfig, PlantEnv, Preview, SourceState, StepOutcome, Task, TrackPos, UnitState,
    BACKWARD, FORWARD, HOLD, LOCAL_OBS_DIM, NUM_ACTIONS,
};
pub use error::{PlantError, PlantProblem};
pub use kpi::Kpis;
pub use plant::{Plant, BUNDLED};
pub use vec_env::PlantVecEnv;
