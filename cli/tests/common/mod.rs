//! Helpers shared by the CLI's integration tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use buridan_cli::eval::EvalArgs;
use buridan_cli::train::TrainArgs;
use clap::Parser;

/// `learner eval` arguments as the command line gives them: `flags` after
/// `eval`, clap's defaults for the rest — so tests name only what they
/// set, and a new flag needs no edit here.
pub fn eval_args<S: AsRef<str>>(flags: &[S]) -> EvalArgs {
    #[derive(Parser)]
    struct Eval {
        #[command(flatten)]
        args: EvalArgs,
    }
    let argv = std::iter::once("eval").chain(flags.iter().map(AsRef::as_ref));
    Eval::try_parse_from(argv)
        .unwrap_or_else(|e| panic!("bad eval flags: {e}"))
        .args
}

/// A PPO config on rm-1.1 small enough for a trial of a few thousand steps.
pub fn tiny_config(dir: &Path) -> PathBuf {
    let path = dir.join("tiny.toml");
    std::fs::write(
        &path,
        r#"
algo = "ppo"
mode = "ctde"
map = "rm-1.1"
agents = 2
starts = "fixed"
envs_per_actor = 4
checkpoint_every = 1
[ppo]
train_batch = 1000
minibatch = 500
epochs = 2
"#,
    )
    .unwrap();
    path
}

/// `learner train` arguments of a PPO run on rm-1.1 with 2 agents, 3000
/// steps: small enough for a test (the recipe's feed-forward sibling: no
/// LSTM, no imitation).
pub fn train_args(out: PathBuf) -> TrainArgs {
    TrainArgs {
        map: Some("rm-1.1".into()),
        maps: None,
        plant: None,
        agents: Some(2),
        algo: Some(buridan_learner::train::Algo::Ppo),
        mode: Some(buridan_policy::Mode::Ctde),
        starts: Some(buridan_env::Starts::Fixed),
        rules: None,
        config: None,
        steps: Some(3000),
        seed: Some(3),
        device: None,
        resume: None,
        metrics: None,
        overrides: vec![
            "ppo.train_batch=1000".into(),
            "ppo.minibatch=500".into(),
            "ppo.epochs=2".into(),
            "envs_per_actor=4".into(),
            "lstm=false".into(),
        ],
        no_imitation: true,
        no_stop: false,
        out,
        quiet: true,
        stop_when_stdin_closes: false,
        dashboard: Default::default(),
    }
}
