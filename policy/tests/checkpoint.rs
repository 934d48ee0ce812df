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

#[test]
fn a_pretrained_model_resolves_by_name_and_loads() {
    let names = checkpoint::available_models();
    for want in [
        "rm-2.1",
        "rm-2.1b",
        "rm-2.2",
        "rm-3.1",
        "pogema-warehouse",
        "plant-dissertation",
    ] {
        assert!(names.iter().any(|n| n == want), "{want} not in {names:?}");
    }
    for name in &names {
        let dir = resolve(format!("model:{name}").as_ref()).unwrap();
        assert_eq!(dir, checkpoint::model_dir(name).unwrap());
        assert!(dir.ends_with(name));
        assert!(
            dir.join(checkpoint::MANIFEST_FILE).is_file(),
            "{name} has no manifest"
        );
        Policy::load(&dir).unwrap_or_else(|e| panic!("model {name}: {e}"));
    }
    let spec = Policy::load(&resolve("model:rm-2.1".as_ref()).unwrap())
        .unwrap()
        .spec()
        .clone();
    assert_eq!(spec.mode, Mode::Ctde);
    assert!(spec.features.intent && spec.features.path);
}

#[test]
fn an_unknown_model_name_lists_the_available_ones() {
    for bad in ["no-such-model", "", "../policy", "rm-2.1/../rm-2.2"] {
        let err = resolve(format!("model:{bad}").as_ref()).unwrap_err();
        let PolicyError::UnknownModel { name, available } = &err else {
            panic!("{bad}: {err}");
        };
        assert_eq!(name, bad);
        assert!(available.iter().any(|n| n == "rm-2.1"), "{available:?}");
        let message = err.to_string();
        assert!(message.contains(&format!("'{bad}'")), "{message}");
        assert!(message.contains("rm-2.1, rm-2.1b"), "{message}");
    }
}
