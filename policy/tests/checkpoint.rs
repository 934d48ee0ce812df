//! The checkpoint layout: which checkpoint a path names.

use buridan_policy::checkpoint::{self, resolve};
use buridan_policy::{Mode, ModelSpec, Policy, PolicyError};

fn save_at(dir: &std::path::Path) {
    Policy::new(ModelSpec::new(Mode::Ctde, 2, 4), 0)
        .unwrap()
        .save(dir)
        .unwrap();
}

#[test]
fn a_run_directory_resolves_to_final_else_the_newest_update() {
    let out = tempfile::tempdir().unwrap();
    let out = out.path();
    assert!(matches!(
        resolve(out),
        Err(PolicyError::NoCheckpoint { .. })
    ));
    save_at(&checkpoint::update_dir(out, 2));
    save_at(&checkpoint::update_dir(out, 10));
    // An update folder without a policy is not a checkpoint.
    std::fs::create_dir_all(checkpoint::update_dir(out, 12)).unwrap();
    assert_eq!(resolve(out).unwrap(), checkpoint::update_dir(out, 10));
    save_at(&checkpoint::final_dir(out));
    assert_eq!(resolve(out).unwrap(), checkpoint::final_dir(out));
    // A checkpoint directory names itself.
    let two = checkpoint::update_dir(out, 2);
    assert_eq!(resolve(&two).unwrap(), two);
}
