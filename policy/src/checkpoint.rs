//! Where a training run keeps its checkpoints: the one layout the trainer
//! writes and every reader (evaluation, `--resume`, a study) resolves.
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

/// Resolves a checkpoint argument: a checkpoint directory itself, or a run
/// directory (its final checkpoint, else its newest `update-*`).
///
/// ```
/// let dir = tempfile::tempdir().unwrap();
/// assert!(buridan_policy::checkpoint::resolve(dir.path()).is_err());
/// ```
pub fn resolve(dir: &Path) -> Result<PathBuf, PolicyError> {
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
