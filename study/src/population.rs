//! The population-based training driver (Jaderberg et al. 2017, in its
//! synchronous form): the population trains in rounds of `interval_steps`
//! env steps up to `steps_per_trial`, `parallel` members at once; after each
//! round but the last, [`exploit_and_explore`] moves the bottom quantile
//! onto copies of top members' checkpoints with perturbed hyperparameters.
//!
//! Each member-round trains in a run directory of its own
//! (`trials/NNNN/round-RRR`, [`round_dir`]) that nothing writes once the
//! round is over. Copying a checkpoint is therefore starting the next round
//! from that directory ([`TrialSpec::start_from`], `learner train --resume
//! DIR` semantics): the copy stays valid while its source trains on, and a
//! killed study continues from its last finished round. Rounds before the
//! last rank members by training success (measured at every update, free);
//! the last round measures the study's objective.

use std::collections::VecDeque;
use std::path::Path;
use std::sync::{Mutex, MutexGuard};
use std::time::Instant;

use crate::config::StudyConfig;
use crate::lineage::{round_dir, Exploitation, PbtMember, PbtState};
use crate::objective::{Measurement, Objective};
use crate::runner::{run_caught, Reporter, TrialError, TrialRunner, TrialSpec};
use crate::scheduler::pbt::{exploit_and_explore, Member, PbtConfig};
use crate::scheduler::{Decision, SchedulerKind};
use crate::state::{Report, StudyState, TrialRecord, TrialStatus};
use crate::study::{save_state, Clock, StudyError, REPORT_SAVE_SECONDS};

/// Rounds of `interval` env steps in a budget of `steps` (the last may be shorter).
///
/// ```
/// assert_eq!(buridan_study::population::rounds(10_000, 3_000), 4);
/// assert_eq!(buridan_study::population::rounds(9_000, 3_000), 3);
/// ```
pub fn rounds(steps: u64, interval: u64) -> u32 {
    steps.div_ceil(interval.max(1)) as u32
}

/// The env-step budget at the end of round `round` (0-based).
///
/// ```
/// assert_eq!(buridan_study::population::round_end(3, 10_000, 3_000), 10_000);
/// assert_eq!(buridan_study::population::round_end(0, 10_000, 3_000), 3_000);
/// ```
pub fn round_end(round: u32, steps: u64, interval: u64) -> u64 {
    (u64::from(round) + 1).saturating_mul(interval).min(steps)
}

/// Runs a PBT study's remaining rounds; returns the member-rounds started.
pub(crate) fn run(
    dir: &Path,
    config: &StudyConfig,
    state: &mut StudyState,
    runner: &dyn TrialRunner,
) -> Result<usize, StudyError> {
    let (SchedulerKind::Pbt { interval_steps, .. }, Some(explore)) =
        (&config.scheduler, config.scheduler.pbt())
    else {
        return Ok(0);
    };
    if state.pbt.is_none() {
        populate(config, state);
    }
    let shared = Shared {
        inner: Mutex::new(Inner {
            state: state.clone(),
            queue: VecDeque::new(),
            failure: None,
            started_now: 0,
            last_save: Instant::now(),
        }),
        dir,
        config,
        clock: Clock::new(state.wall_seconds, config.wall_time),
        interval: *interval_steps,
        rounds: rounds(config.steps_per_trial, *interval_steps),
    };
    shared.save(&mut shared.lock());
    drive(&shared, runner, &explore);
    let inner = shared.inner.into_inner().unwrap_or_else(|e| e.into_inner());
    *state = inner.state;
    match inner.failure {
        Some(e) => Err(e),
        None => Ok(inner.started_now),
    }
}

/// The initial population: the sampler's first `trials` configurations.
fn populate(config: &StudyConfig, state: &mut StudyState) {
    let sampler = config.sampler.build(config.seed, config.grid_points);
    let mut pbt = PbtState::new(0);
    for id in 0..config.trials {
        let Some(overrides) = sampler.suggest(&config.space, id, &[]) else {
            break;
        };
        let mut record = TrialRecord::new(id, overrides);
        record.run_dir = round_dir(id, 0);
        state.trials.push(record);
        pbt.members.push(PbtMember::default());
    }
    state.pbt = Some(pbt);
}

struct Inner {
    state: StudyState,
    /// Members still to train in the current round.
    queue: VecDeque<u64>,
    failure: Option<StudyError>,
    started_now: usize,
    last_save: Instant,
}

struct Shared<'a> {
    inner: Mutex<Inner>,
    dir: &'a Path,
    config: &'a StudyConfig,
    clock: Clock,
    interval: u64,
    rounds: u32,
}

impl Shared<'_> {
    fn lock(&self) -> MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn save(&self, inner: &mut Inner) {
        inner.last_save = Instant::now();
        save_state(self.dir, &self.clock, &mut inner.state, &mut inner.failure);
    }
}

fn pbt(state: &StudyState) -> &PbtState {
    state.pbt.as_ref().expect("a PBT study is populated first")
}

fn live(state: &StudyState) -> impl Iterator<Item = &TrialRecord> {
    state
        .trials
        .iter()
        .filter(|t| t.status != TrialStatus::Failed)
}

/// Round after round until the budget, a failure to save, or the wall time.
fn drive(shared: &Shared<'_>, runner: &dyn TrialRunner, explore: &PbtConfig) {
    loop {
        let round = {
            let mut inner = shared.lock();
            let round = pbt(&inner.state).rounds_done;
            if round >= shared.rounds || inner.failure.is_some() {
                return;
            }
            let members = &pbt(&inner.state).members;
            let queue: VecDeque<u64> = live(&inner.state)
                .filter(|t| members[t.id as usize].rounds == round)
                .map(|t| t.id)
                .collect();
            if live(&inner.state).next().is_none() {
                return;
            }
            inner.queue = queue;
            round
        };
        let threads = shared.config.parallel.max(1);
        std::thread::scope(|s| {
            for _ in 0..threads {
                s.spawn(|| worker(shared, runner, round));
            }
        });
        let mut inner = shared.lock();
        if inner.failure.is_some() {
            return;
        }
        let members = &pbt(&inner.state).members;
        let unfinished = live(&inner.state).any(|t| members[t.id as usize].rounds == round);
        if unfinished {
            // Cut by the wall time: everyone waits for the next session.
            for t in inner.state.trials.iter_mut() {
                if t.status == TrialStatus::Running {
                    t.status = TrialStatus::Interrupted;
                }
            }
            shared.save(&mut inner);
            return;
        }
        end_round(
            shared.config,
            &mut inner.state,
            round,
            shared.rounds,
            explore,
        );
        shared.save(&mut inner);
    }
}

/// After round `round`: every live member's next round starts from its own
/// checkpoint, except the exploiters', which start from their sources'.
fn end_round(
    config: &StudyConfig,
    state: &mut StudyState,
    round: u32,
    rounds: u32,
    explore: &PbtConfig,
) {
    let live: Vec<u64> = live(state).map(|t| t.id).collect();
    let StudyState { trials, pbt, .. } = state;
    let pbt = pbt.as_mut().expect("a PBT study is populated first");
    for &id in &live {
        pbt.members[id as usize].start_from = Some(round_dir(id, round));
    }
    if round + 1 < rounds {
        // Members without a score yet (no finished episode) sit this one out.
        let population: Vec<Member> = live
            .iter()
            .filter_map(|&id| {
                Some(Member {
                    trial: id,
                    score: pbt.members[id as usize].scores[round as usize]?,
                    overrides: trials[id as usize].overrides.clone(),
                })
            })
            .collect();
        let mut rng = round_rng(config.seed, round);
        for e in exploit_and_explore(&population, &config.space, explore, &mut rng) {
            let (to, from) = (e.trial as usize, e.source as usize);
            let r = round as usize;
            pbt.lineage.push(Exploitation {
                round,
                step: pbt.members[from].steps[r],
                trial: e.trial,
                source: e.source,
                trial_score: pbt.members[to].scores[r],
                source_score: pbt.members[from].scores[r],
                overrides: e.overrides.clone(),
            });
            pbt.members[to].start_from = Some(round_dir(e.source, round));
            trials[to].overrides = e.overrides;
        }
    }
    pbt.rounds_done = round + 1;
}

/// The random stream of the exploit after `round`: the same in a resumed study.
fn round_rng(seed: u64, round: u32) -> rand_chacha::ChaCha8Rng {
    crate::sampler::trial_rng(seed ^ 0x9e37_79b9_7f4a_7c15, u64::from(round))
}

fn worker(shared: &Shared<'_>, runner: &dyn TrialRunner, round: u32) {
    loop {
        let spec = {
            let mut inner = shared.lock();
            if inner.failure.is_some() || shared.clock.out_of_time() {
                return;
            }
            let Some(id) = inner.queue.pop_front() else {
                return;
            };
            let spec = start(shared, &mut inner.state, id, round);
            inner.started_now += 1;
            shared.save(&mut inner);
            spec
        };
        let started = Instant::now();
        let mut reporter = MemberReporter {
            shared,
            id: spec.id,
            cut: false,
        };
        let outcome = run_caught(runner, &spec, &mut reporter);
        let cut = reporter.cut;
        let mut inner = shared.lock();
        let seconds = started.elapsed().as_secs_f64();
        finish(
            shared,
            &mut inner.state,
            &spec,
            round,
            outcome,
            cut,
            seconds,
        );
        shared.save(&mut inner);
    }
}

/// Marks member `id` as training round `round` and returns its spec.
fn start(shared: &Shared<'_>, state: &mut StudyState, id: u64, round: u32) -> TrialSpec {
    let (dir, config) = (shared.dir, shared.config);
    let StudyState { trials, pbt, .. } = state;
    let member = &mut pbt.as_mut().expect("populated").members[id as usize];
    let record = &mut trials[id as usize];
    // Started before and not finished: the round continues from its own checkpoint.
    let resume = member.started > member.rounds;
    if !resume {
        member.started = round + 1;
        member.schedule.push(record.overrides.clone());
    }
    record.run_dir = round_dir(id, round);
    record.status = TrialStatus::Running;
    record.starts += 1;
    let last = round + 1 == shared.rounds;
    TrialSpec {
        id,
        overrides: record.overrides.clone(),
        steps: round_end(round, config.steps_per_trial, shared.interval),
        seed: config.seed.wrapping_add(id),
        run_dir: dir.join(&record.run_dir),
        resume,
        start_from: member.start_from.as_ref().map(|p| dir.join(p)),
        objective: if last {
            config.objective
        } else {
            Objective::TrainSuccess
        },
    }
}

/// Books the outcome of member `spec.id`'s round.
fn finish(
    shared: &Shared<'_>,
    state: &mut StudyState,
    spec: &TrialSpec,
    round: u32,
    outcome: Result<Measurement, TrialError>,
    cut: bool,
    seconds: f64,
) {
    let objective = shared.config.objective;
    let StudyState { trials, pbt, .. } = state;
    let member = &mut pbt.as_mut().expect("populated").members[spec.id as usize];
    let record = &mut trials[spec.id as usize];
    record.seconds += seconds;
    match outcome {
        // A run may end before its budget on its own (a `stop_return`
        // goal): only the wall-time cut leaves a round unfinished.
        Ok(m) if cut && m.step < spec.steps => {
            record.status = TrialStatus::Interrupted;
            record.last = Some(m);
        }
        Ok(m) => {
            member.rounds = round + 1;
            member.steps.push(m.step);
            member
                .scores
                .push(objective.intermediate(&m).map(|s| s.key()));
            record.error = None;
            if round + 1 == shared.rounds {
                record.score = objective.score(&m);
                record.status = TrialStatus::Completed;
            }
            record.last = Some(m);
        }
        Err(e) => {
            record.error = Some(e.message);
            record.status = TrialStatus::Failed;
        }
    }
}

/// Records a member's reports; stops it only when the wall time is used.
struct MemberReporter<'s, 'a> {
    shared: &'s Shared<'a>,
    id: u64,
    cut: bool,
}

impl Reporter for MemberReporter<'_, '_> {
    fn report(&mut self, m: &Measurement) -> Decision {
        if self.cut {
            return Decision::Stop;
        }
        let mut inner = self.shared.lock();
        if let Some(score) = self.shared.config.objective.intermediate(m) {
            if let Some(t) = inner.state.trials.get_mut(self.id as usize) {
                // A resumed round re-reports steps it reported before: skip those.
                if t.reports.last().is_none_or(|r| m.step > r.step) {
                    t.reports.push(Report {
                        step: m.step,
                        value: score.key(),
                    });
                    t.last = Some(m.clone());
                }
            }
        }
        if self.shared.clock.out_of_time() {
            self.cut = true;
            self.shared.save(&mut inner);
            return Decision::Stop;
        }
        if inner.last_save.elapsed().as_secs_f64() >= REPORT_SAVE_SECONDS {
            self.shared.save(&mut inner);
        }
        Decision::Continue
    }
}
