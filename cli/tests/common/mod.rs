//! Helpers shared by the CLI's integration tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

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
