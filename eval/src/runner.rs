//! Runs a controller on the env's seeded episodes and records what happened.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use buridan_env::{EnvConfig, EnvError, GridEnv, Map, Starts};

use crate::controller::Controller;
use crate::stats::BoxStats;

/// What to evaluate on.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct EvalSpec {
    /// Number of agents.
    pub agents: usize,
    /// Episodes `0..episodes` of the seeded generator.
    pub episodes: usize,
    /// Seed of the episode generator.
    pub seed: u64,
    /// Random or the map's fixed scenario.
    pub starts: Starts,
    /// Truncation step count.
    pub t_max: u32,
    /// Episodes run in parallel (each on its own controller instance).
    pub jobs: usize,
}

impl Default for EvalSpec {
    fn default() -> Self {
        Self {
            agents: 4,
            episodes: 100,
            seed: 42,
            starts: Starts::Random,
            t_max: 100,
            jobs: 1,
        }
    }
}

/// One evaluated episode: a CSV row.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct EpisodeRecord {
    /// Episode index.
    pub episode: u64,
    /// All agents on their goals before `T_max`.
    pub success: bool,
    /// Steps taken in the env (the makespan on success).
    pub timesteps: u32,
    /// Σ over agents of the step of its final arrival at its goal (on success).
    pub sum_of_costs: Option<u32>,
    /// Episode reward summed over agents.
    pub reward: f32,
    /// Time spent in the controller (planning and acting), milliseconds.
    pub compute_ms: f64,
    /// Why the controller gave up, if it did (then the env is not stepped).
    pub gave_up: Option<String>,
    /// Plan makespan, for planners (may exceed `T_max`).
    pub plan_makespan: Option<u32>,
    /// Plan sum of costs, for planners.
    pub plan_sum_of_costs: Option<u32>,
    /// Failed move requests.
    pub blocked_moves: u32,
    /// Steps with a deadlocked agent (definitions in [`buridan_env::monitor`]:
    /// stuck for `k` steps, waiting only on agents that are stuck or parked
    /// on their goals, and not moving).
    pub deadlock_steps: u32,
    /// Steps with a livelocked agent (jammed the same way, but moving).
    pub livelock_steps: u32,
    /// Times an agent became deadlocked.
    pub deadlock_events: u32,
    /// Agents deadlocked at least once.
    pub deadlocked_agents: u32,
    /// Each agent's deadlocked steps, space-separated in agent order.
    #[serde(serialize_with = "space_separated")]
    pub deadlock_steps_per_agent: Vec<u32>,
    /// Each agent's livelocked steps, space-separated in agent order.
    #[serde(serialize_with = "space_separated")]
    pub livelock_steps_per_agent: Vec<u32>,
    /// Agents deadlocked or livelocked after the last step: the episode
    /// ended in a jam.
    pub jammed_at_end: u32,
    /// Agents stuck after the last step (off their goals, no progress for
    /// `k` steps), jammed or on their own.
    pub stuck_at_end: u32,
    /// Plans a rescuing controller followed to end a jam (empty for others).
    pub rescues: Option<u32>,
}

/// Writes `[3, 0, 5]` as `"3 0 5"`: one CSV cell, and still readable in JSON.
fn space_separated<S: serde::Serializer>(values: &[u32], s: S) -> Result<S::Ok, S::Error> {
    let text = values
        .iter()
        .map(u32::to_string)
        .collect::<Vec<_>>()
        .join(" ");
    s.serialize_str(&text)
}

/// Aggregate of one evaluation: the JSON summary.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct EvalSummary {
    /// Controller name.
    pub controller: String,
    /// Map name.
    pub map: String,
    /// Agents per episode.
    pub agents: usize,
    /// Episodes evaluated.
    pub episodes: usize,
    /// Seed of the episode generator.
    pub seed: u64,
    /// Fraction of episodes solved within `T_max`.
    pub success_rate: f64,
    /// Fraction of episodes for which the controller produced a plan (planners:
    /// found within the time limit, whatever its makespan).
    pub planned_rate: f64,
    /// Median timesteps of successful episodes.
    pub timesteps_median: Option<f64>,
    /// First quartile of timesteps of successful episodes.
    pub timesteps_q1: Option<f64>,
    /// Third quartile of timesteps of successful episodes.
    pub timesteps_q3: Option<f64>,
    /// Box-plot statistics of the timesteps of successful episodes.
    pub timesteps_box: Option<BoxStats>,
    /// Mean sum of costs of successful episodes.
    pub sum_of_costs_mean: Option<f64>,
    /// Median compute time per instance, milliseconds.
    pub compute_ms_median: Option<f64>,
    /// Mean compute time per instance, milliseconds.
    pub compute_ms_mean: f64,
    /// Mean episode reward.
    pub reward_mean: f64,
    /// Episodes the controller gave up on, by reason.
    pub gave_up: std::collections::BTreeMap<String, usize>,
    /// Mean steps with a deadlocked agent per episode.
    pub deadlock_steps_mean: f64,
    /// Mean steps with a livelocked agent per episode.
    pub livelock_steps_mean: f64,
    /// Fraction of episodes with at least one deadlocked step.
    pub deadlock_episode_rate: f64,
    /// Failed episodes (the controller played, `T_max` reached) that ended
    /// in a jam: some agent deadlocked or livelocked at the last step.
    pub failures_ending_jammed: usize,
    /// Failed episodes that ended with agents stuck, but none in a jam
    /// (stuck on their own: the policy's failure, not a deadlock).
    pub failures_ending_stuck_alone: usize,
    /// Wall time of the whole evaluation, seconds.
    pub wall_seconds: f64,
}

/// Everything an evaluation produced.
#[derive(Debug, Clone)]
pub struct EvalReport {
    /// One record per episode, in episode order.
    pub records: Vec<EpisodeRecord>,
    /// The aggregate.
    pub summary: EvalSummary,
    /// Visit counts per cell over all episodes (row-major).
    pub visits: Vec<u64>,
}

/// Evaluates controllers made by `make` on episodes `0..spec.episodes`.
/// `on_episode` is called after each episode (e.g. to advance a progress bar).
///
/// ```
/// use buridan_eval::{evaluate, EvalSpec, RandomController};
/// let map = std::sync::Arc::new(buridan_env::Map::load("rm-1.1").unwrap());
/// let spec = EvalSpec { agents: 2, episodes: 3, ..EvalSpec::default() };
/// let report = evaluate(&map, &spec, &|| Box::new(RandomController::new(1)), &|_| {}).unwrap();
/// assert_eq!(report.records.len(), 3);
/// ```
pub fn evaluate(
    map: &Arc<Map>,
    spec: &EvalSpec,
    make: &(dyn Fn() -> Box<dyn Controller> + Sync),
    on_episode: &(dyn Fn(&EpisodeRecord) + Sync),
) -> Result<EvalReport, EnvError> {
    let started = Instant::now();
    let cfg = episode_config(spec, make().as_ref());
    // Fail early, on the caller's thread, for bad configurations.
    GridEnv::new(map.clone(), cfg.clone())?;
    let next = AtomicUsize::new(0);
    let results = Mutex::new(Vec::with_capacity(spec.episodes));
    let cells = map.grid.height() * map.grid.width();
    let visits = Mutex::new(vec![0u64; cells]);
    let mut name = String::new();
    std::thread::scope(|scope| -> Result<(), EnvError> {
        let workers: Vec<_> = (0..spec.jobs.max(1))
            .map(|_| {
                scope.spawn(|| -> Result<String, EnvError> {
                    let mut controller = make();
                    let mut env = GridEnv::new(map.clone(), cfg.clone())?;
                    env.clear_visits();
                    loop {
                        let e = next.fetch_add(1, Ordering::Relaxed);
                        if e >= spec.episodes {
                            break;
                        }
                        let record = run_episode(&mut env, controller.as_mut(), e as u64)?;
                        on_episode(&record);
                        results
                            .lock()
                            .expect("no panics while holding the lock")
                            .push(record);
                    }
                    let mut v = visits.lock().expect("no panics while holding the lock");
                    for (t, &x) in v.iter_mut().zip(env.visits()) {
                        *t += x;
                    }
                    Ok(controller.name())
                })
            })
            .collect();
        for w in workers {
            name = w.join().expect("evaluation worker panicked")?;
        }
        Ok(())
    })?;
    let mut records = results.into_inner().expect("lock not poisoned");
    records.sort_by_key(|r| r.episode);
    let summary = summarize(&name, &map.name, spec, &records, started.elapsed());
    Ok(EvalReport {
        records,
        summary,
        visits: visits.into_inner().expect("lock not poisoned"),
    })
}

/// The env configuration of [`evaluate`]'s episodes for `spec`: the env
/// writes what `controller` reads (a policy's window and features).
///
/// ```
/// use buridan_eval::{runner::episode_config, EvalSpec, RandomController};
/// let spec = EvalSpec { agents: 3, seed: 7, ..EvalSpec::default() };
/// let cfg = episode_config(&spec, &RandomController::new(7));
/// assert_eq!((cfg.agents, cfg.seed, cfg.t_max), (3, 7, 100));
/// ```
pub fn episode_config(spec: &EvalSpec, controller: &dyn Controller) -> EnvConfig {
    EnvConfig {
        agents: spec.agents,
        t_max: spec.t_max,
        starts: spec.starts,
        seed: spec.seed,
        sensor_range: controller.obs_sensor_range(),
        features: controller.obs_features(),
        ..EnvConfig::default()
    }
}

/// Plays one episode with `controller`, timing its calls.
pub fn run_episode(
    env: &mut GridEnv,
    controller: &mut dyn Controller,
    episode: u64,
) -> Result<EpisodeRecord, EnvError> {
    run_episode_observed(env, controller, episode, &mut |_| {})
}

/// Plays one episode as [`run_episode`] does, showing `observe` the env
/// after the reset (once the controller has prepared) and after every step:
/// how a replay records what happened.
pub fn run_episode_observed(
    env: &mut GridEnv,
    controller: &mut dyn Controller,
    episode: u64,
    observe: &mut dyn FnMut(&GridEnv),
) -> Result<EpisodeRecord, EnvError> {
    env.reset_to(episode)?;
    let n = env.agents();
    let mut compute = Duration::ZERO;
    let t0 = Instant::now();
    let prepared = controller.begin_episode(env);
    compute += t0.elapsed();
    let notes = controller.episode_notes();
    observe(env);
    if let Err(why) = prepared {
        return Ok(EpisodeRecord {
            episode,
            success: false,
            timesteps: 0,
            sum_of_costs: None,
            reward: 0.0,
            compute_ms: compute.as_secs_f64() * 1e3,
            gave_up: Some(why.to_string()),
            plan_makespan: notes.plan_makespan,
            plan_sum_of_costs: notes.plan_sum_of_costs,
            blocked_moves: 0,
            deadlock_steps: 0,
            livelock_steps: 0,
            deadlock_events: 0,
            deadlocked_agents: 0,
            deadlock_steps_per_agent: vec![0; n],
            livelock_steps_per_agent: vec![0; n],
            jammed_at_end: 0,
            stuck_at_end: 0,
            rescues: notes.rescues,
        });
    }
    let mut actions = vec![0u8; n];
    let mut rewards = vec![0.0f32; n];
    let mut arrival = vec![0u32; n];
    loop {
        let t0 = Instant::now();
        controller.act(env, &mut actions);
        compute += t0.elapsed();
        let out = env.step(&actions, &mut rewards)?;
        controller.after_step(&rewards);
        observe(env);
        for (i, a) in arrival.iter_mut().enumerate() {
            if !env.at_goal(i) {
                // Still off its goal after step t: it arrives at t + 1 at the earliest.
                *a = env.t() + 1;
            }
        }
        if out.done() {
            break;
        }
    }
    let stats = env.stats();
    let monitor = env.monitor();
    Ok(EpisodeRecord {
        episode,
        success: stats.success,
        timesteps: stats.length,
        // An agent's cost is the step after which it never left its goal again.
        sum_of_costs: stats.success.then(|| arrival.iter().sum()),
        reward: stats.reward,
        compute_ms: compute.as_secs_f64() * 1e3,
        gave_up: None,
        plan_makespan: notes.plan_makespan,
        plan_sum_of_costs: notes.plan_sum_of_costs,
        blocked_moves: stats.blocked_moves,
        deadlock_steps: stats.deadlock_steps,
        livelock_steps: stats.livelock_steps,
        deadlock_events: stats.deadlock_events,
        deadlocked_agents: monitor.deadlocked_agents() as u32,
        deadlock_steps_per_agent: monitor.agent_deadlock_steps().to_vec(),
        livelock_steps_per_agent: monitor.agent_livelock_steps().to_vec(),
        jammed_at_end: (monitor.deadlocked() + monitor.livelocked()) as u32,
        stuck_at_end: monitor.stuck() as u32,
        rescues: controller.episode_notes().rescues,
    })
}

fn summarize(
    controller: &str,
    map: &str,
    spec: &EvalSpec,
    records: &[EpisodeRecord],
    wall: Duration,
) -> EvalSummary {
    let n = records.len().max(1) as f64;
    let solved: Vec<&EpisodeRecord> = records.iter().filter(|r| r.success).collect();
    let steps: Vec<f64> = solved.iter().map(|r| f64::from(r.timesteps)).collect();
    let timesteps_box = BoxStats::of(&steps);
    let compute: Vec<f64> = records.iter().map(|r| r.compute_ms).collect();
    let soc: Vec<f64> = solved
        .iter()
        .filter_map(|r| r.sum_of_costs)
        .map(f64::from)
        .collect();
    let played_failures: Vec<&EpisodeRecord> = records
        .iter()
        .filter(|r| !r.success && r.gave_up.is_none())
        .collect();
    let mut gave_up = std::collections::BTreeMap::new();
    for why in records.iter().filter_map(|r| r.gave_up.clone()) {
        *gave_up.entry(why).or_insert(0) += 1;
    }
    let mean = |v: &[f64]| {
        if v.is_empty() {
            None
        } else {
            Some(v.iter().sum::<f64>() / v.len() as f64)
        }
    };
    EvalSummary {
        controller: controller.to_string(),
        map: map.to_string(),
        agents: spec.agents,
        episodes: records.len(),
        seed: spec.seed,
        success_rate: solved.len() as f64 / n,
        planned_rate: records.iter().filter(|r| r.gave_up.is_none()).count() as f64 / n,
        timesteps_median: timesteps_box.map(|b| b.median),
        timesteps_q1: timesteps_box.map(|b| b.q1),
        timesteps_q3: timesteps_box.map(|b| b.q3),
        timesteps_box,
        sum_of_costs_mean: mean(&soc),
        compute_ms_median: BoxStats::of(&compute).map(|b| b.median),
        compute_ms_mean: mean(&compute).unwrap_or(0.0),
        reward_mean: records.iter().map(|r| f64::from(r.reward)).sum::<f64>() / n,
        gave_up,
        deadlock_steps_mean: records
            .iter()
            .map(|r| f64::from(r.deadlock_steps))
            .sum::<f64>()
            / n,
        livelock_steps_mean: records
            .iter()
            .map(|r| f64::from(r.livelock_steps))
            .sum::<f64>()
            / n,
        deadlock_episode_rate: records.iter().filter(|r| r.deadlock_steps > 0).count() as f64 / n,
        failures_ending_jammed: played_failures
            .iter()
            .filter(|r| r.jammed_at_end > 0)
            .count(),
        failures_ending_stuck_alone: played_failures
            .iter()
            .filter(|r| r.jammed_at_end == 0 && r.stuck_at_end > 0)
            .count(),
        wall_seconds: wall.as_secs_f64(),
    }
}
