//! A whole study on a synthetic objective, no learner needed: TPE with
//! ASHA over three parameters of SPEC §4's PPO space, two trials at a time.
//!
//! ```sh
//! cargo run -p buridan-study --example synthetic -- /tmp/synthetic-study
//! ```
//!
//! Interrupt it (Ctrl-C) and run it again: finished trials are not rerun.

use std::path::PathBuf;

use buridan_study::{
    Measurement, Reporter, Study, StudyConfig, TrialError, TrialRunner, TrialSpec,
};

/// Success plateaus at a value set by the configuration; the curve rises
/// with steps. Stands in for `learner train`.
struct Synthetic;

impl TrialRunner for Synthetic {
    fn run(
        &self,
        spec: &TrialSpec,
        reporter: &mut dyn Reporter,
    ) -> Result<Measurement, TrialError> {
        let num = |k: &str| {
            let v = spec
                .overrides
                .get(k)
                .ok_or_else(|| TrialError::new(format!("{k} missing")))?;
            v.as_float()
                .or_else(|| v.as_integer().map(|i| i as f64))
                .ok_or_else(|| TrialError::new(format!("{k} is not a number")))
        };
        let (lr, epochs, clip) = (num("ppo.lr")?, num("ppo.epochs")?, num("ppo.clip")?);
        let plateau = (1.0
            - 0.15 * (lr.log10() + 3.0).powi(2)
            - 0.004 * (epochs - 12.0).powi(2)
            - 2.0 * (clip - 0.1).powi(2))
        .clamp(0.0, 1.0);
        let mut m = Measurement::default();
        for step in (20_000..=spec.steps).step_by(20_000) {
            let progress = 1.0 - (-(step as f64) / 300_000.0).exp();
            m = Measurement {
                step,
                train_success: Some(plateau * progress),
                train_len: Some(60.0 - 30.0 * plateau * progress),
                ..Default::default()
            };
            if !reporter.report(&m).keeps_going() {
                break;
            }
        }
        Ok(m)
    }
}

const STUDY: &str = r#"
[study]
name = "synthetic"
sampler = "tpe"
trials = 40
parallel = 2
steps_per_trial = 1_000_000
wall_time = "10m"
objective = "train_success"
seed = 1

[study.scheduler]
kind = "asha"
grace_steps = 100_000
reduction = 3

[space]
"ppo.lr" = { log_uniform = [1e-5, 1e-1] }
"ppo.epochs" = { int = [5, 14] }
"ppo.clip" = { choice = [0.05, 0.1, 0.2, 0.3] }
"#;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = PathBuf::from(
        std::env::args()
            .nth(1)
            .unwrap_or_else(|| "synthetic-study".into()),
    );
    let config = StudyConfig::from_toml_str(STUDY)?;
    let mut study = Study::open(&dir, config)?;
    let progress = study.run(&Synthetic)?;
    println!("{progress:?}");
    for file in study.write_outputs()? {
        println!("wrote {}", file.display());
    }
    if let Some(best) = study.state().best() {
        println!(
            "best: trial {} {:?} -> {}",
            best.id,
            best.score,
            buridan_study::overrides::describe(&best.overrides)
        );
    }
    Ok(())
}
