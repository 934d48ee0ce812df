//! Population-based training in the study driver, with a fake runner whose
//! "checkpoint" is a file in its run directory: exploitation beats
//! independent training on an objective whose best learning rate drifts,
//! the lineage is recorded and consistent, and a killed or cut study
//! continues from its last finished round to the same result.

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Duration;

use buridan_study::config::ConfigError;
use buridan_study::lineage::round_dir;
use buridan_study::state::{StudyState, STATE_FILE};
use buridan_study::*;
use serde::{Deserialize, Serialize};

const STEPS: u64 = 20_000;
const CHECKPOINT: &str = "skill.json";

/// What the fake trainer keeps in a checkpoint.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize)]
struct Skill {
    step: u64,
    skill: f64,
}

/// The learning rate (log10) that learns fastest drifts from 1e-2 at the
/// start to 1e-4 at the end: no fixed value is good throughout.
fn rate(lr: f64, step: u64) -> f64 {
    let best = -2.0 - 2.0 * step as f64 / STEPS as f64;
    (-(lr.log10() - best).powi(2) / (2.0 * 0.3f64.powi(2))).exp()
}

/// One call of the runner: member, round (from the run directory), resume, start_from.
#[derive(Debug, Clone, PartialEq)]
struct Call {
    id: u64,
    round: u32,
    resume: bool,
    start_from: Option<PathBuf>,
}

/// Trains "skill" at [`rate`], 100 steps per report, checkpointing into
/// its run directory when it ends or is stopped; starts from its own
/// checkpoint when resuming, else from `start_from`'s.
#[derive(Default)]
struct Fake {
    calls: Mutex<Vec<Call>>,
    /// Sleep per report, to let the wall time cut rounds.
    sleep: Duration,
    /// Copy study.json aside when this (member, round) starts: what a kill
    /// at that moment leaves on disk.
    snapshot_at: Option<(u64, u32)>,
}

/// The PBT round of a run directory (0 for a trial outside PBT).
fn round_of(run_dir: &Path) -> u32 {
    let name = run_dir.file_name().unwrap().to_str().unwrap();
    name.strip_prefix("round-")
        .map_or(0, |r| r.parse().unwrap())
}

fn load(dir: &Path) -> Option<Skill> {
    let text = std::fs::read_to_string(dir.join(CHECKPOINT)).ok()?;
    serde_json::from_str(&text).ok()
}

impl TrialRunner for Fake {
    fn run(
        &self,
        spec: &TrialSpec,
        reporter: &mut dyn Reporter,
    ) -> Result<Measurement, TrialError> {
        let round = round_of(&spec.run_dir);
        self.calls.lock().unwrap().push(Call {
            id: spec.id,
            round,
            resume: spec.resume,
            start_from: spec.start_from.clone(),
        });
        if self.snapshot_at == Some((spec.id, round)) && !spec.resume {
            let study_dir = spec.run_dir.ancestors().nth(3).unwrap();
            std::fs::copy(study_dir.join(STATE_FILE), study_dir.join("snapshot.json")).unwrap();
        }
        let own = spec.resume.then(|| load(&spec.run_dir)).flatten();
        let mut s = match (own, &spec.start_from) {
            (Some(s), _) => s,
            (None, Some(from)) => {
                load(from).ok_or_else(|| TrialError::new(format!("no checkpoint in {from:?}")))?
            }
            (None, None) => Skill::default(),
        };
        let lr = spec.overrides["lr"].as_float().unwrap();
        let measure = |s: &Skill| Measurement {
            step: s.step,
            train_success: Some(s.skill / STEPS as f64),
            ..Default::default()
        };
        while s.step < spec.steps {
            std::thread::sleep(self.sleep);
            s.skill += 100.0 * rate(lr, s.step);
            s.step += 100;
            if !reporter.report(&measure(&s)).keeps_going() {
                break;
            }
        }
        std::fs::create_dir_all(&spec.run_dir).unwrap();
        std::fs::write(
            spec.run_dir.join(CHECKPOINT),
            serde_json::to_string(&s).unwrap(),
        )
        .unwrap();
        Ok(measure(&s))
    }
}

impl Fake {
    fn calls(&self) -> Vec<Call> {
        self.calls.lock().unwrap().clone()
    }
}

fn config(scheduler: &str, seed: u64, extra: &str) -> StudyConfig {
    StudyConfig::from_toml_str(&format!(
        "[study]\nname = \"pbt\"\nparallel = 2\nsteps_per_trial = {STEPS}\nseed = {seed}\n{extra}\n\
         {scheduler}\n[space]\nlr = {{ log_uniform = [1e-5, 1e-1] }}"
    ))
    .unwrap()
}

const PBT: &str =
    "[study.scheduler]\nkind = \"pbt\"\npopulation = 8\ninterval_steps = 1000\nresample_probability = 0.2";

fn best_score(state: &StudyState) -> f64 {
    state.best().unwrap().score.unwrap().value
}

#[test]
fn exploiting_the_best_members_beats_training_them_independently() {
    let (mut pbt_total, mut alone_total) = (0.0, 0.0);
    for seed in 0..4 {
        let dir = tempfile::tempdir().unwrap();
        let mut study = Study::open(dir.path(), config(PBT, seed, "")).unwrap();
        let p = study.run(&Fake::default()).unwrap();
        assert_eq!((p.completed, p.failed), (8, 0));
        // Every member trained to the budget.
        for t in &study.state().trials {
            assert_eq!(t.last.as_ref().unwrap().step, STEPS);
        }
        let pbt = best_score(study.state());

        // The same 8 initial configurations (same sampler and seed), no exploitation.
        let dir = tempfile::tempdir().unwrap();
        let mut alone = Study::open(dir.path(), config("", seed, "trials = 8")).unwrap();
        alone.run(&Fake::default()).unwrap();
        let members = &study.state().pbt.as_ref().unwrap().members;
        for t in &alone.state().trials {
            assert_eq!(t.overrides, members[t.id as usize].schedule[0]);
        }
        let alone = best_score(alone.state());
        assert!(
            pbt > alone,
            "seed {seed}: PBT {pbt:.3} vs independent {alone:.3}"
        );
        pbt_total += pbt;
        alone_total += alone;
    }
    // No fixed learning rate is good throughout; following the drift is.
    assert!(
        pbt_total / 4.0 > alone_total / 4.0 + 0.1,
        "PBT {:.3} vs independent {:.3}",
        pbt_total / 4.0,
        alone_total / 4.0
    );
}

#[test]
fn the_lineage_says_who_copied_whom_and_the_outputs_hold_it() {
    let dir = tempfile::tempdir().unwrap();
    let fake = Fake::default();
    let mut study = Study::open(dir.path(), config(PBT, 1, "")).unwrap();
    study.run(&fake).unwrap();
    let state = study.state();
    let pbt = state.pbt.as_ref().unwrap();
    assert_eq!(pbt.rounds_done, 20);
    // 20 rounds, after each but the last the bottom 2 of 8 members copy
    // the top 2 (unless tied with them).
    assert!(
        (19..=19 * 2).contains(&pbt.lineage.len()),
        "{}",
        pbt.lineage.len()
    );
    let calls = fake.calls();
    for e in &pbt.lineage {
        assert!(e.source_score >= e.trial_score, "{e:?}");
        assert_eq!(
            e.step,
            pbt.members[e.source as usize].steps[e.round as usize]
        );
        // The copier's next round used the new values, from the source's checkpoint.
        let member = &pbt.members[e.trial as usize];
        assert_eq!(member.schedule[e.round as usize + 1], e.overrides);
        let call = calls
            .iter()
            .find(|c| c.id == e.trial && c.round == e.round + 1)
            .unwrap();
        assert_eq!(
            call.start_from.as_deref(),
            Some(dir.path().join(round_dir(e.source, e.round)).as_path())
        );
    }
    // Members not exploited continue from their own last round.
    let own = calls
        .iter()
        .filter(|c| c.round > 0)
        .filter(|c| {
            c.start_from.as_deref() == Some(dir.path().join(round_dir(c.id, c.round - 1)).as_path())
        })
        .count();
    assert_eq!(own + pbt.lineage.len(), 19 * 8);

    study.write_outputs().unwrap();
    let csv = std::fs::read_to_string(dir.path().join("pbt.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + pbt.lineage.len());
    assert!(csv.starts_with("round,step,trial,source,trial_score,source_score,lr\n"));
    // The best member's schedule: one row per round, ending with its own values.
    let best = state.best().unwrap();
    let schedule = pbt.schedule(best.id);
    assert_eq!(schedule.len(), 20);
    assert_eq!(schedule.last().unwrap().member, best.id);
    assert_eq!(schedule.last().unwrap().overrides, best.overrides);
    // The optimum drifts down: the schedule lowers the learning rate.
    let lr = |i: usize| schedule[i].overrides["lr"].as_float().unwrap();
    assert!(lr(19) < lr(0) / 10.0, "{} -> {}", lr(0), lr(19));
    let rows = std::fs::read_to_string(dir.path().join("pbt-schedule.csv")).unwrap();
    assert_eq!(rows.lines().count(), 21);
}

/// Asserts two studies ended alike: trials, scores and lineage (scores to
/// 1e-9: study.json's floats may come back one ulp off).
fn assert_same_outcome(a: &StudyState, b: &StudyState) {
    let close = |x: Option<f64>, y: Option<f64>| match (x, y) {
        (Some(x), Some(y)) => (x - y).abs() < 1e-9,
        (x, y) => x == y,
    };
    assert_eq!(a.trials.len(), b.trials.len());
    for (s, t) in a.trials.iter().zip(&b.trials) {
        assert_eq!((&s.overrides, s.status), (&t.overrides, t.status));
        assert!(close(s.score.map(|x| x.value), t.score.map(|x| x.value)));
    }
    let (la, lb) = (
        &a.pbt.as_ref().unwrap().lineage,
        &b.pbt.as_ref().unwrap().lineage,
    );
    assert_eq!(la.len(), lb.len());
    for (e, f) in la.iter().zip(lb) {
        assert_eq!(
            (e.round, e.step, e.trial, e.source, &e.overrides),
            (f.round, f.step, f.trial, f.source, &f.overrides)
        );
        assert!(close(e.trial_score, f.trial_score) && close(e.source_score, f.source_score));
    }
}

#[test]
fn a_killed_pbt_study_continues_from_its_last_finished_round() {
    let whole = tempfile::tempdir().unwrap();
    let mut study = Study::open(whole.path(), config(PBT, 2, "")).unwrap();
    study.run(&Fake::default()).unwrap();
    let expected = study.state().clone();

    // The first invocation is killed as member 2 starts round 3: on disk, what was saved then.
    let dir = tempfile::tempdir().unwrap();
    let first = Fake {
        snapshot_at: Some((2, 3)),
        ..Default::default()
    };
    Study::open(dir.path(), config(PBT, 2, ""))
        .unwrap()
        .run(&first)
        .unwrap();
    std::fs::rename(
        dir.path().join("snapshot.json"),
        dir.path().join(STATE_FILE),
    )
    .unwrap();
    let killed = StudyState::load(dir.path()).unwrap().unwrap();
    let members = &killed.pbt.as_ref().unwrap().members;
    assert_eq!(killed.pbt.as_ref().unwrap().rounds_done, 3);
    assert_eq!(members[2].started, 4);

    let second = Fake::default();
    let mut study = Study::open(dir.path(), config(PBT, 2, "")).unwrap();
    let p = study.run(&second).unwrap();
    let calls = second.calls();
    assert!(
        calls.iter().all(|c| c.round >= 3),
        "a finished round ran again"
    );
    let in_round_3: Vec<&Call> = calls.iter().filter(|c| c.round == 3).collect();
    for (id, m) in members.iter().enumerate() {
        let call = in_round_3.iter().find(|c| c.id == id as u64);
        match m.rounds {
            4 => assert!(call.is_none(), "member {id} finished round 3 already"),
            _ => assert_eq!(call.unwrap().resume, m.started == 4, "member {id}"),
        }
    }
    assert_eq!(calls.len(), in_round_3.len() + 16 * 8);
    assert_eq!(p.completed, 8);
    assert_same_outcome(study.state(), &expected);
}

#[test]
fn the_wall_time_cuts_a_round_and_the_next_session_finishes_it() {
    let whole = tempfile::tempdir().unwrap();
    let mut study = Study::open(whole.path(), config(PBT, 3, "")).unwrap();
    study.run(&Fake::default()).unwrap();
    let expected = study.state().clone();

    let dir = tempfile::tempdir().unwrap();
    let slow = Fake {
        sleep: Duration::from_millis(1),
        ..Default::default()
    };
    // 8 members × 200 reports × ≥ 1 ms over 2 threads: at least 0.8 s in all.
    let mut study = Study::open(dir.path(), config(PBT, 3, "wall_time = \"0.3s\"")).unwrap();
    let p = study.run(&slow).unwrap();
    assert!(p.interrupted > 0 && p.completed == 0, "{p:?}");
    let cut = study.state().pbt.as_ref().unwrap().rounds_done;
    assert!(cut < 20);

    let fast = Fake::default();
    let mut study = Study::open(dir.path(), config(PBT, 3, "wall_time = \"1h\"")).unwrap();
    assert_eq!(study.run(&fast).unwrap().completed, 8);
    assert!(fast.calls().iter().all(|c| c.round >= cut));
    assert_same_outcome(study.state(), &expected);
}

#[test]
fn a_pbt_space_must_not_change_the_network() {
    let e = StudyConfig::from_toml_str(&format!(
        "[study]\nname = \"x\"\nparallel = 2\nsteps_per_trial = 10\n{PBT}\n[space]\nhidden = {{ choice = [[32, 32], [64, 64]] }}\nlr = {{ uniform = [0, 1] }}"
    ))
    .unwrap_err();
    assert_eq!(
        e,
        ConfigError::NetworkKey {
            key: "hidden".into()
        }
    );
    assert!(e.to_string().contains("`hidden` shapes the network"), "{e}");
    // Outside PBT, varying `hidden` is fine.
    StudyConfig::from_toml_str(
        "[study]\nname = \"x\"\ntrials = 2\nsteps_per_trial = 10\n[space]\nhidden = { choice = [[32, 32], [64, 64]] }",
    )
    .unwrap();
}

#[test]
fn the_population_is_the_trial_count_and_defaults_to_parallel() {
    let cfg = StudyConfig::from_toml_str(
        "[study]\nname = \"x\"\nparallel = 3\nsteps_per_trial = 10\n[study.scheduler]\nkind = \"pbt\"\ninterval_steps = 5\n[space]\nlr = { uniform = [0, 1] }",
    )
    .unwrap();
    assert_eq!(cfg.trials, 3);
    let e = StudyConfig::from_toml_str(&format!(
        "[study]\nname = \"x\"\ntrials = 5\nsteps_per_trial = 10\n{PBT}\n[space]\nlr = {{ uniform = [0, 1] }}"
    ))
    .unwrap_err();
    assert!(
        matches!(
            e,
            ConfigError::Invalid {
                field: "trials",
                ..
            }
        ),
        "{e}"
    );
    // A PBT study is not a cluster batch, and its scheduler cannot change on resume.
    let dir = tempfile::tempdir().unwrap();
    let mut study = Study::open(dir.path(), config(PBT, 0, "")).unwrap();
    assert_eq!(study.plan(2).unwrap_err(), StudyError::PbtBatch);
    let other = PBT.replace("population = 8", "population = 6");
    assert_eq!(
        Study::open(dir.path(), config(&other, 0, "")).err(),
        Some(StudyError::Mismatch { field: "scheduler" })
    );
}
