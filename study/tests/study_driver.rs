//! The study driver with fake runners: resume without rerunning finished
//! trials, early stopping inside a study, wall-time cuts, failures, outputs.

use std::collections::BTreeMap;
use std::sync::Mutex;
use std::time::Duration;

use buridan_study::state::{StudyState, TrialStatus};
use buridan_study::*;

/// Counts calls per trial id; success = 1 − |x − 0.6| rising with steps.
#[derive(Default)]
struct Counting {
    calls: Mutex<BTreeMap<u64, Vec<bool>>>,
    sleep: Duration,
}

impl Counting {
    fn calls(&self) -> BTreeMap<u64, Vec<bool>> {
        self.calls.lock().unwrap().clone()
    }
}

impl TrialRunner for Counting {
    fn run(
        &self,
        spec: &TrialSpec,
        reporter: &mut dyn Reporter,
    ) -> Result<Measurement, TrialError> {
        self.calls
            .lock()
            .unwrap()
            .entry(spec.id)
            .or_default()
            .push(spec.resume);
        let x = spec.overrides["x"]
            .as_float()
            .ok_or_else(|| TrialError::new("x is not a float"))?;
        let quality = 1.0 - (x - 0.6).abs();
        let mut m = Measurement::default();
        for step in (100..=spec.steps).step_by(100) {
            std::thread::sleep(self.sleep);
            let progress = step as f64 / spec.steps as f64;
            m = Measurement {
                step,
                train_success: Some(quality * progress),
                train_len: Some(50.0 - 20.0 * quality),
                ..Default::default()
            };
            if !reporter.report(&m).keeps_going() {
                break;
            }
        }
        Ok(m)
    }
}

fn config(extra: &str, trials: u64) -> StudyConfig {
    StudyConfig::from_toml_str(&format!(
        "[study]\nname = \"t\"\ntrials = {trials}\nparallel = 2\nsteps_per_trial = 1000\nseed = 4\n{extra}\n[space]\nx = {{ uniform = [0, 1] }}"
    ))
    .unwrap()
}

#[test]
fn a_study_resumes_without_rerunning_finished_trials() {
    let dir = tempfile::tempdir().unwrap();
    // First invocation: four trials.
    let first = Counting::default();
    let mut study = Study::open(dir.path(), config("", 4)).unwrap();
    let p = study.run(&first).unwrap();
    assert_eq!((p.completed, p.started_now), (4, 4));
    assert_eq!(first.calls().len(), 4);
    let before = StudyState::load(dir.path()).unwrap().unwrap();

    // The process is killed during trial 3: on disk it is still running.
    let mut killed = before.clone();
    killed.trials[3].status = TrialStatus::Running;
    killed.save(dir.path()).unwrap();

    // Second invocation, with a larger budget of 6 trials.
    let second = Counting::default();
    let mut study = Study::open(dir.path(), config("", 6)).unwrap();
    let p = study.run(&second).unwrap();
    let calls = second.calls();
    assert_eq!(
        calls.keys().copied().collect::<Vec<_>>(),
        [3, 4, 5],
        "{calls:?}"
    );
    assert_eq!(calls[&3], [true], "the interrupted trial resumes");
    assert_eq!(
        (calls[&4].as_slice(), calls[&5].as_slice()),
        (&[false][..], &[false][..])
    );
    assert_eq!((p.completed, p.started_now), (6, 3));
    let after = study.state();
    for id in 0..3 {
        // Finished trials are untouched: same configuration and result.
        assert_eq!(after.trials[id], before.trials[id]);
    }
    // The resumed trial kept its configuration.
    assert_eq!(after.trials[3].overrides, before.trials[3].overrides);
    assert_eq!(after.trials[3].starts, 2);

    // Third invocation: nothing left to do, nothing runs.
    let third = Counting::default();
    let p = Study::open(dir.path(), config("", 6))
        .unwrap()
        .run(&third)
        .unwrap();
    assert!(third.calls().is_empty());
    assert_eq!(p.started_now, 0);
}

#[test]
fn reopening_with_another_space_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    Study::open(dir.path(), config("", 2)).unwrap();
    let other = StudyConfig::from_toml_str(
        "[study]\nname = \"t\"\ntrials = 2\nparallel = 2\nsteps_per_trial = 1000\nseed = 4\n[space]\nx = { uniform = [0, 2] }",
    )
    .unwrap();
    assert_eq!(
        Study::open(dir.path(), other).err(),
        Some(StudyError::Mismatch { field: "space" })
    );
}

#[test]
fn asha_inside_a_study_stops_bad_trials_early() {
    let dir = tempfile::tempdir().unwrap();
    let runner = Counting::default();
    let cfg = config(
        "[study.scheduler]\nkind = \"asha\"\ngrace_steps = 100\nreduction = 3",
        12,
    );
    // One at a time, so the order of reports (and the test) is deterministic.
    let mut study = Study::open(dir.path(), StudyConfig { parallel: 1, ..cfg }).unwrap();
    let p = study.run(&runner).unwrap();
    assert_eq!(p.completed + p.stopped, 12);
    assert!(p.stopped >= 6, "{p:?}");
    let state = study.state();
    // The trial nearest the optimum x = 0.6 ran its full budget and is the best.
    let distance =
        |t: &buridan_study::state::TrialRecord| (t.overrides["x"].as_float().unwrap() - 0.6).abs();
    let nearest = state
        .trials
        .iter()
        .min_by(|a, b| distance(a).total_cmp(&distance(b)))
        .unwrap();
    assert_eq!(nearest.status, TrialStatus::Completed);
    assert_eq!(state.best().unwrap().id, nearest.id);
    // Stopped trials used fewer steps than the budget, the study far fewer in all.
    let steps: u64 = state
        .trials
        .iter()
        .map(|t| t.last.as_ref().unwrap().step)
        .sum();
    assert!(steps < 12 * 1000 / 2, "steps used {steps}");
    for t in state
        .trials
        .iter()
        .filter(|t| t.status == TrialStatus::Stopped)
    {
        assert!(t.last.as_ref().unwrap().step < 1000);
        assert!(t.score.is_some(), "a stopped trial keeps its last score");
    }
}

#[test]
fn the_wall_time_budget_cuts_trials_and_a_later_session_resumes_them() {
    let dir = tempfile::tempdir().unwrap();
    let slow = Counting {
        sleep: Duration::from_millis(20),
        ..Default::default()
    };
    // 10 reports × 20 ms = 200 ms per trial; 150 ms of budget.
    let mut study = Study::open(dir.path(), config("wall_time = \"0.15s\"", 4)).unwrap();
    let p = study.run(&slow).unwrap();
    assert_eq!(p.interrupted, 2, "{p:?}");
    assert_eq!(p.completed, 0);
    assert!(study.state().wall_seconds >= 0.15);
    // More time: the interrupted trials resume, then the rest run.
    let fast = Counting::default();
    let mut study = Study::open(dir.path(), config("wall_time = \"1h\"", 4)).unwrap();
    let p = study.run(&fast).unwrap();
    assert_eq!(p.completed, 4);
    let calls = fast.calls();
    assert_eq!(calls[&0], [true]);
    assert_eq!(calls[&1], [true]);
    assert_eq!(calls[&2], [false]);
}

struct Failing;

impl TrialRunner for Failing {
    fn run(&self, spec: &TrialSpec, _: &mut dyn Reporter) -> Result<Measurement, TrialError> {
        match spec.id {
            0 => Err(TrialError::new("invalid --set override")),
            1 => panic!("runner bug"),
            _ => Ok(Measurement {
                step: spec.steps,
                train_success: Some(0.5),
                ..Default::default()
            }),
        }
    }
}

#[test]
fn failures_and_panics_are_recorded_not_fatal() {
    let dir = tempfile::tempdir().unwrap();
    let mut study = Study::open(dir.path(), config("", 3)).unwrap();
    let p = study.run(&Failing).unwrap();
    assert_eq!((p.failed, p.completed), (2, 1));
    let t = &study.state().trials;
    assert_eq!(t[0].error.as_deref(), Some("invalid --set override"));
    assert_eq!(t[1].error.as_deref(), Some("the runner panicked"));
    // Failed trials are finished: a resume does not run them again.
    let p = Study::open(dir.path(), config("", 3))
        .unwrap()
        .run(&Failing)
        .unwrap();
    assert_eq!(p.started_now, 0);
}

#[test]
fn outputs_name_the_best_configuration() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = config("sampler = \"tpe\"", 14);
    let mut study = Study::open(dir.path(), cfg).unwrap();
    study.run(&Counting::default()).unwrap();
    let files = study.write_outputs().unwrap();
    for f in &files {
        assert!(std::fs::metadata(f).unwrap().len() > 0, "{f:?}");
    }
    let best = std::fs::read_to_string(dir.path().join("best.toml")).unwrap();
    let table: toml::Table = toml::from_str(&best).unwrap();
    let x = table["x"].as_float().unwrap();
    assert_eq!(
        Some(x),
        study.state().best().unwrap().overrides["x"].as_float()
    );
    let csv = std::fs::read_to_string(dir.path().join("trials.csv")).unwrap();
    assert_eq!(csv.lines().count(), 15);
    assert!(csv
        .starts_with("id,status,objective,episode_len,last_step,seconds,starts,x,run_dir,error\n"));
    let png = std::fs::read(dir.path().join("params.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
}

#[test]
fn the_grid_stops_the_study_when_exhausted() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = config("sampler = \"grid\"\ngrid_points = 3", 10);
    let mut study = Study::open(dir.path(), cfg).unwrap();
    let p = study.run(&Counting::default()).unwrap();
    assert_eq!(p.completed, 3);
}

#[test]
fn ties_go_to_shorter_episodes() {
    struct Tied;
    impl TrialRunner for Tied {
        fn run(&self, spec: &TrialSpec, _: &mut dyn Reporter) -> Result<Measurement, TrialError> {
            Ok(Measurement {
                step: spec.steps,
                eval_greedy_success: Some(1.0),
                eval_greedy_len: Some(if spec.id == 2 { 20.0 } else { 30.0 }),
                ..Default::default()
            })
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let cfg = config("objective = \"eval_greedy\"", 4);
    let mut study = Study::open(dir.path(), cfg).unwrap();
    study.run(&Tied).unwrap();
    assert_eq!(study.state().best().unwrap().id, 2);
}
