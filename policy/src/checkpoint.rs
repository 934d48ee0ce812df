//! Where a training run keeps its checkpoints: the one layout the trainer
//! writes and every reader (evaluation, `--resume`, a study) resolves.
//!
//! Pretrained policies of the repository's `models/` folder are named
//! `model:NAME` wherever a checkpoint directory is accepted ([`resolve`],
//! [`model_dir`]).
//!
//! ```text
//! OUT/checkpoints/update-000010/    every `checkpoint_every` updates
//! OUT/checkpoints/final/            at the end of the run
//!     spec.json, model.safetensors  the policy (Policy::save, Policy::load)
//!     optimizer.safetensors, trainer.json, config.toml   the trainer's, for resume
//! ```
//!
//! ```
//! use buridan_policy::checkpoint;
//! let out = std::path::Path::new("runs/a");
//! assert_eq!(checkpoint::update_dir(out, 10), out.join("checkpoints/update-000010"));
//! assert_eq!(checkpoint::final_dir(out), out.join("checkpoints/final"));
//! ```

use std::path::{Path, PathBuf};

use crate::error::PolicyError;
use crate::policy::SPEC_FILE;

/// The folder of a run directory that holds its checkpoints.
pub const CHECKPOINTS_DIR: &str = "checkpoints";
/// The checkpoint written when a run ends.
pub const FINAL_DIR: &str = "final";
/// The trainer's counters inside a checkpoint.
pub const TRAINER_FILE: &str = "trainer.json";
/// The optimiser moments inside a checkpoint.
pub const OPTIMIZER_FILE: &str = "optimizer.safetensors";
/// The run configuration inside a checkpoint (and in the run directory).
pub const CONFIG_FILE: &str = "config.toml";
/// The prefix of a checkpoint argument that names a pretrained model
/// (`model:rm-2.1` is the folder `models/rm-2.1`).
pub const MODEL_PREFIX: &str = "model:";
/// The environment variable that names the folder of pretrained models
/// (searched first; see [`models_dirs`]).
pub const MODELS_ENV: &str = "BURIDAN_MODELS";
/// A pretrained model's description inside its folder.
pub const MANIFEST_FILE: &str = "manifest.toml";

/// `OUT/checkpoints`.
pub fn checkpoints_dir(out: &Path) -> PathBuf {
    out.join(CHECKPOINTS_DIR)
}

/// `OUT/checkpoints/update-NNNNNN`, the checkpoint after `updates` updates.
pub fn update_dir(out: &Path, updates: u64) -> PathBuf {
    checkpoints_dir(out).join(format!("update-{updates:06}"))
}

/// `OUT/checkpoints/final`, the checkpoint of a finished run.
pub fn final_dir(out: &Path) -> PathBuf {
    checkpoints_dir(out).join(FINAL_DIR)
}

/// Whether `dir` is a checkpoint (it holds a policy spec).
pub fn is_checkpoint(dir: &Path) -> bool {
    dir.join(SPEC_FILE).is_file()
}

/// The folders searched for pretrained models, in order, those that exist:
/// `$BURIDAN_MODELS`, `models/` in the current directory, and the
/// `models/` folder of the checkout this crate was built from (so that
/// `cargo run` works from a fresh clone in any directory).
pub fn models_dirs() -> Vec<PathBuf> {
    let mut dirs = Vec::new();
    if let Some(env) = std::env::var_os(MODELS_ENV) {
        dirs.push(PathBuf::from(env));
    }
    dirs.push(PathBuf::from("models"));
    dirs.push(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("..")
            .join("models"),
    );
    let mut seen: Vec<PathBuf> = Vec::new();
    dirs.retain(|d| {
        let Ok(canon) = d.canonicalize() else {
            return false;
        };
        if !canon.is_dir() || seen.contains(&canon) {
            return false;
        }
        seen.push(canon);
        true
    });
    dirs
}

/// The names of the pretrained models found in [`models_dirs`]: their
/// folders that hold a checkpoint, sorted, each once.
pub fn available_models() -> Vec<String> {
    let mut names: Vec<String> = models_dirs()
        .iter()
        .filter_map(|d| std::fs::read_dir(d).ok())
        .flatten()
        .filter_map(|e| e.ok())
        .filter(|e| is_checkpoint(&e.path()))
        .filter_map(|e| e.file_name().to_str().map(str::to_owned))
        .collect();
    names.sort();
    names.dedup();
    names
}

/// The folder of the pretrained model `name` (`rm-2.1`, without the
/// `model:` prefix): the first of [`models_dirs`] that holds it as a
/// checkpoint. An unknown name is [`PolicyError::UnknownModel`], which
/// lists the names there are.
pub fn model_dir(name: &str) -> Result<PathBuf, PolicyError> {
    let plain = !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'))
        && !name.starts_with('.');
    if plain {
        for dir in models_dirs() {
            let candidate = dir.join(name);
            if is_checkpoint(&candidate) {
                return Ok(candidate);
            }
        }
    }
    Err(PolicyError::UnknownModel {
        name: name.to_owned(),
        available: available_models(),
    })
}

/// Resolves a checkpoint argument: `model:NAME` (a pretrained model,
/// [`model_dir`]), a checkpoint directory itself, or a run directory (its
/// final checkpoint, else its newest `update-*`).
///
/// ```
/// let dir = tempfile::tempdir().unwrap();
/// assert!(buridan_policy::checkpoint::resolve(dir.path()).is_err());
/// let err = buridan_policy::checkpoint::resolve("model:no-such-model".as_ref()).unwrap_err();
/// assert!(err.to_string().contains("no-such-model"));
/// ```
pub fn resolve(dir: &Path) -> Result<PathBuf, PolicyError> {
    if let Some(name) = dir.to_str().and_then(|s| s.strip_prefix(MODEL_PREFIX)) {
        return model_dir(name);
    }
    if is_checkpoint(dir) {
        return Ok(dir.to_path_buf());
    }
    let last = final_dir(dir);
    if is_checkpoint(&last) {
        return Ok(last);
    }
    let root = checkpoints_dir(dir);
    let entries = std::fs::read_dir(&root).map_err(|_| PolicyError::NoCheckpoint {
        dir: dir.to_path_buf(),
    })?;
    let mut updates: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| is_checkpoint(p))
        .collect();
    // `update-NNNNNN` sorts by update number as long as runs stay below 10⁶ updates.
    updates.sort();
    updates.pop().ok_or(PolicyError::NoCheckpoint { dir: root })
}
