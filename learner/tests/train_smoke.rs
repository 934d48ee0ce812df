//! The trainer's plumbing: outputs, checkpoints, resume, every algorithm ×
//! mode (× LSTM) end to end on tiny budgets.

use buridan_env::Starts;
use buridan_learner::algo::schedule::Schedule;
use buridan_learner::train::{
    final_checkpoint, train, Algo, Algorithm, ImpalaConfig, MetricsRow, ModelConfig, NoProgress,
    PpoConfig, Progress, RunConfig, Summary, Task, TrainConfig, TrainError,
};
use buridan_policy::{Mode, Policy, PolicyError};

fn tiny(algo: Algo, mode: Mode) -> TrainConfig {
    TrainConfig {
        algorithm: match algo {
            Algo::Ppo => Algorithm::Ppo(PpoConfig {
                train_batch: 160,
                minibatch: 80,
                epochs: 2,
                ..PpoConfig::default()
            }),
            Algo::Impala => Algorithm::Impala(ImpalaConfig {
                train_batch: 160,
                ..ImpalaConfig::default()
            }),
        },
        mode,
        task: Task::Grid("rm-1.1".into()),
        agents: 2,
        starts: Starts::Fixed,
        model: ModelConfig {
            hidden: vec![16, 16],
            lstm: false,
            lstm_cells: 8,
            max_seq_len: 8,
        },
        run: RunConfig {
            steps: 800,
            envs_per_actor: 4,
            fragment_len: 20,
            checkpoint_every: 2,
            ..RunConfig::default()
        },
        ..TrainConfig::default()
    }
}

#[derive(Default)]
struct Record {
    rows: Vec<MetricsRow>,
    checkpoints: usize,
    finished: Option<Summary>,
    started: Option<(u64, u64)>,
}

impl Progress for Record {
    fn on_start(&mut self, _cfg: &TrainConfig, total: u64, done: u64) {
        self.started = Some((total, done));
    }
    fn on_update(&mut self, row: &MetricsRow) {
        self.rows.push(row.clone());
    }
    fn on_checkpoint(&mut self, _dir: &std::path::Path) {
        self.checkpoints += 1;
    }
    fn on_finish(&mut self, s: &Summary) {
        self.finished = Some(s.clone());
    }
}

#[test]
fn ppo_writes_metrics_checkpoints_summary_and_resumes() {
    buridan_policy::threads::pin_threads(1);
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let cfg = tiny(Algo::Ppo, Mode::Ctde);
    let mut rec = Record::default();
    let s = train(&cfg, &out, &mut rec).unwrap();
    // 160 env steps per update (2 fragments of 20 steps × 4 envs), 800 steps → 5 updates.
    assert_eq!(s.env_steps, 800);
    assert_eq!(s.agent_steps, 1600);
    assert_eq!(s.updates, 5);
    assert_eq!(rec.rows.len(), 5);
    assert_eq!(rec.started, Some((800, 0)));
    assert!(rec
        .rows
        .windows(2)
        .all(|w| w[1].env_steps == w[0].env_steps + 160));
    assert_eq!(rec.checkpoints, 3); // updates 2, 4 and the final one
    assert_eq!(rec.finished.as_ref().unwrap().env_steps, 800);
    let csv = std::fs::read_to_string(out.join("metrics.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "update,env_steps,agent_steps,wall_seconds,steps_per_s,episodes,episode_return_mean,\
         success_rate,episode_len_mean,total_loss,policy_loss,vf_loss,entropy,kl,kl_coeff,\
         grad_norm,mean_rho,stale_fragments,learn_seconds,lr,entropy_coeff"
    );
    assert_eq!(lines.count(), 5);
    // Every row reads back as a MetricsRow (the curves command does this).
    let rows: Vec<MetricsRow> = csv::Reader::from_path(out.join("metrics.csv"))
        .unwrap()
        .deserialize()
        .collect::<Result<_, _>>()
        .unwrap();
    assert_eq!(rows.last().unwrap().env_steps, 800);
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    for key in [
        "env_steps",
        "wall_seconds",
        "episode_return_mean",
        "success_rate",
    ] {
        assert!(summary.get(key).is_some(), "summary lacks {key}");
    }
    for ck in ["update-000002", "update-000004", "final"] {
        let d = out.join("checkpoints").join(ck);
        for f in [
            "spec.json",
            "model.safetensors",
            "optimizer.safetensors",
            "trainer.json",
            "config.toml",
        ] {
            assert!(d.join(f).is_file(), "{} lacks {f}", d.display());
        }
    }
    let p = Policy::load(&final_checkpoint(&out)).unwrap();
    assert_eq!(p.spec().mode, Mode::Ctde);

    // Resume from the final checkpoint to 1600 steps: counters continue,
    // metrics.csv grows, weights start where they stopped.
    let mut resumed_cfg = cfg.clone();
    resumed_cfg.run.steps = 1600;
    resumed_cfg.run.resume = Some(final_checkpoint(&out));
    let mut rec2 = Record::default();
    let s2 = train(&resumed_cfg, &out, &mut rec2).unwrap();
    assert_eq!(rec2.started, Some((1600, 800)));
    assert_eq!(s2.env_steps, 1600);
    assert_eq!(s2.updates, 10);
    assert_eq!(rec2.rows.first().unwrap().update, 6);
    // The episode window survives the resume: the first update (40 steps
    // per env, fresh episodes of up to 100 steps) reports the saved episodes.
    let trainer: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(final_checkpoint(&out).join("trainer.json")).unwrap(),
    )
    .unwrap();
    let saved = trainer["recent_episodes"].as_array().unwrap().len();
    assert!(saved > 0 && saved <= 100, "{saved} saved episodes");
    assert!(rec2.rows[0].episode_return_mean.is_finite());
    assert!(rec2.rows[0].episodes >= s.episodes);
    let csv = std::fs::read_to_string(out.join("metrics.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 10);
    assert!(s2.wall_seconds >= s.wall_seconds);

    // Resuming with a different architecture is refused.
    let mut bad = resumed_cfg.clone();
    bad.model.hidden = vec![8];
    let err = train(&bad, &dir.path().join("bad"), &mut NoProgress).unwrap_err();
    assert!(
        matches!(
            err,
            TrainError::Resume {
                source: PolicyError::SpecMismatch { .. },
                ..
            }
        ),
        "{err:?}"
    );
}

#[test]
fn every_algorithm_and_mode_trains_end_to_end() {
    buridan_policy::threads::pin_threads(1);
    let dir = tempfile::tempdir().unwrap();
    for algo in [Algo::Ppo, Algo::Impala] {
        for mode in [Mode::Cte, Mode::Ctde, Mode::Dte] {
            for lstm in [false, true] {
                let mut cfg = tiny(algo, mode);
                cfg.model.lstm = lstm;
                cfg.run.steps = 480;
                cfg.run.checkpoint_every = 0;
                if algo == Algo::Impala {
                    cfg.run.num_actors = 2;
                }
                let out = dir.path().join(format!("{algo}-{mode}-{lstm}"));
                let mut rec = Record::default();
                let s = train(&cfg, &out, &mut rec)
                    .unwrap_or_else(|e| panic!("{algo} {mode} lstm={lstm}: {e:#}"));
                assert!(s.env_steps >= 480);
                for r in &rec.rows {
                    assert!(r.total_loss.is_finite(), "{algo} {mode} {lstm}: {r:?}");
                    assert!(r.entropy > 0.0 && r.entropy <= 5f64.ln() * cfg.agents as f64 + 1e-6);
                }
                let p = Policy::load(&final_checkpoint(&out)).unwrap();
                assert_eq!(p.spec().is_recurrent(), lstm);
                assert_eq!(p.nets().len(), if mode == Mode::Dte { 2 } else { 1 });
                assert_eq!(p.spec().heads, if mode == Mode::Cte { 2 } else { 1 });
            }
        }
    }
}

#[test]
fn bundled_configs_parse() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("configs");
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            TrainConfig::from_toml_file(&path).unwrap();
            n += 1;
        }
    }
    assert!(n >= 4);
}

#[test]
fn imitation_runs_before_learning_and_logs_its_rounds() {
    buridan_policy::threads::pin_threads(1);
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = tiny(Algo::Impala, Mode::Ctde);
    cfg.starts = Starts::Random;
    cfg.run.steps = 0; // imitation only
    cfg.imitation = Some(buridan_imitate::ImitationConfig {
        rounds: 2,
        steps_per_round: 400,
        envs: 4,
        ..Default::default()
    });
    let summary = train(&cfg, dir.path(), &mut NoProgress).unwrap();
    assert_eq!((summary.env_steps, summary.updates), (0, 0));
    let csv = std::fs::read_to_string(dir.path().join("imitation.csv")).unwrap();
    assert_eq!(csv.lines().count(), 3, "{csv}");
    assert!(csv.starts_with("round,env_steps,rows,"), "{csv}");
    // The imitated policy is the run's final checkpoint, and it is trained.
    let trained = Policy::load(&final_checkpoint(dir.path())).unwrap();
    let fresh = Policy::new(trained.spec().clone(), cfg.run.seed).unwrap();
    assert_ne!(
        trained.weights(0).unwrap().tensors[0].data,
        fresh.weights(0).unwrap().tensors[0].data
    );
    // A recurrent policy imitates too (on windows of its own steps).
    let lstm_dir = tempfile::tempdir().unwrap();
    cfg.model.lstm = true;
    train(&cfg, lstm_dir.path(), &mut NoProgress).unwrap();
    let csv = std::fs::read_to_string(lstm_dir.path().join("imitation.csv")).unwrap();
    assert_eq!(csv.lines().count(), 3, "{csv}");
    let trained = Policy::load(&final_checkpoint(lstm_dir.path())).unwrap();
    assert!(trained.spec().is_recurrent());
    // DTE's agents each imitate with their own network, CTE's joint policy
    // with one head per agent: every network moves, and the expert's
    // actions are what each head learns.
    for (mode, lstm) in [(Mode::Dte, false), (Mode::Cte, false), (Mode::Dte, true)] {
        cfg.mode = mode;
        cfg.model.lstm = lstm;
        let out = tempfile::tempdir().unwrap();
        train(&cfg, out.path(), &mut NoProgress).unwrap();
        let rounds = std::fs::read_to_string(out.path().join("imitation.csv")).unwrap();
        assert_eq!(rounds.lines().count(), 3, "{mode}: {rounds}");
        let trained = Policy::load(&final_checkpoint(out.path())).unwrap();
        let fresh = Policy::new(trained.spec().clone(), cfg.run.seed).unwrap();
        for k in 0..trained.nets().len() {
            let (a, b) = (trained.net_vars(k), fresh.net_vars(k));
            let values = |v: &candle_core::Var| {
                v.as_tensor()
                    .flatten_all()
                    .unwrap()
                    .to_vec1::<f32>()
                    .unwrap()
            };
            let moved = a
                .iter()
                .zip(&b)
                .any(|((_, x), (_, y))| values(x) != values(y));
            assert!(moved, "{mode}: network {k} did not learn");
        }
    }
}

#[test]
fn polish_imitates_after_learning_and_before_the_final_checkpoint() {
    buridan_policy::threads::pin_threads(1);
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = tiny(Algo::Ppo, Mode::Ctde);
    cfg.starts = Starts::Random;
    let trained = dir.path().join("trained");
    let before = train(&cfg, &trained, &mut NoProgress).unwrap();
    assert!(!trained.join("polish.csv").exists());
    // Polish the trained run: resumed at its budget, it learns no more
    // from rewards, and DAgger rolls out the trained policy from round 0.
    cfg.run.resume = Some(final_checkpoint(&trained));
    cfg.polish = Some(buridan_imitate::ImitationConfig {
        rounds: 2,
        steps_per_round: 400,
        envs: 4,
        expert_first: false,
        ..Default::default()
    });
    let polished = dir.path().join("polished");
    let summary = train(&cfg, &polished, &mut NoProgress).unwrap();
    assert_eq!(
        (summary.env_steps, summary.updates),
        (before.env_steps, before.updates)
    );
    let csv = std::fs::read_to_string(polished.join("polish.csv")).unwrap();
    assert_eq!(csv.lines().count(), 3, "{csv}");
    assert!(!polished.join("imitation.csv").exists());
    let weights = |run: &std::path::Path| {
        Policy::load(&final_checkpoint(run))
            .unwrap()
            .weights(0)
            .unwrap()
            .tensors[0]
            .data
            .clone()
    };
    assert_ne!(weights(&trained), weights(&polished));
    // A bad [polish] section names itself.
    cfg.polish.as_mut().unwrap().rounds = 0;
    let err = train(&cfg, &dir.path().join("bad"), &mut NoProgress).unwrap_err();
    let chain = buridan_env::error::error_chain(&err);
    assert!(
        chain.contains("[polish]") && chain.contains("rounds"),
        "{chain}"
    );
}

#[test]
fn schedules_set_each_updates_learning_rate_and_entropy_coefficient() {
    buridan_policy::threads::pin_threads(1);
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = tiny(Algo::Impala, Mode::Ctde);
    let impala = cfg.algorithm.impala_mut().unwrap();
    impala.lr_schedule = Some(Schedule::new(vec![(0, 1e-3), (800, 0.0)]).unwrap());
    impala.entropy_schedule = Some(Schedule::new(vec![(320, 0.02)]).unwrap());
    let mut rec = Record::default();
    train(&cfg, &dir.path().join("run"), &mut rec).unwrap();
    // Update k (1-based) learns from the batch that ends at 160·k env
    // steps, with the rates of the env steps sampled so far (RLlib's
    // `timesteps_total`): 160·k.
    let lrs: Vec<f64> = rec.rows.iter().map(|r| r.lr).collect();
    let expected = [8e-4, 6e-4, 4e-4, 2e-4, 0.0];
    for (got, want) in lrs.iter().zip(expected) {
        assert!(
            (got - want).abs() < 1e-12,
            "lr {lrs:?}, expected {expected:?}"
        );
    }
    assert!(rec
        .rows
        .iter()
        .all(|r| (r.entropy_coeff - 0.02).abs() < 1e-9));
    // The file records them too.
    let rows: Vec<MetricsRow> = csv::Reader::from_path(dir.path().join("run/metrics.csv"))
        .unwrap()
        .deserialize()
        .collect::<Result<_, _>>()
        .unwrap();
    assert!((rows[2].lr - 4e-4).abs() < 1e-12);

    // Without schedules the rows show the constant settings.
    let cfg = tiny(Algo::Ppo, Mode::Ctde);
    let mut rec = Record::default();
    train(&cfg, &dir.path().join("plain"), &mut rec).unwrap();
    let ppo = cfg.algorithm.ppo().unwrap();
    assert!(rec.rows.iter().all(|r| r.lr == ppo.lr));
    assert!(rec
        .rows
        .iter()
        .all(|r| r.entropy_coeff == ppo.entropy_coeff as f64));
}

/// A small PPO run on rm-1.1 (fixed starts) that imitates LaCAM and
/// OD-A* for two short DAgger rounds first.
fn imitating_rm_1_1() -> TrainConfig {
    let mut cfg = tiny(Algo::Ppo, Mode::Ctde);
    cfg.model.hidden = vec![64, 64];
    let ppo = cfg.algorithm.ppo_mut().unwrap();
    (ppo.train_batch, ppo.minibatch) = (1000, 500);
    cfg.run.fragment_len = 50;
    cfg.imitation = Some(buridan_imitate::ImitationConfig {
        expert: vec!["lacam".into(), "od-astar".into()],
        rounds: 2,
        steps_per_round: 2_000,
        envs: 4,
        epochs: 10,
        minibatch: 256,
        ..Default::default()
    });
    cfg
}

/// Right after imitation the RL phase's rollouts do what the imitated
/// policy does: on rm-1.1's corridor with one niche (fixed starts, the
/// simplest conflict) the first training batch succeeds as the planner's
/// episodes do. (Labels that only the env could follow — entering a cell as
/// its holder leaves, which the policy's mask forbids — once taught a
/// policy that solved every DAgger episode with the expert's help and none
/// on its own.)
#[test]
fn the_first_episodes_after_imitation_succeed_as_the_imitated_policy_does() {
    buridan_policy::threads::pin_threads(1);
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = imitating_rm_1_1();
    // A budget it does not need: `[stop]` ends the run once it has held.
    cfg.run.steps = 50_000;
    cfg.run.stop = Some(buridan_learner::train::StopRule {
        success: 0.9,
        hold: 3_000,
        greedy: None,
    });
    let mut record = Record::default();
    let summary = train(&cfg, dir.path(), &mut record).unwrap();
    let first = &record.rows[0];
    assert!(first.episodes >= 20, "{first:?}");
    assert!(first.success_rate >= 0.9, "{first:?}");
    assert_eq!(
        summary.stop_reason,
        buridan_learner::train::StopReason::Learned
    );
    assert!(summary.env_steps < cfg.run.steps, "{summary:?}");
}

/// The rows of a run's `greedy.csv`.
fn greedy_records(dir: &std::path::Path) -> Vec<buridan_learner::train::stop::GreedyRecord> {
    csv::Reader::from_path(dir.join(buridan_learner::train::GREEDY_FILE))
        .unwrap()
        .deserialize()
        .collect::<Result<_, _>>()
        .unwrap()
}

/// [`imitating_rm_1_1`] for 20k env steps that only a greedy check of 8
/// episodes, every 4,000 env steps, can stop (its training rule needs a
/// stretch longer than the budget).
fn imitating_rm_1_1_to_a_greedy_stop(keep_best: bool) -> TrainConfig {
    use buridan_learner::train::stop::GreedyCheck;
    buridan_policy::threads::pin_threads(1);
    let mut cfg = imitating_rm_1_1();
    cfg.run.steps = 20_000;
    cfg.run.stop = Some(buridan_learner::train::StopRule {
        success: 1.0,
        hold: 1_000_000,
        greedy: Some(GreedyCheck {
            success: 1.0,
            episodes: 8,
            every: 4_000,
            keep_best,
            finalists: None,
        }),
    });
    cfg
}

/// Trains `cfg`, which the greedy check after its first update stops;
/// the summary and the rows of `greedy.csv`.
fn stopped_by_the_first_update_s_check(
    cfg: &TrainConfig,
) -> (
    buridan_learner::train::Summary,
    Vec<buridan_learner::train::stop::GreedyRecord>,
) {
    let dir = tempfile::tempdir().unwrap();
    let summary = train(cfg, dir.path(), &mut Record::default()).unwrap();
    assert_eq!(
        summary.stop_reason,
        buridan_learner::train::StopReason::Greedy,
        "{summary:?}"
    );
    assert_eq!(summary.updates, 1, "stopped after the first update");
    (summary, greedy_records(dir.path()))
}

/// `[stop.greedy]`: once the greedy policy solves the held-out episodes the
/// run stops, says why, and books every check in `greedy.csv`; a level no
/// policy reaches (a stretch longer than the budget for the training rule)
/// leaves the run to its budget, one check per `every` env steps.
#[test]
fn a_greedy_check_on_held_out_episodes_stops_a_run_that_has_learned() {
    use buridan_learner::train::StopReason;
    let mut cfg = imitating_rm_1_1_to_a_greedy_stop(false);

    // The imitated policy solves rm-1.1 (fixed starts) greedily: the first
    // check, right after the first update, stops the run.
    let (summary, rows) = stopped_by_the_first_update_s_check(&cfg);
    assert_eq!(rows.len(), 1, "{rows:?}");
    assert_eq!(
        (rows[0].update, rows[0].episodes, rows[0].solved),
        (1, 8, 8)
    );
    assert_eq!(
        summary.greedy_check,
        Some(rows[0]),
        "the summary names the last check"
    );

    // Without imitation the first updates' greedy policy solves nothing:
    // no check passes, one runs every 4,000 env steps, the budget ends it.
    let dir = tempfile::tempdir().unwrap();
    cfg.imitation = None;
    cfg.run.steps = 9_000;
    let summary = train(&cfg, dir.path(), &mut Record::default()).unwrap();
    assert_eq!(summary.stop_reason, StopReason::Budget, "{summary:?}");
    let rows = greedy_records(dir.path());
    assert_eq!(rows[0].update, 1, "{rows:?}");
    assert!(rows.len() >= 2, "{rows:?}");
    for pair in rows.windows(2) {
        let gap = pair[1].env_steps - pair[0].env_steps;
        assert!((4_000..5_000).contains(&gap), "{rows:?}");
    }
    assert!(rows.iter().all(|r| r.solved < r.episodes), "{rows:?}");
}

/// `[stop.greedy] keep_best`: the weights the RL phase starts from are
/// checked before the first update (the imitated policy already solves
/// rm-1.1; the check after the first update ends the run); without a pass
/// the last update's weights are checked at the end and the final
/// checkpoint holds the best check's weights, the earlier on a tie.
#[test]
fn keep_best_checks_the_imitated_weights_first_and_keeps_the_best_check() {
    use buridan_learner::train::StopReason;
    let mut cfg = imitating_rm_1_1_to_a_greedy_stop(true);

    let (summary, rows) = stopped_by_the_first_update_s_check(&cfg);
    let seen: Vec<_> = rows.iter().map(|r| (r.update, r.solved)).collect();
    assert_eq!(
        seen,
        [(0, 8), (1, 8)],
        "the imitated weights, then update 1's"
    );
    assert_eq!(summary.kept_check, Some(rows[0]), "the earlier on a tie");

    // Without imitation nothing passes: a check before the first update,
    // one every 4,000 env steps, one after the last update; the kept one
    // solved the most, the earliest of those.
    let dir = tempfile::tempdir().unwrap();
    cfg.imitation = None;
    cfg.run.steps = 9_000;
    let summary = train(&cfg, dir.path(), &mut Record::default()).unwrap();
    assert_eq!(summary.stop_reason, StopReason::Budget, "{summary:?}");
    let rows = greedy_records(dir.path());
    assert_eq!(rows[0].update, 0, "{rows:?}");
    assert_eq!(rows.last().unwrap().update, summary.updates, "{rows:?}");
    let most = rows.iter().map(|r| r.solved).max().unwrap();
    let best = rows.iter().find(|r| r.solved == most).copied();
    assert_eq!(summary.kept_check, best, "{rows:?}");
}

/// `keep_best`: weights that pass their check before the first update
/// (the imitated policy solves rm-1.1) stop the run after one train batch,
/// which they play, whatever that update does: a learning rate that wrecks
/// the policy in one update leaves the run's training episodes and its
/// final checkpoint those of the imitated weights (on rm-1.1 the recipe's
/// first PPO update once left a greedy policy that solved none of 200
/// held-out episodes, and the training episodes after it lowered the run's
/// return).
#[test]
fn a_run_that_starts_learned_stops_after_one_batch_and_keeps_its_start() {
    use buridan_learner::train::StopReason;
    let mut cfg = imitating_rm_1_1_to_a_greedy_stop(true);
    cfg.algorithm.ppo_mut().unwrap().lr = 0.5;
    let dir = tempfile::tempdir().unwrap();
    let summary = train(&cfg, dir.path(), &mut Record::default()).unwrap();
    assert_eq!(summary.stop_reason, StopReason::Greedy, "{summary:?}");
    assert_eq!(summary.updates, 1, "{summary:?}");
    assert!(summary.success_rate >= 0.9, "{summary:?}");
    let rows = greedy_records(dir.path());
    assert_eq!((rows[0].update, rows[0].solved), (0, 8), "{rows:?}");
    assert_eq!(summary.kept_check, Some(rows[0]), "{rows:?}");
    let kept = Policy::load(&dir.path().join("checkpoints/final")).unwrap();
    let map = std::sync::Arc::new(buridan_env::Map::load("rm-1.1").unwrap());
    let env = buridan_learner::train::env_config(&cfg, 42);
    let episodes = buridan_learner::train::rollout::rollout(
        &kept,
        map,
        env,
        8,
        8,
        buridan_policy::ActMode::Greedy,
        42,
    )
    .unwrap();
    assert!(episodes.iter().all(|e| e.success), "{episodes:?}");
}

/// What the probe tests play with: the imitated rm-1.1 policy (solves
/// every held-out episode), a fresh one (solves none), a policy to load
/// either into, the map and its env, and a probe on `check` writing into
/// `dir`.
struct ProbeBench {
    imitated: Policy,
    fresh: Policy,
    policy: Policy,
    ground: buridan_learner::train::stop::Ground,
    probe: buridan_learner::train::stop::GreedyProbe,
}

impl ProbeBench {
    fn new(dir: &std::path::Path, check: buridan_learner::train::stop::GreedyCheck) -> Self {
        buridan_policy::threads::pin_threads(1);
        let mut cfg = imitating_rm_1_1();
        cfg.run.steps = 0;
        train(&cfg, &dir.join("im"), &mut Record::default()).unwrap();
        let imitated = Policy::load(&dir.join("im/checkpoints/final")).unwrap();
        let policy = Policy::new(imitated.spec().clone(), 7).unwrap();
        let fresh = Policy::new(imitated.spec().clone(), 7).unwrap();
        Self {
            imitated,
            fresh,
            policy,
            ground: buridan_learner::train::stop::Ground {
                map: std::sync::Arc::new(buridan_env::Map::load("rm-1.1").unwrap()),
                env: buridan_learner::train::env_config(&cfg, 0),
                stepping_aside: false,
            },
            probe: buridan_learner::train::stop::GreedyProbe::new(check, dir).unwrap(),
        }
    }

    /// Checks `weights` as the weights of update `update`; whether they pass.
    fn check(&mut self, update: u64, imitated: bool) -> bool {
        let weights = if imitated {
            &self.imitated
        } else {
            &self.fresh
        };
        self.policy.copy_from(weights).unwrap();
        let at = buridan_learner::train::target::Mark {
            update,
            env_steps: 1_000 * update,
            wall_seconds: update as f64,
        };
        self.probe.run(&self.policy, &self.ground, at).unwrap()
    }

    /// The probe's choice, with the fresh weights in the policy before it.
    fn restore_best(
        &self,
    ) -> (
        buridan_learner::train::stop::GreedyRecord,
        Option<buridan_learner::train::stop::FinalRecord>,
    ) {
        self.policy.copy_from(&self.fresh).unwrap();
        self.probe
            .restore_best(&self.policy, &self.ground)
            .unwrap()
            .unwrap()
    }

    fn holds_the_imitated_weights(&self) -> bool {
        self.policy.weights(0).unwrap() == self.imitated.weights(0).unwrap()
    }
}

/// A probe with `keep_best` puts back the weights of its best check: a
/// policy that solves the held-out episodes, then a fresh one in its place
/// that does not, and the first one's weights return.
#[test]
fn a_probe_restores_the_weights_of_its_best_check() {
    use buridan_learner::train::stop::GreedyCheck;
    let dir = tempfile::tempdir().unwrap();
    let check = GreedyCheck {
        success: 1.0,
        episodes: 8,
        every: 1,
        keep_best: true,
        finalists: None,
    };
    let mut bench = ProbeBench::new(dir.path(), check);
    assert!(bench.check(0, true));
    assert!(!bench.check(1, false));
    let (kept, replay) = bench.restore_best();
    assert_eq!((kept.update, kept.solved, replay), (0, 8, None));
    assert!(
        bench.holds_the_imitated_weights(),
        "the imitated weights are back"
    );
    assert!(!dir
        .path()
        .join(buridan_learner::train::stop::FINALISTS_FILE)
        .exists());
}

/// Checks of 8 episodes, every one a candidate, and 2 finalists replayed
/// on 12 episodes.
fn two_finalists() -> buridan_learner::train::stop::GreedyCheck {
    buridan_learner::train::stop::GreedyCheck {
        success: 1.0,
        episodes: 8,
        every: 1,
        keep_best: true,
        finalists: Some(buridan_learner::train::stop::Finalists {
            count: 2,
            episodes: 12,
        }),
    }
}

/// `[stop.greedy.finalists]`: the probe keeps its two best checks (the
/// earlier among equals) and replays both on the same final episodes; the
/// kept weights are the finalist that solved the most of them (the
/// earlier on a tie), each replay a row of `finalists.csv`.
#[test]
fn finalists_are_replayed_on_the_final_episodes_and_the_best_replay_is_kept() {
    use buridan_learner::train::stop::{FinalRecord, FINALISTS_FILE};
    let dir = tempfile::tempdir().unwrap();
    let mut bench = ProbeBench::new(dir.path(), two_finalists());
    // Updates 0 and 2 play the fresh weights, 1 and 3 the imitated ones:
    // the two best checks are updates 1 and 3.
    for update in 0..4 {
        bench.check(update, update % 2 == 1);
    }
    let (kept, replay) = bench.restore_best();
    assert_eq!(
        (kept.update, kept.solved),
        (1, 8),
        "the earlier of two equal replays"
    );
    let replay = replay.expect("two finalists replayed");
    assert_eq!((replay.update, replay.solved, replay.episodes), (1, 12, 12));
    assert!(bench.holds_the_imitated_weights());
    let rows: Vec<FinalRecord> = csv::Reader::from_path(dir.path().join(FINALISTS_FILE))
        .unwrap()
        .deserialize()
        .collect::<Result<_, _>>()
        .unwrap();
    let seen: Vec<_> = rows
        .iter()
        .map(|r| (r.update, r.check_solved, r.solved))
        .collect();
    assert_eq!(seen, [(1, 8, 12), (3, 8, 12)], "{rows:?}");
}

/// The replay, not the check, decides among finalists: the imitated
/// weights checked on episodes cut to one step (none solvable) tie with
/// the fresh weights' earlier check, and the replay on whole episodes
/// keeps them, where the checks alone would keep the earlier, fresh ones.
#[test]
fn the_final_replay_overrules_the_order_of_the_checks() {
    let dir = tempfile::tempdir().unwrap();
    let mut bench = ProbeBench::new(dir.path(), two_finalists());
    assert!(!bench.check(0, false));
    let whole = bench.ground.env.clone();
    bench.ground.env.t_max = 1;
    assert!(!bench.check(1, true));
    bench.ground.env = whole;
    let (kept, replay) = bench.restore_best();
    assert_eq!((kept.update, kept.solved), (1, 0), "the imitated weights");
    assert_eq!(replay.map(|r| r.solved), Some(12));
    assert!(bench.holds_the_imitated_weights());
}

/// With finalists a check's pass ends the run only if the same weights
/// reach the level on the final episodes: the imitated weights pass and
/// are confirmed (all 12 final episodes, booked in `greedy.csv`); fresh
/// weights reach nothing there; a check that fails is not replayed.
#[test]
fn a_pass_stands_only_if_the_final_episodes_confirm_it() {
    let dir = tempfile::tempdir().unwrap();
    let mut bench = ProbeBench::new(dir.path(), two_finalists());
    assert!(bench.check(0, true));
    assert!(!bench.check(1, false));
    let rows = greedy_records(dir.path());
    let seen: Vec<_> = rows.iter().map(|r| (r.solved, r.confirmed)).collect();
    assert_eq!(seen, [(8, Some(12)), (0, None)]);
    bench.policy.copy_from(&bench.fresh).unwrap();
    assert_eq!(
        bench.probe.confirm(&bench.policy, &bench.ground).unwrap(),
        (false, Some(0))
    );
    bench.policy.copy_from(&bench.imitated).unwrap();
    assert_eq!(
        bench.probe.confirm(&bench.policy, &bench.ground).unwrap(),
        (true, Some(12))
    );
}

/// A polish is kept only if its weights solve more of the final
/// held-out episodes than the finalist it started from, raw and through
/// `shield-lanes=16` together: a "polish" that left the fresh weights
/// (none solved raw; the shield's progress fallback walks some home) gives
/// the imitated finalist back; one that left the imitated weights over a
/// fresh finalist is kept.
#[test]
fn a_polish_is_kept_only_if_it_solves_more_final_episodes_than_its_finalist() {
    let dir = tempfile::tempdir().unwrap();
    let mut bench = ProbeBench::new(dir.path(), two_finalists());
    bench.check(0, true);
    bench.check(1, true);
    let (_, replay) = bench.restore_best();
    let replay = replay.expect("two finalists replayed");
    let before = bench
        .probe
        .unpolished(&bench.policy, &bench.ground, replay, 1)
        .unwrap();
    assert_eq!((before.kept.solved, before.shielded), (12, 12));
    bench.policy.copy_from(&bench.fresh).unwrap();
    let judged = bench
        .probe
        .judge_polish(&bench.policy, &bench.ground, &before)
        .unwrap();
    assert_eq!(
        (
            judged.episodes,
            judged.solved,
            judged.kept_solved,
            judged.kept_shielded,
            judged.polished_kept
        ),
        (12, 0, 12, 12, false)
    );
    assert!(judged.shielded < 12, "{judged:?}");
    assert!(
        bench.holds_the_imitated_weights(),
        "the finalist's weights are back"
    );

    let fresh_finalist = buridan_learner::train::stop::FinalRecord {
        solved: 0,
        ..replay
    };
    bench.policy.copy_from(&bench.fresh).unwrap();
    let before = bench
        .probe
        .unpolished(&bench.policy, &bench.ground, fresh_finalist, 1)
        .unwrap();
    assert_eq!(before.shielded, judged.shielded, "the same plays");
    bench.policy.copy_from(&bench.imitated).unwrap();
    let judged = bench
        .probe
        .judge_polish(&bench.policy, &bench.ground, &before)
        .unwrap();
    assert_eq!(
        (judged.solved, judged.shielded, judged.polished_kept),
        (12, 12, true)
    );
    assert!(
        bench.holds_the_imitated_weights(),
        "the polished weights stay"
    );
}

#[test]
fn a_run_under_execution_delays_trains_and_keeps_them_in_its_config() {
    buridan_policy::threads::pin_threads(1);
    let dir = tempfile::tempdir().unwrap();
    let cfg = TrainConfig {
        delay: 0.3,
        ..tiny(Algo::Ppo, Mode::Ctde)
    };
    let mut rec = Record::default();
    let s = train(&cfg, &dir.path().join("run"), &mut rec).unwrap();
    assert_eq!(s.env_steps, 800);
    let saved = TrainConfig::from_toml_file(&dir.path().join("run/config.toml")).unwrap();
    assert_eq!(saved.delay, 0.3);
    assert_eq!(buridan_learner::train::env_config(&saved, 0).delay, 0.3);
}
