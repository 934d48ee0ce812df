//! Fuzz target of the training configuration: TOML text →
//! `TrainConfig::from_toml_file`, and `--maps` lists →
//! `WeightedMap::parse_list`. Nothing panics; an accepted config validates,
//! prints (`to_toml`) and reads back to the same config. Seeds are the
//! shipped configs (`learner/configs`, `learner/studies/base`).
//! `BURIDAN_FUZZ_CASES` sets the cases per target (default 256);
//! `scripts/fuzz.sh` runs every target with a million.

#[path = "../../env/tests/fuzz_support/mod.rs"]
mod fuzz_support;

use std::path::{Path, PathBuf};

use buridan_learner::train::{ConfigError, TrainConfig, WeightedMap};
use fuzz_support::{mutated_text, random_text, run};
use proptest::prelude::*;

/// Keys, tables and values of the config format, for insertion.
const TOML_WORDS: &[&str] = &[
    "\n[ppo]\n",
    "\n[impala]\n",
    "\n[imitation]\n",
    "\n[features]\n",
    "\n[ppo.lr_schedule]\n",
    "\nmaps = [{ name = \"rm-2.2\", weight = 2.0 }, { name = \"rm-3.1\" }]\n",
    "\nmap = \"rm-1.1\"\n",
    "\nmode = \"cte\"\n",
    "\nalgo = \"impala\"\n",
    "\nlstm = true\n",
    "\nrules = \"pogema\"\n",
    "\nstarts = \"fixed\"\n",
    "\nhidden = []\n",
    "\nt_max = 0\n",
    "\ngreedy_mix = 0.5\n",
    "\nresume = \"/nonexistent\"\n",
    "\nstop_return = nan\n",
    "lr",
    " = ",
    "=",
    "\"",
    "'",
    "[",
    "]",
    "{",
    "}",
    ",",
    "#",
    "\n",
    "true",
    "\"\"\"",
    "1979-05-27T07:32:00Z",
    "[[maps]]\nname = \"x\"\n",
];

fn repo_file_texts(dirs: &[&str]) -> Vec<String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut texts = Vec::new();
    for dir in dirs {
        let mut paths: Vec<PathBuf> = std::fs::read_dir(root.join(dir))
            .expect("shipped configs")
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|x| x == "toml"))
            .collect();
        paths.sort();
        texts.extend(paths.iter().map(|p| std::fs::read_to_string(p).unwrap()));
    }
    texts
}

/// The shipped training configs and the printed default and recipe.
fn seeds() -> Vec<String> {
    let mut texts = repo_file_texts(&["configs", "studies/base"]);
    texts.push(TrainConfig::default().to_toml());
    texts.push(TrainConfig::recipe().to_toml());
    texts
}

/// A scratch directory in memory where there is one (`/dev/shm`): writing
/// the config file to disk for every input costs milliseconds.
fn scratch_dir() -> tempfile::TempDir {
    let shm = Path::new("/dev/shm");
    if shm.is_dir() {
        if let Ok(dir) = tempfile::tempdir_in(shm) {
            return dir;
        }
    }
    tempfile::tempdir().unwrap()
}

/// Reads `text` as a config file at `path`; true if accepted (then
/// checked: it validates, and its printed form reads back to the same).
fn check_config(path: &Path, text: &str) -> Result<bool, TestCaseError> {
    std::fs::write(path, text).unwrap();
    let cfg = match TrainConfig::from_toml_file(path) {
        Ok(cfg) => cfg,
        Err(
            ConfigError::Parse { .. }
            | ConfigError::Invalid(_)
            | ConfigError::Imitation { .. }
            | ConfigError::MapAndMaps { .. }
            | ConfigError::NoMaps
            | ConfigError::BadWeight { .. }
            | ConfigError::DuplicateMap { .. }
            | ConfigError::OutOfRange { .. }
            | ConfigError::CentralOnSeveralMaps,
        ) => return Ok(false),
        Err(other) => return Err(TestCaseError::fail(format!("unexpected error: {other:?}"))),
    };
    cfg.validate()
        .map_err(|e| TestCaseError::fail(format!("accepted but invalid: {e}")))?;
    let printed = cfg.to_toml();
    std::fs::write(path, &printed).unwrap();
    let back = TrainConfig::from_toml_file(path).map_err(|e| {
        TestCaseError::fail(format!(
            "printed config does not read back: {e:?}\n{printed}"
        ))
    })?;
    // Compared as text: NaN ≠ NaN.
    prop_assert_eq!(back.to_toml(), printed);
    prop_assert!(cfg.task.is_plant() || !cfg.layouts().is_empty());
    Ok(true)
}

/// TOML text (a shipped config mutated, or random) →
/// `TrainConfig::from_toml_file`.
#[test]
fn fuzz_train_config() {
    let dir = scratch_dir();
    let path = dir.path().join("fuzz.toml");
    let text = prop_oneof![
        8 => mutated_text(seeds(), TOML_WORDS),
        1 => random_text(),
    ];
    run("train_config", text, |text| check_config(&path, &text));
}

/// `--maps` lists → `WeightedMap::parse_list`: no panic; an accepted list
/// has one non-empty name per entry, and its label lists them.
#[test]
fn fuzz_maps_list() {
    let seeds = vec![
        "rm-2.2:1,rm-3.1:2".to_string(),
        "rm-2.2, rm-3.1".to_string(),
        "a.map:0.5".to_string(),
    ];
    let text = prop_oneof![
        4 => mutated_text(seeds, &[":", ",", " ", "::", "rm-1.1", "nan", "inf", "-1"]),
        1 => random_text(),
    ];
    run("maps_list", text, |text| {
        let Ok(maps) = WeightedMap::parse_list(&text) else {
            return Ok(false);
        };
        prop_assert_eq!(maps.len(), text.split(',').count());
        for m in &maps {
            prop_assert!(!m.name.is_empty() && m.name.trim() == m.name);
        }
        let label = WeightedMap::label(&maps);
        prop_assert_eq!(label.split('+').count() >= maps.len(), true);
        Ok(true)
    });
}

/// The seeds are accepted configs (so the mutations start from valid
/// inputs), and the check can fail.
#[test]
fn fuzz_seeds_are_accepted() {
    let dir = scratch_dir();
    let path = dir.path().join("seed.toml");
    for text in seeds() {
        assert!(check_config(&path, &text).unwrap(), "{text}");
    }
}
