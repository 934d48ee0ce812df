//! The equivalent command lines and the controllers of an experiment's cells.

use std::path::{Path, PathBuf};

use buridan_env::Starts;
use buridan_eval::by_name::{Act, Controller, ControllerParseError, Portfolio};

use super::{is_mixture, EvalCell, Evaluated, Experiment, TrainCell};
use crate::resolve::{resolve, ResolveError, RunArgs};
use buridan_learner::train::TrainConfig;

impl Experiment {
    /// The controller of an evaluation cell (a planner's name was checked
    /// when the study file was read, not when a plan file is).
    pub fn controller(
        &self,
        cell: &EvalCell,
        out: &Path,
    ) -> Result<Controller, ControllerParseError> {
        match &cell.evaluated {
            Evaluated::Policy { train, actions } => {
                let planner = self
                    .eval
                    .rescue_planner
                    .as_deref()
                    .and_then(|p| p.parse::<Portfolio>().ok());
                let run = out.join(&self.train[*train].run_dir);
                Ok(actions.controller_for(&run, planner.as_ref()))
            }
            Evaluated::Planner => cell.method.parse(),
        }
    }

    /// The planner time limit of an evaluation cell, seconds: the rescue's
    /// for policies in a planner net, the planners' otherwise.
    pub fn time_limit(&self, cell: &EvalCell) -> f64 {
        match &cell.evaluated {
            Evaluated::Policy { actions, .. } if actions.controller().has_net() => {
                self.eval.rescue_time
            }
            _ => self.eval.time_limit,
        }
    }

    /// The equivalent `learner eval` command line of an evaluation cell:
    /// a controller whose policies all sample is written greedy, with
    /// `--sample`.
    pub fn eval_command(&self, cell: &EvalCell, out: &Path) -> String {
        let e = &self.eval;
        let (controller, sample) = match (&cell.evaluated, self.controller(cell, out)) {
            (Evaluated::Policy { .. }, Ok(c)) => {
                let policies = c.policies();
                let sample = !policies.is_empty() && policies.iter().all(|p| p.act == Act::Sampled);
                if sample {
                    (c.with_act(Act::Greedy).to_string(), true)
                } else {
                    (c.to_string(), false)
                }
            }
            _ => (cell.method.clone(), false),
        };
        let mut args = vec![
            "learner".to_string(),
            "eval".into(),
            "--map".into(),
            cell.layout.clone(),
            "--agents".into(),
            cell.agents.to_string(),
            "--episodes".into(),
            e.episodes.to_string(),
            "--seed".into(),
            e.seed.to_string(),
            "--starts".into(),
            match e.starts {
                Starts::Random => "random".into(),
                Starts::Fixed => "fixed".into(),
            },
            "--t-max".into(),
            e.t_max.to_string(),
            "--controller".into(),
            controller,
        ];
        if sample {
            args.push("--sample".into());
        }
        match &cell.evaluated {
            Evaluated::Policy { actions, .. } => {
                if actions.controller().has_net() {
                    args.extend(["--time-limit".into(), self.time_limit(cell).to_string()]);
                }
            }
            Evaluated::Planner => args.extend([
                "--time-limit".into(),
                self.time_limit(cell).to_string(),
                "--memory-limit".into(),
                e.memory_limit.to_string(),
            ]),
        }
        args.extend(["--out".into(), out.join(&cell.dir).display().to_string()]);
        shell_join(&args)
    }
}

impl TrainCell {
    /// The `learner train` arguments of this cell in experiment directory `out`
    /// (resuming from the run directory's newest checkpoint if it has one).
    pub fn run_args(&self, out: &Path) -> RunArgs {
        let mixture = is_mixture(&self.layout);
        RunArgs {
            map: (!mixture).then(|| self.layout.clone()),
            maps: mixture.then(|| self.layout.clone()),
            config: self.config.clone(),
            steps: self.steps,
            seed: Some(self.seed),
            resume: Some(PathBuf::from("auto")),
            overrides: self.set.clone(),
            no_stop: self.no_stop,
            out: out.join(&self.run_dir),
            ..RunArgs::default()
        }
    }

    /// The resolved configuration, exactly as `learner train` resolves it.
    pub fn config_in(&self, out: &Path) -> Result<TrainConfig, ResolveError> {
        resolve(&self.run_args(out))
    }

    /// The equivalent `learner train` command line.
    pub fn command(&self, out: &Path) -> String {
        let a = self.run_args(out);
        let mut args = vec!["learner".to_string(), "train".into()];
        if let Some(config) = &self.config {
            args.extend(["--config".into(), config.display().to_string()]);
        }
        args.extend([
            if is_mixture(&self.layout) {
                "--maps".into()
            } else {
                "--map".into()
            },
            self.layout.clone(),
            "--seed".into(),
            self.seed.to_string(),
        ]);
        if let Some(s) = self.steps {
            args.extend(["--steps".into(), s.to_string()]);
        }
        for s in &self.set {
            args.extend(["--set".into(), s.clone()]);
        }
        if self.no_stop {
            args.push("--no-stop".into());
        }
        args.extend([
            "--resume".into(),
            "auto".into(),
            "--out".into(),
            a.out.display().to_string(),
        ]);
        shell_join(&args)
    }
}

/// Joins arguments into a shell command line, quoting where needed.
///
/// ```
/// assert_eq!(buridan_experiment::plan::shell_join(&["a".into(), "b c".into(), "x=[1, 2]".into()]), "a 'b c' 'x=[1, 2]'");
/// ```
pub fn shell_join(args: &[String]) -> String {
    args.iter()
        .map(|a| {
            let plain = !a.is_empty()
                && a.chars()
                    .all(|c| c.is_ascii_alphanumeric() || "-_./:=,+@%".contains(c));
            if plain {
                a.clone()
            } else {
                format!("'{}'", a.replace('\'', r"'\''"))
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}
