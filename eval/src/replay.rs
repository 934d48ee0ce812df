//! Records what happens in one of [`crate::evaluate`]'s episodes, step by
//! step, for drawing (`buridan-render` turns a [`Trace`] into a GIF).
//!
//! Episode `k` of a seed is the very episode the harness plays as its
//! `k`-th: the same env configuration ([`crate::runner::episode_config`]),
//! the same reset and the same loop ([`crate::runner::run_episode_observed`]).

use std::sync::Arc;

use buridan_env::monitor::AgentState;
use buridan_env::{Cell, EnvError, GridEnv, Map};

use crate::controller::Controller;
use crate::runner::{episode_config, run_episode, run_episode_observed, EpisodeRecord, EvalSpec};

/// What the stall monitor said about an agent after a step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Mark {
    /// Moving towards its goal, or waiting without being stuck.
    Free,
    /// On its goal.
    AtGoal,
    /// Off its goal without progress for the monitor's window (blocked).
    Stuck,
    /// Stuck in a jam and not moving.
    Deadlocked,
    /// Stuck in a jam but moving.
    Livelocked,
}

/// The agents after one step (or after the reset, step 0).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Snapshot {
    /// Steps taken so far.
    pub t: u32,
    /// Each agent's cell.
    pub positions: Vec<Cell>,
    /// Each agent's state.
    pub marks: Vec<Mark>,
}

/// One recorded episode: the layout, the goals and a [`Snapshot`] per step.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Trace {
    /// Map name.
    pub map: String,
    /// Controller name.
    pub controller: String,
    /// Seed of the episode generator.
    pub seed: u64,
    /// Episode index.
    pub episode: u64,
    /// Rows of the layout.
    pub height: usize,
    /// Columns of the layout.
    pub width: usize,
    /// Row-major: `true` for walls.
    pub walls: Vec<bool>,
    /// Each agent's goal.
    pub goals: Vec<Cell>,
    /// Truncation step count.
    pub t_max: u32,
    /// Snapshots from the reset on, one per step.
    pub snapshots: Vec<Snapshot>,
    /// The harness's record of the episode.
    pub record: EpisodeRecord,
}

/// Why an episode could not be recorded.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    /// The episode is not among those the evaluation plays.
    #[error("episode {episode} is out of range: an evaluation of {episodes} episodes plays 0..{episodes}")]
    OutOfRange {
        /// The episode asked for.
        episode: u64,
        /// Episodes of the evaluation.
        episodes: usize,
    },
    /// The env refused the configuration or a step.
    #[error(transparent)]
    Env(#[from] EnvError),
}

/// How the controller reaches episode `k`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Warmup {
    /// A fresh controller: exact for controllers whose episodes depend only
    /// on the seed and the episode (planners, random, greedy policies).
    Fresh,
    /// The controller plays episodes `0..k` first, as a one-job evaluation
    /// does: exact for controllers that carry state across episodes (a
    /// sampling policy's random stream).
    Preceding,
}

/// Plays episode `episode` of `spec` with a controller made by `make` and
/// records it.
///
/// ```
/// use buridan_eval::replay::{record_episode, Warmup};
/// use buridan_eval::{evaluate, EvalSpec, RandomController};
/// let map = std::sync::Arc::new(buridan_env::Map::load("rm-1.1").unwrap());
/// let spec = EvalSpec { agents: 2, episodes: 3, ..EvalSpec::default() };
/// let make = || -> Box<dyn buridan_eval::Controller> { Box::new(RandomController::new(42)) };
/// let trace = record_episode(&map, &spec, &make, 2, Warmup::Fresh).unwrap();
/// let report = evaluate(&map, &spec, &make, &|_| {}).unwrap();
/// assert_eq!(trace.record.timesteps, report.records[2].timesteps);
/// assert_eq!(trace.snapshots.len() as u32, trace.record.timesteps + 1);
/// assert!(record_episode(&map, &spec, &make, 3, Warmup::Fresh).is_err());
/// ```
pub fn record_episode(
    map: &Arc<Map>,
    spec: &EvalSpec,
    make: &dyn Fn() -> Box<dyn Controller>,
    episode: u64,
    warmup: Warmup,
) -> Result<Trace, ReplayError> {
    if episode >= spec.episodes as u64 {
        return Err(ReplayError::OutOfRange {
            episode,
            episodes: spec.episodes,
        });
    }
    let mut controller = make();
    let cfg = episode_config(spec, controller.as_ref());
    let mut env = GridEnv::new(map.clone(), cfg)?;
    if warmup == Warmup::Preceding {
        for e in 0..episode {
            run_episode(&mut env, controller.as_mut(), e)?;
        }
    }
    let mut snapshots = Vec::new();
    let mut goals = Vec::new();
    let record = run_episode_observed(&mut env, controller.as_mut(), episode, &mut |env| {
        if goals.is_empty() {
            goals = env.goals();
        }
        snapshots.push(snapshot(env));
    })?;
    Ok(Trace {
        map: map.name.clone(),
        controller: controller.name(),
        seed: spec.seed,
        episode,
        height: map.grid.height(),
        width: map.grid.width(),
        walls: map.grid.walls().to_vec(),
        goals,
        t_max: spec.t_max,
        snapshots,
        record,
    })
}

fn snapshot(env: &GridEnv) -> Snapshot {
    let monitor = env.monitor();
    let marks = (0..env.agents())
        .map(|i| match monitor.state(i) {
            AgentState::Deadlocked => Mark::Deadlocked,
            AgentState::Livelocked => Mark::Livelocked,
            AgentState::Free if env.at_goal(i) => Mark::AtGoal,
            AgentState::Free if monitor.is_stuck(i) => Mark::Stuck,
            AgentState::Free => Mark::Free,
        })
        .collect();
    Snapshot {
        t: env.t(),
        positions: env.positions(),
        marks,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{evaluate, RandomController};

    /// rm-2.1 and an evaluation of `episodes` episodes with `agents` agents.
    fn rm21(agents: usize, episodes: usize) -> (Arc<Map>, EvalSpec) {
        let map = Arc::new(Map::load("rm-2.1").unwrap());
        let spec = EvalSpec {
            agents,
            episodes,
            ..EvalSpec::default()
        };
        (map, spec)
    }

    fn random() -> Box<dyn Controller> {
        Box::new(RandomController::new(42))
    }

    #[test]
    fn every_episode_matches_the_harness() {
        let (map, spec) = rm21(6, 4);
        let report = evaluate(&map, &spec, &random, &|_| {}).unwrap();
        for r in &report.records {
            let trace = record_episode(&map, &spec, &random, r.episode, Warmup::Fresh).unwrap();
            let mut got = trace.record.clone();
            got.compute_ms = r.compute_ms;
            assert_eq!(&got, r);
            assert_eq!(trace.goals.len(), 6);
            let last = trace.snapshots.last().unwrap();
            assert_eq!(last.t, r.timesteps);
            let at_goal = last.marks.iter().filter(|m| **m == Mark::AtGoal).count();
            assert_eq!(r.success, at_goal == 6);
        }
    }

    #[test]
    fn a_random_crowd_shows_stuck_agents() {
        let (map, spec) = rm21(16, 1);
        let trace = record_episode(&map, &spec, &random, 0, Warmup::Preceding).unwrap();
        assert!(trace
            .snapshots
            .iter()
            .flat_map(|s| &s.marks)
            .any(|m| *m != Mark::Free && *m != Mark::AtGoal));
    }
}
