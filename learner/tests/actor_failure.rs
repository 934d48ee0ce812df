//! An embedded run whose actor fails reports the actor's own error as the
//! cause, not a bare "an actor stopped".

use std::error::Error;

use buridan_actor::{CollectError, Collector};
use buridan_env::{BatchedEnv, EnvError, EpisodeStats, ObsKind, Starts};
use buridan_learner::train::{
    ActorEnv, ExchangeError, InProcess, NoProgress, Run, RunConfig, Task, TrainConfig, TrainError,
};

/// A grid env batch whose simulator breaks down after `healthy_steps`.
struct BreaksDown {
    inner: ActorEnv,
    healthy_steps: usize,
}

impl BatchedEnv for BreaksDown {
    fn num_envs(&self) -> usize {
        self.inner.num_envs()
    }
    fn agents(&self) -> usize {
        self.inner.agents()
    }
    fn kind(&self) -> ObsKind {
        self.inner.kind()
    }
    fn obs_dim(&self) -> usize {
        self.inner.obs_dim()
    }
    fn obs(&self) -> &[f32] {
        self.inner.obs()
    }
    fn masks(&self) -> &[u8] {
        self.inner.masks()
    }
    fn step(&mut self, actions: &[u8]) -> Result<(), EnvError> {
        if self.healthy_steps == 0 {
            return Err(EnvError::InvalidConfig(
                "the simulator lost its track layout".into(),
            ));
        }
        self.healthy_steps -= 1;
        self.inner.step(actions)
    }
    fn rewards(&self) -> &[f32] {
        self.inner.rewards()
    }
    fn terminated(&self) -> &[u8] {
        self.inner.terminated()
    }
    fn truncated(&self) -> &[u8] {
        self.inner.truncated()
    }
    fn final_obs(&self) -> &[f32] {
        self.inner.final_obs()
    }
    fn drain_episodes(&mut self) -> Vec<EpisodeStats> {
        self.inner.drain_episodes()
    }
}

#[test]
fn the_learner_names_the_failing_actors_cause() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = TrainConfig {
        task: Task::Grid("rm-1.1".into()),
        agents: 2,
        starts: Starts::Fixed,
        run: RunConfig {
            steps: 20_000,
            envs_per_actor: 2,
            ..RunConfig::default()
        },
        ..TrainConfig::default()
    };
    let run = Run::prepare(&cfg, dir.path()).unwrap();
    let healthy = run.collector(0).unwrap();
    let broken = Collector {
        id: 0,
        venv: BreaksDown {
            inner: healthy.venv,
            // Two fragments of 50 steps, then the fault in the third.
            healthy_steps: 120,
        },
        inference: healthy.inference,
        behaviour: healthy.behaviour,
        fragment_len: healthy.fragment_len,
        version: healthy.version,
        shield: None,
    };
    let mut exchange =
        InProcess::spawn(vec![broken], cfg.queue_capacity(), cfg.staleness(), 0).unwrap();
    let err = run.learn(&mut exchange, &mut NoProgress).unwrap_err();
    // Matched as data, no downcast:
    match &err {
        TrainError::Exchange(ExchangeError::Actor {
            actor: 0,
            source: CollectError::Env(EnvError::InvalidConfig(why)),
        }) => assert_eq!(why, "the simulator lost its track layout"),
        other => panic!("unexpected error: {other:?}"),
    }
    // …and the whole chain reads as a sentence.
    let mut chain = err.to_string();
    let mut cause = err.source();
    while let Some(c) = cause {
        chain += &format!(": {c}");
        cause = c.source();
    }
    assert_eq!(
        chain,
        "actor 0 failed: the env failed: invalid configuration: the simulator lost its track layout"
    );
}
