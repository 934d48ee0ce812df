//! Lifelong throughput on one goal file: a controller drives the robots
//! for T steps on given starts and goal sequences, and the measure is
//! POGEMA's `avg_throughput`, goals reached per step.
//!
//! The robots are a lifelong [`GridEnv`] under pogema rules reset with the
//! file's sequences ([`GridEnv::reset_with_sequences`]): a robot standing on
//! its goal after a step gets the next goal of its own sequence, goals may be
//! shared, and with a delay each move fails (becomes a wait) with that
//! probability, drawn from the env's seeded stream for the episode. The
//! controller answers through a [`FleetSession`] opened with shared goals,
//! the path every closed-loop controller takes: a policy or a shield acts
//! on the reported state; a one-shot planner (`lacam`) plans again whenever
//! a goal changes or a robot lags, towards distinct stand-ins where goals
//! are shared ([`crate::fleet::planning_goals`]), and a step whose planner
//! finds no plan is a step of waits (counted).
//!
//! ```
//! use std::sync::Arc;
//! use buridan_env::{Cell, Map};
//! use buridan_eval::goal_sequences::GoalFile;
//! use buridan_eval::throughput::{run_goal_file, LifelongSpec};
//! let map = Arc::new(Map::load("rm-2.1").unwrap());
//! let free = map.grid.free_cells();
//! let file = GoalFile {
//!     map: map.name.clone(),
//!     steps: 40,
//!     starts: vec![free[0], free[5]],
//!     sequences: vec![(1..40).map(|k| free[(k * 7) % free.len()]).collect(); 2],
//!     comments: vec![],
//! };
//! let spec = LifelongSpec { steps: 40, ..LifelongSpec::default() };
//! let run = run_goal_file(&map, &file, "demo.goals", &"lifelong-pibt".parse().unwrap(), &spec).unwrap();
//! assert_eq!((run.steps, run.collisions), (40, 0));
//! assert!(run.throughput > 0.0);
//! ```

use std::collections::HashSet;
use std::sync::Arc;
use std::time::Instant;

use buridan_env::{EnvConfig, EnvError, GridEnv, Map, Rules};
use buridan_mapf::Limits;

use crate::by_name::Controller as ControllerSpec;
use crate::fleet::{FleetError, FleetOptions, FleetSession};
use crate::goal_sequences::GoalFile;

/// How a lifelong run is measured.
#[derive(Debug, Clone)]
pub struct LifelongSpec {
    /// Steps per run (POGEMA's lifelong benchmark: 256).
    pub steps: u32,
    /// Probability that a robot's move fails and becomes a wait.
    pub delay: f32,
    /// Seed of the controller's draws and of the delays.
    pub seed: u64,
    /// The episode index of the delay draws (an instance's seed, so that
    /// instances lag differently).
    pub episode: u64,
    /// A planner's limits each time it plans.
    pub limits: Limits,
}

impl Default for LifelongSpec {
    fn default() -> Self {
        Self {
            steps: 256,
            delay: 0.0,
            seed: 0,
            episode: 0,
            limits: Limits::default(),
        }
    }
}

/// What one lifelong run measured.
#[derive(Debug, Clone, PartialEq)]
pub struct LifelongRun {
    /// Robots.
    pub agents: usize,
    /// Steps run.
    pub steps: u32,
    /// Goals reached in all.
    pub goals_reached: u32,
    /// Goals reached per step (POGEMA's `avg_throughput`).
    pub throughput: f64,
    /// Goals reached at each step.
    pub per_step: Vec<u32>,
    /// Steps at which two robots stood on one cell (0 under the env's rules).
    pub collisions: u32,
    /// Steps whose planner found no plan (every robot waited).
    pub gave_up_steps: u32,
    /// Plans made after the first (a planner's).
    pub replans: u64,
    /// Moves the delay turned into waits.
    pub delayed_moves: u32,
    /// The most goals of its sequence any robot was given.
    pub most_goals_given: usize,
    /// Wall-clock seconds of the run.
    pub wall_s: f64,
}

/// Why a lifelong run could not be measured; each names its goal file.
#[derive(Debug, thiserror::Error)]
pub enum ThroughputError {
    /// The file's starts or goals do not fit the map or the env refused a step.
    #[error("{file}: {source}")]
    Env {
        /// The goal file.
        file: String,
        /// The env's complaint (names the agent and cell).
        source: EnvError,
    },
    /// The controller could not be built or its session refused the state.
    #[error("{file}: {source}")]
    Fleet {
        /// The goal file.
        file: String,
        /// The session's complaint.
        source: Box<FleetError>,
    },
    /// The file's map is not the map given.
    #[error("{file}: made for map '{file_map}', run on '{map}'")]
    WrongMap {
        /// The goal file.
        file: String,
        /// The map its header names.
        file_map: String,
        /// The map given.
        map: String,
    },
    /// A robot reached the last goal of its sequence: the file has too few
    /// goals for these steps, and throughput after that would be wrong.
    #[error("{file}: agent {agent} reached the last of its {goals} goals at step {step} of {steps}: the file has too few goals for this run")]
    Exhausted {
        /// The goal file.
        file: String,
        /// The robot.
        agent: usize,
        /// The length of its sequence.
        goals: usize,
        /// The step it reached it.
        step: u32,
        /// The steps asked for.
        steps: u32,
    },
}

/// The robots of a lifelong run on `file`, as [`run_goal_file`] plays
/// them: a lifelong env under pogema rules, reset with the file's starts
/// and goal sequences, for `spec.steps` steps, each move failing with
/// probability `spec.delay` from the env's seeded stream for
/// `spec.episode`. Whoever drives these robots (a fleet service's client)
/// sees the delays `run_goal_file` sees.
pub fn lifelong_robots(
    map: &Arc<Map>,
    file: &GoalFile,
    spec: &LifelongSpec,
) -> Result<GridEnv, EnvError> {
    let cfg = EnvConfig {
        agents: file.agents(),
        rules: Rules::Pogema,
        lifelong: true,
        t_max: spec.steps,
        delay: spec.delay,
        seed: spec.seed,
        ..EnvConfig::default()
    };
    let mut robots = GridEnv::new(map.clone(), cfg)?;
    robots.reset_with_sequences(spec.episode, &file.starts, &file.sequences)?;
    Ok(robots)
}

/// Runs `controller` for `spec.steps` steps on the tasks of `file` (named
/// `name` in errors) on `map` (see the [module docs](self)).
pub fn run_goal_file(
    map: &Arc<Map>,
    file: &GoalFile,
    name: &str,
    controller: &ControllerSpec,
    spec: &LifelongSpec,
) -> Result<LifelongRun, ThroughputError> {
    let env_err = |source| ThroughputError::Env {
        file: name.to_string(),
        source,
    };
    let fleet_err = |source| ThroughputError::Fleet {
        file: name.to_string(),
        source: Box::new(source),
    };
    if file.map != map.name {
        return Err(ThroughputError::WrongMap {
            file: name.to_string(),
            file_map: file.map.clone(),
            map: map.name.clone(),
        });
    }
    let started = Instant::now();
    let agents = file.agents();
    let mut robots = lifelong_robots(map, file, spec).map_err(env_err)?;
    let mut fleet = FleetSession::open(
        map.clone(),
        robots.config().rules,
        controller,
        &robots.positions(),
        &robots.goals(),
        FleetOptions::from(spec.seed)
            .within(spec.limits)
            .with_shared_goals(),
    )
    .map_err(fleet_err)?;
    let (mut moves, mut rewards) = (vec![0u8; agents], vec![0.0f32; agents]);
    let (mut per_step, mut collisions, mut gave_up_steps) = (Vec::new(), 0, 0);
    let mut cells = HashSet::with_capacity(agents);
    let mut reached = 0;
    while !robots.is_over() {
        match fleet.step(&robots.positions(), &robots.goals()) {
            Ok(answer) => moves.copy_from_slice(answer),
            Err(FleetError::GaveUp(_)) => {
                moves.fill(0);
                gave_up_steps += 1;
            }
            Err(e) => return Err(fleet_err(e)),
        }
        robots.step(&moves, &mut rewards).map_err(env_err)?;
        let now = robots.stats().goals_reached;
        per_step.push(now - reached);
        reached = now;
        cells.clear();
        if !robots.positions().iter().all(|&c| cells.insert(c)) {
            collisions += 1;
        }
        // Exhausted at the last step is harmless: nothing was missed.
        if let Some(agent) = robots.sequence_exhausted().filter(|_| !robots.is_over()) {
            return Err(ThroughputError::Exhausted {
                file: name.to_string(),
                agent,
                goals: file.sequences[agent].len(),
                step: robots.t(),
                steps: spec.steps,
            });
        }
    }
    let steps = robots.t();
    Ok(LifelongRun {
        agents,
        steps,
        goals_reached: reached,
        throughput: f64::from(reached) / f64::from(steps.max(1)),
        per_step,
        collisions,
        gave_up_steps,
        replans: fleet.replans(),
        delayed_moves: robots.delayed_moves(),
        most_goals_given: (0..agents)
            .map(|i| robots.goals_given(i))
            .max()
            .unwrap_or(0),
        wall_s: started.elapsed().as_secs_f64(),
    })
}
