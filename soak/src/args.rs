//! The soak's flags (`learner bench soak`), their checks, and the learner's
//! configuration they name.

use std::path::{Path, PathBuf};

use buridan_experiment::resolve::{resolve, RunArgs};
use buridan_learner::train::TrainConfig;

use crate::SoakError;

/// Arguments of `learner bench soak`.
#[derive(Debug, Clone, clap::Args)]
pub struct SoakArgs {
    /// How long to run, in minutes (fractions allowed).
    #[arg(long, default_value_t = 30.0)]
    pub minutes: f64,
    /// The learner's TrainConfig.
    #[arg(long, default_value = "learner/configs/impala-ctde-rm-2.1.toml")]
    pub config: PathBuf,
    /// `KEY=VALUE` overrides of the config (as `learner serve --set`).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub overrides: Vec<String>,
    /// Actor processes.
    #[arg(long, default_value_t = 2)]
    pub actors: usize,
    /// Mean seconds between random actor kills (exponentially distributed).
    #[arg(long, default_value_t = 60.0)]
    pub kill_every: f64,
    /// Longest wait before a killed actor is restarted, in seconds
    /// (uniform from a tenth of it).
    #[arg(long, default_value_t = 5.0)]
    pub restart_within: f64,
    /// Training success over the last 100 episodes the run must reach.
    #[arg(long, default_value_t = 0.8)]
    pub target: f64,
    /// Seed of the run, the kills and the misbehaving client.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Seconds between samples of memory and metrics.
    #[arg(long, default_value_t = 5.0)]
    pub sample_every: f64,
    /// The learner's `--session-idle-timeout` (the misbehaving client
    /// checks its idle sessions expire).
    #[arg(long, default_value_t = 5.0)]
    pub session_idle_timeout: f64,
    /// The learner's `--max-sessions` (default: actors + 8); the
    /// misbehaving client probes it.
    #[arg(long)]
    pub max_sessions: Option<usize>,
    /// The `actor` executable (default: `actor` beside this one).
    #[arg(long)]
    pub actor_exe: Option<PathBuf>,
    /// Leave the misbehaving client out.
    #[arg(long)]
    pub no_misbehave: bool,
    /// Output directory (must not hold an earlier soak).
    #[arg(long)]
    pub out: PathBuf,
}

impl SoakArgs {
    /// Refuses flags the soak cannot run with.
    pub fn validate(&self) -> Result<(), SoakError> {
        if !(self.minutes > 0.0 && self.minutes.is_finite()) {
            return Err(SoakError::Flag("--minutes must be positive"));
        }
        if self.actors == 0 {
            return Err(SoakError::Flag("--actors must be at least 1"));
        }
        if !(self.kill_every > 0.0 && self.sample_every > 0.0 && self.restart_within >= 0.0) {
            return Err(SoakError::Flag(
                "--kill-every and --sample-every must be positive",
            ));
        }
        if !(0.0..=1.0).contains(&self.target) {
            return Err(SoakError::Flag("--target is a success rate in [0, 1]"));
        }
        Ok(())
    }

    /// `--set KEY=VALUE` for each override, as `learner serve` takes them.
    pub fn set_flags(&self) -> impl Iterator<Item = &str> {
        self.overrides.iter().flat_map(|s| ["--set", s.as_str()])
    }

    /// The learner's config file and overrides, as on its command line.
    pub fn config_line(&self) -> String {
        std::iter::once(self.config.display().to_string())
            .chain(self.set_flags().map(String::from))
            .collect::<Vec<_>>()
            .join(" ")
    }

    /// The learner's run options as `learner serve --config … --out
    /// run_dir --set …` resolves them.
    pub fn learner_config(&self, run_dir: &Path) -> Result<TrainConfig, SoakError> {
        let run = RunArgs {
            config: Some(self.config.clone()),
            overrides: self.overrides.clone(),
            out: run_dir.to_path_buf(),
            ..RunArgs::default()
        };
        Ok(resolve(&run)?)
    }
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    use super::*;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        soak: SoakArgs,
    }

    #[test]
    fn soak_flags_parse() {
        let c = Cli::try_parse_from(["soak", "--out", "x", "--minutes", "0.5"]).unwrap();
        assert_eq!(
            (c.soak.minutes, c.soak.actors, c.soak.kill_every),
            (0.5, 2, 60.0)
        );
        assert!(c.soak.validate().is_ok());
    }

    #[test]
    fn flags_out_of_range_are_refused() {
        let parse = |extra: &[&str]| {
            let argv = ["soak", "--out", "x"].iter().chain(extra).copied();
            Cli::try_parse_from(argv).unwrap().soak.validate()
        };
        assert!(parse(&["--minutes", "0"]).is_err());
        assert!(parse(&["--actors", "0"]).is_err());
        assert!(parse(&["--kill-every", "0"]).is_err());
        assert!(parse(&["--target", "1.5"]).is_err());
    }

    #[test]
    fn the_config_line_names_the_overrides_as_flags() {
        let c = Cli::try_parse_from(["soak", "--out", "x", "--config", "a.toml", "--set", "k=1"])
            .unwrap();
        assert_eq!(c.soak.config_line(), "a.toml --set k=1");
    }

    #[test]
    fn the_learner_config_is_the_file_with_its_overrides() {
        let config = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../learner/configs/impala-ctde-rm-2.1.toml"
        );
        let c = Cli::try_parse_from(["soak", "--out", "x", "--config", config, "--set", "seed=7"])
            .unwrap();
        let cfg = c.soak.learner_config(Path::new("x/run")).unwrap();
        assert_eq!(cfg.run.seed, 7);
    }
}
