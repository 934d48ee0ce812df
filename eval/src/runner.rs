//! Runs a controller on the env's seeded episodes and records what happened.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use buridan_env::{Cell, EnvConfig, EnvError, Grid, GridEnv, Map, Rules, Scenario, Starts};

use crate::controller::Controller;
use crate::instances::Instance;
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
    /// The rule set the env moves agents by (thesis by default). `t_max`
    /// is set separately: [`Rules::default_t_max`] is the rule set's own.
    pub rules: Rules,
    /// Execution delays: the probability that an agent fails to carry out
    /// its move in a step ([`buridan_env::EnvConfig::delay`]; 0, the
    /// default: none). Controllers see the positions that resulted.
    pub delay: f32,
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
            rules: Rules::Thesis,
            delay: 0.0,
        }
    }
}

/// Whether a delay is off (then the summary leaves it out).
fn is_zero(p: &f32) -> bool {
    *p == 0.0
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
    /// Agent-steps whose action was not the policy's first choice, for a
    /// policy through the collision shield (empty for others): of
    /// `agents × timesteps`, the moves that were not the policy's own.
    pub overridden: Option<u32>,
    /// The `.scen` file of an instance set's episode (empty for generated
    /// episodes).
    pub instance: Option<String>,
    /// Sum of costs in POGEMA's sense, for every episode: each agent's cost
    /// is the step (1-based) at which it last arrived on its goal and
    /// stayed, `T_max` if it is off its goal at the end
    /// ([`GridEnv::cost`]). An episode given up on counts as every agent
    /// waiting until `T_max`.
    pub soc: u64,
    /// Makespan in POGEMA's sense: the largest of those costs.
    pub makespan: u32,
    /// The single-agent lower bound of the SoC: Σ shortest-path distances
    /// from starts to goals (empty if some goal is unreachable).
    pub soc_lower_bound: Option<u64>,
    /// Fraction of agents on their goals at the end (POGEMA's ISR).
    pub isr: f64,
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

/// Aggregate of one evaluation: the JSON summary (read back by reports;
/// fields an older file lacks take their defaults).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
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
    /// The rule set the env moved agents by.
    pub rules: Rules,
    /// Truncation step count `T_max`.
    pub t_max: u32,
    /// The execution delays' probability ([`EvalSpec::delay`]; left out
    /// of the file when 0).
    #[serde(skip_serializing_if = "is_zero")]
    pub delay: f32,
    /// Episodes that came from `.scen` files (0: the seeded generator's).
    pub instances: usize,
    /// Worst compute time per instance, milliseconds.
    pub compute_ms_max: f64,
    /// Mean POGEMA sum of costs over all episodes (agents off their goals
    /// at the end cost `T_max`; see [`EpisodeRecord::soc`]).
    pub soc_mean: f64,
    /// Mean POGEMA makespan over all episodes.
    pub makespan_mean: f64,
    /// Median of SoC over its lower bound, over all episodes with a
    /// positive bound.
    pub soc_ratio_median: Option<f64>,
    /// Mean of SoC over its lower bound, over the same episodes.
    pub soc_ratio_mean: Option<f64>,
    /// Median of SoC over its lower bound, over successful episodes.
    pub soc_ratio_median_solved: Option<f64>,
    /// Mean fraction of agents on their goals at the end (ISR).
    pub isr_mean: f64,
}

/// Everything an evaluation produced.
#[derive(Debug, Clone)]
pub struct EvalReport {
    /// One record per episode, in episode order.
    pub records: Vec<EpisodeRecord>,
    /// The aggregate.
    pub summary: EvalSummary,
    /// Visit counts per cell over all episodes (row-major; empty for a
    /// report [merged](Self::merge) over several maps).
    pub visits: Vec<u64>,
}

impl EvalReport {
    /// One report of the evaluations of one controller with one `spec` on
    /// several maps (an instance set spread over maps, as POGEMA's mazes
    /// with one instance per map and count): every record, in the order
    /// given, and the summary over all of them under the name `map`. The
    /// maps' cells differ, so the report holds no visit counts.
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_eval::{evaluate, EvalReport, EvalSpec, RandomController};
    /// let spec = EvalSpec { agents: 2, episodes: 2, ..EvalSpec::default() };
    /// let run = |id| {
    ///     let map = Arc::new(buridan_env::Map::load(id).unwrap());
    ///     evaluate(&map, &spec, &|| Box::new(RandomController::new(1)), &|_| {}).unwrap()
    /// };
    /// let merged = EvalReport::merge("two maps", &spec, vec![run("rm-1.1"), run("rm-2.1")]);
    /// assert_eq!((merged.records.len(), merged.summary.episodes), (4, 4));
    /// assert_eq!(merged.summary.map, "two maps");
    /// assert!(merged.visits.is_empty());
    /// ```
    pub fn merge(map: &str, spec: &EvalSpec, reports: Vec<EvalReport>) -> EvalReport {
        let controller = reports
            .first()
            .map(|r| r.summary.controller.clone())
            .unwrap_or_default();
        let wall: f64 = reports.iter().map(|r| r.summary.wall_seconds).sum();
        let instances = reports.iter().map(|r| r.summary.instances).sum();
        let records: Vec<EpisodeRecord> = reports.into_iter().flat_map(|r| r.records).collect();
        let mut summary = summarize(
            &controller,
            map,
            spec,
            &records,
            Duration::from_secs_f64(wall),
        );
        summary.instances = instances;
        EvalReport {
            records,
            summary,
            visits: Vec::new(),
        }
    }
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
    evaluate_on(map, spec, None, make, on_episode)
}

/// Evaluates controllers made by `make` on `instances` (an instance set,
/// [`crate::instances`]): episode `e` starts from instance `e`'s starts and
/// goals, and its record names the instance. `spec.episodes` and
/// `spec.starts` are not used; `spec.agents` must be the instances'.
///
/// ```
/// use buridan_env::Cell;
/// use buridan_eval::{evaluate_instances, instances::Instance, EvalSpec};
/// let map = std::sync::Arc::new(buridan_env::Map::load("rm-1.1").unwrap());
/// let inst = |name: &str, start: usize| Instance {
///     name: name.into(), path: name.into(),
///     starts: vec![Cell::new(1, start)], goals: vec![Cell::new(1, start + 2)],
/// };
/// let spec = EvalSpec { agents: 1, rules: buridan_env::Rules::Pogema, t_max: 128, ..EvalSpec::default() };
/// let make = || -> Box<dyn buridan_eval::Controller> {
///     Box::new(buridan_eval::planner::PlannerController::new(
///         buridan_mapf::planner_for_rules("lacam", buridan_env::Rules::Pogema).unwrap().into(),
///         Default::default(),
///     ))
/// };
/// let report = evaluate_instances(&map, &spec, &[inst("a.scen", 0), inst("b.scen", 3)], &make, &|_| {}).unwrap();
/// assert_eq!(report.records[1].instance.as_deref(), Some("b.scen"));
/// assert_eq!((report.records[1].soc, report.records[1].soc_lower_bound), (2, Some(2)));
/// assert_eq!((report.summary.success_rate, report.summary.soc_ratio_median), (1.0, Some(1.0)));
/// ```
pub fn evaluate_instances(
    map: &Arc<Map>,
    spec: &EvalSpec,
    instances: &[Instance],
    make: &(dyn Fn() -> Box<dyn Controller> + Sync),
    on_episode: &(dyn Fn(&EpisodeRecord) + Sync),
) -> Result<EvalReport, EnvError> {
    evaluate_on(map, spec, Some(instances), make, on_episode)
}

fn evaluate_on(
    map: &Arc<Map>,
    spec: &EvalSpec,
    instances: Option<&[Instance]>,
    make: &(dyn Fn() -> Box<dyn Controller> + Sync),
    on_episode: &(dyn Fn(&EpisodeRecord) + Sync),
) -> Result<EvalReport, EnvError> {
    let started = Instant::now();
    let mut cfg = episode_config(spec, make().as_ref());
    let episodes = instances.map_or(spec.episodes, <[Instance]>::len);
    // An instance set's map need not hold 2n random cells: the env starts
    // from the first instance (as a fixed scenario), each episode from its own.
    let map = match instances.and_then(<[Instance]>::first) {
        Some(first) => {
            cfg.starts = Starts::Fixed;
            let mut with_scenario = Map::clone(map);
            with_scenario.scenario = Some(Scenario {
                starts: first.starts.clone(),
                goals: first.goals.clone(),
            });
            Arc::new(with_scenario)
        }
        None => map.clone(),
    };
    let map = &map;
    // Fail early, on the caller's thread, for bad configurations.
    GridEnv::new(map.clone(), cfg.clone())?;
    let next = AtomicUsize::new(0);
    let results = Mutex::new(Vec::with_capacity(episodes));
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
                        if e >= episodes {
                            break;
                        }
                        let record = match instances {
                            Some(set) => {
                                let inst = &set[e];
                                env.reset_with(e as u64, &inst.starts, &inst.goals)?;
                                let mut record = play_episode(
                                    &mut env,
                                    controller.as_mut(),
                                    e as u64,
                                    &mut |_| {},
                                )?;
                                record.instance = Some(inst.name.clone());
                                record
                            }
                            None => run_episode(&mut env, controller.as_mut(), e as u64)?,
                        };
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
    let mut summary = summarize(&name, &map.name, spec, &records, started.elapsed());
    summary.instances = instances.map_or(0, <[Instance]>::len);
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
/// assert_eq!((cfg.agents, cfg.seed, cfg.t_max, cfg.rules), (3, 7, 100, buridan_env::Rules::Thesis));
/// ```
pub fn episode_config(spec: &EvalSpec, controller: &dyn Controller) -> EnvConfig {
    EnvConfig {
        agents: spec.agents,
        t_max: spec.t_max,
        rules: spec.rules,
        starts: spec.starts,
        seed: spec.seed,
        sensor_range: controller.obs_sensor_range(),
        features: controller.obs_features(),
        delay: spec.delay,
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
    play_episode(env, controller, episode, observe)
}

/// The single-agent lower bound of the sum of costs of `env`'s episode:
/// The single-agent lower bound of an instance's sum of costs: Σ
/// shortest-path distances from each start to its goal on `grid`, `None`
/// if some goal is unreachable.
///
/// ```
/// use buridan_env::{Cell, Grid};
/// let grid = Grid::from_rows(&["...", ".@.", "..."]).unwrap();
/// let (a, b) = (Cell::new(0, 1), Cell::new(2, 1));
/// // Around the pillar, both ways: 4 steps each.
/// assert_eq!(buridan_eval::runner::soc_lower_bound(&grid, &[a, b], &[b, a]), Some(8));
/// let walled = Grid::from_rows(&[".@."]).unwrap();
/// assert_eq!(buridan_eval::runner::soc_lower_bound(&walled, &[Cell::new(0, 0)], &[Cell::new(0, 2)]), None);
/// ```
pub fn soc_lower_bound(grid: &Grid, starts: &[Cell], goals: &[Cell]) -> Option<u64> {
    starts
        .iter()
        .zip(goals)
        .map(|(&start, &goal)| {
            let d = grid.distances_to(goal)[grid.index(start)];
            (d != buridan_env::map::UNREACHABLE).then_some(u64::from(d))
        })
        .sum()
}

/// Plays `env`'s freshly reset episode with `controller` (see
/// [`run_episode_observed`]).
fn play_episode(
    env: &mut GridEnv,
    controller: &mut dyn Controller,
    episode: u64,
    observe: &mut dyn FnMut(&GridEnv),
) -> Result<EpisodeRecord, EnvError> {
    let n = env.agents();
    let lower_bound = soc_lower_bound(&env.map().grid, &env.positions(), &env.goals());
    let mut compute = Duration::ZERO;
    let t0 = Instant::now();
    let prepared = controller.begin_episode(env);
    compute += t0.elapsed();
    let notes = controller.episode_notes();
    observe(env);
    if let Err(why) = prepared {
        // As if every agent waited until T_max: those on their goals from
        // the start cost 1 (POGEMA's first step), the others T_max.
        let t_max = env.config().t_max;
        let costs: Vec<u32> = (0..n)
            .map(|i| if env.at_goal(i) { 1 } else { t_max })
            .collect();
        let on_goal = (0..n).filter(|&i| env.at_goal(i)).count();
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
            overridden: notes.overridden,
            instance: None,
            soc: costs.iter().map(|&c| u64::from(c)).sum(),
            makespan: costs.iter().copied().max().unwrap_or(0),
            soc_lower_bound: lower_bound,
            isr: on_goal as f64 / n.max(1) as f64,
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
        overridden: controller.episode_notes().overridden,
        instance: None,
        soc: env.sum_of_costs(),
        makespan: env.makespan(),
        soc_lower_bound: lower_bound,
        isr: f64::from(stats.agents_at_goal) / n.max(1) as f64,
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
    let ratio = |r: &&EpisodeRecord| match r.soc_lower_bound {
        Some(lb) if lb > 0 => Some(r.soc as f64 / lb as f64),
        _ => None,
    };
    let ratios: Vec<f64> = records.iter().filter_map(|r| ratio(&r)).collect();
    let solved_ratios: Vec<f64> = solved.iter().filter_map(ratio).collect();
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
        rules: spec.rules,
        t_max: spec.t_max,
        delay: spec.delay,
        instances: 0,
        compute_ms_max: compute.iter().copied().fold(0.0, f64::max),
        soc_mean: records.iter().map(|r| r.soc as f64).sum::<f64>() / n,
        makespan_mean: records.iter().map(|r| f64::from(r.makespan)).sum::<f64>() / n,
        soc_ratio_median: BoxStats::of(&ratios).map(|b| b.median),
        soc_ratio_mean: mean(&ratios),
        soc_ratio_median_solved: BoxStats::of(&solved_ratios).map(|b| b.median),
        isr_mean: records.iter().map(|r| r.isr).sum::<f64>() / n,
    }
}
