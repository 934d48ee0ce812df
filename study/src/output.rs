//! A study's files: `trials.csv`, `trials.json`, `best.toml`,
//! `objective.png` and `params.png` in the study directory; for PBT also
//! `pbt.csv` (the lineage) and `pbt-schedule.csv` (the best member's
//! hyperparameters round by round).

use std::path::{Path, PathBuf};

use crate::overrides::to_table;
use crate::plot;
use crate::state::StudyState;

/// Writing an output file failed, in words.
///
/// ```
/// let e = buridan_study::output::OutputError { path: "x".into(), message: "denied".into() };
/// assert_eq!(e.to_string(), "cannot write x: denied");
/// ```
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("cannot write {path}: {message}")]
pub struct OutputError {
    /// The file.
    pub path: String,
    /// Why.
    pub message: String,
}

fn fail(path: &Path, e: impl std::fmt::Display) -> OutputError {
    OutputError {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// One row per trial: id, status, objective, episode length, last step,
/// seconds, starts, one column per parameter, run directory, error.
///
/// ```
/// # let cfg = buridan_study::StudyConfig::from_toml_str("[study]\nname = \"x\"\ntrials = 1\nsteps_per_trial = 1\n[space]\nx = { int = [1, 2] }").unwrap();
/// let state = buridan_study::state::StudyState::new(&cfg);
/// let csv = buridan_study::output::trials_csv(&state);
/// assert_eq!(csv, "id,status,objective,episode_len,last_step,seconds,starts,x,run_dir,error\n");
/// ```
pub fn trials_csv(state: &StudyState) -> String {
    let keys: Vec<&str> = state
        .config
        .space
        .params()
        .iter()
        .map(|p| p.key.as_str())
        .collect();
    let mut w = csv::Writer::from_writer(Vec::new());
    let mut header = vec![
        "id",
        "status",
        "objective",
        "episode_len",
        "last_step",
        "seconds",
        "starts",
    ];
    header.extend(&keys);
    header.extend(["run_dir", "error"]);
    let _ = w.write_record(&header);
    let opt = |x: Option<f64>| x.map(|v| v.to_string()).unwrap_or_default();
    for t in &state.trials {
        let mut row = vec![
            t.id.to_string(),
            t.status.name().to_string(),
            opt(t.score.map(|s| s.value)),
            opt(t.score.and_then(|s| s.episode_len)),
            t.last
                .as_ref()
                .map(|m| m.step.to_string())
                .unwrap_or_default(),
            format!("{:.1}", t.seconds),
            t.starts.to_string(),
        ];
        for k in &keys {
            row.push(
                t.overrides
                    .get(*k)
                    .map(|v| v.to_string())
                    .unwrap_or_default(),
            );
        }
        row.push(t.run_dir.display().to_string());
        row.push(t.error.clone().unwrap_or_default());
        let _ = w.write_record(&row);
    }
    w.into_inner()
        .ok()
        .and_then(|b| String::from_utf8(b).ok())
        .unwrap_or_default()
}

/// The best trial's overrides as a TOML configuration fragment (nested
/// sections), with a comment naming the trial and its score; `None` before
/// any trial has finished with a score.
///
/// ```
/// # let cfg = buridan_study::StudyConfig::from_toml_str("[study]\nname = \"x\"\ntrials = 1\nsteps_per_trial = 1\n[space]\nx = { int = [1, 2] }").unwrap();
/// assert!(buridan_study::output::best_toml(&buridan_study::state::StudyState::new(&cfg)).is_none());
/// ```
pub fn best_toml(state: &StudyState) -> Option<String> {
    let best = state.best()?;
    let score = best.score?;
    let mut text = format!(
        "# Best trial of study `{}`: trial {} ({}), {} = {}{}\n# Merge into the base configuration{}.\n",
        state.config.name,
        best.id,
        best.run_dir.display(),
        state.config.objective.name(),
        score.value,
        score
            .episode_len
            .map(|l| format!(", mean episode length {l:.1}"))
            .unwrap_or_default(),
        state
            .config
            .base_config
            .as_ref()
            .map(|b| format!(" {b}"))
            .unwrap_or_default(),
    );
    text.push_str(&toml::to_string(&to_table(&best.overrides)).unwrap_or_default());
    Some(text)
}

/// Writes every output of the study into `dir`; returns the files written.
///
/// ```no_run
/// # fn f(state: &buridan_study::state::StudyState) {
/// let files = buridan_study::output::write_all("runs/tune".as_ref(), state).unwrap();
/// # }
/// ```
pub fn write_all(dir: &Path, state: &StudyState) -> Result<Vec<PathBuf>, OutputError> {
    let mut files = Vec::new();
    let mut write = |name: &str, text: String| -> Result<(), OutputError> {
        let path = dir.join(name);
        std::fs::write(&path, text).map_err(|e| fail(&path, e))?;
        files.push(path);
        Ok(())
    };
    write("trials.csv", trials_csv(state))?;
    let json = serde_json::to_string_pretty(&state.trials).map_err(|e| fail(dir, e))?;
    write("trials.json", json)?;
    if let Some(best) = best_toml(state) {
        write("best.toml", best)?;
    }
    if let Some(lineage) = crate::lineage::lineage_csv(state) {
        write("pbt.csv", lineage)?;
    }
    if let Some(schedule) = crate::lineage::schedule_csv(state) {
        write("pbt-schedule.csv", schedule)?;
    }
    for (name, draw) in [
        (
            "objective.png",
            plot::objective_vs_trial as fn(&Path, &StudyState) -> _,
        ),
        ("params.png", plot::parameter_effects),
    ] {
        let path = dir.join(name);
        draw(&path, state).map_err(|e| fail(&path, e.message))?;
        files.push(path);
    }
    Ok(files)
}
