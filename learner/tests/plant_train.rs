//! Training on the AGV plant (`plant = "dissertation"`): the run's envs are
//! plant envs, the policy reads the plant observation, and everything that
//! counts success stays well defined though plant episodes only truncate.

use buridan_learner::train::{
    final_checkpoint, train, Algorithm, ModelConfig, NoProgress, PpoConfig, RunConfig, Task,
    TrainConfig,
};
use buridan_policy::{Mode, Policy};

fn tiny(mode: Mode) -> TrainConfig {
    TrainConfig {
        algorithm: Algorithm::Ppo(PpoConfig {
            train_batch: 160,
            minibatch: 80,
            epochs: 2,
            ..PpoConfig::default()
        }),
        mode,
        task: Task::Plant("dissertation".into()),
        agents: 2,
        // Short episodes, so that some finish within the budget.
        t_max: 40,
        model: ModelConfig {
            hidden: vec![16, 16],
            ..ModelConfig::default()
        },
        run: RunConfig {
            steps: 480,
            envs_per_actor: 4,
            fragment_len: 20,
            checkpoint_every: 0,
            ..RunConfig::default()
        },
        ..TrainConfig::default()
    }
}

#[test]
fn a_plant_run_trains_and_reports_without_success() {
    buridan_policy::threads::pin_threads(1);
    for (mode, obs_dim) in [(Mode::Ctde, 11), (Mode::Cte, 4 + 6 * 2)] {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("run");
        let s = train(&tiny(mode), &out, &mut NoProgress).unwrap();
        assert_eq!((s.env_steps, s.updates), (480, 3));
        assert_eq!(s.map, "plant:dissertation");
        assert_eq!(s.maps, ["plant:dissertation"]);
        // 4 envs × 120 steps each: 3 episodes of 40 steps per env.
        assert_eq!(s.episodes, 12);
        assert_eq!(s.episode_len_mean, 40.0);
        assert!(
            s.episode_return_mean.is_finite(),
            "{}",
            s.episode_return_mean
        );
        assert_eq!(s.success_rate, 0.0);
        assert!(s.time_to_target.is_empty(), "{:?}", s.time_to_target);
        assert!(s.success_by_map.is_empty());
        let policy = Policy::load(&final_checkpoint(&out)).unwrap();
        assert_eq!(policy.spec().obs_dim, obs_dim, "{mode:?}");
        assert_eq!(policy.spec().maps, ["plant:dissertation"]);
        let config = std::fs::read_to_string(out.join("config.toml")).unwrap();
        assert!(config.contains("plant = \"dissertation\""), "{config}");
        assert!(!config.contains("map ="), "{config}");
        let csv = std::fs::read_to_string(out.join("metrics.csv")).unwrap();
        assert_eq!(csv.lines().count(), 4, "{csv}");
    }
}

#[test]
fn a_plant_run_resumes_from_its_checkpoint() {
    buridan_policy::threads::pin_threads(1);
    let dir = tempfile::tempdir().unwrap();
    let (first, second) = (dir.path().join("a"), dir.path().join("b"));
    train(&tiny(Mode::Ctde), &first, &mut NoProgress).unwrap();
    let mut cfg = tiny(Mode::Ctde);
    cfg.run.steps = 640;
    cfg.run.resume = Some(final_checkpoint(&first));
    let s = train(&cfg, &second, &mut NoProgress).unwrap();
    assert_eq!((s.env_steps, s.updates), (640, 4));
    assert!(s.time_to_target.is_empty());
}

#[test]
fn too_many_agvs_for_the_plant_are_refused_before_training() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = TrainConfig {
        agents: 9,
        ..tiny(Mode::Ctde)
    };
    let err = train(&cfg, dir.path(), &mut NoProgress).unwrap_err();
    let text = buridan_env::error::error_chain(&err);
    assert!(
        text.contains("9 agents do not fit map 'plant:dissertation'"),
        "{text}"
    );
    assert!(text.contains("starts for 1 to 4 AGVs"), "{text}");
}
