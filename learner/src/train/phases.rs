//! The imitation phases of a run: `[imitation]` before learning from
//! rewards, `[polish]` after it, each DAgger on the run's layouts with an
//! env stream of its own and a CSV of its rounds.

use std::path::Path;

use buridan_env::{seed, VecEnv, WeightedLayout};
use buridan_imitate::ImitationConfig;
use buridan_policy::Policy;

use super::config::TrainConfig;
use super::{cores, env_config, TrainError};

/// The imitation rounds of a run, one CSV row each.
pub const IMITATION_FILE: &str = "imitation.csv";

/// The polish rounds of a run (`[polish]`, after learning from rewards),
/// one CSV row each.
pub const POLISH_FILE: &str = "polish.csv";

/// When a run imitates its planners: which phase, its CSV and env stream.
#[derive(Debug, Clone, Copy)]
pub(super) enum Phase {
    /// `[imitation]`: a fresh policy, before learning from rewards.
    Warmup,
    /// `[polish]`: the trained policy, before the final checkpoint.
    Polish,
}

impl Phase {
    fn file(self) -> &'static str {
        match self {
            Phase::Warmup => IMITATION_FILE,
            Phase::Polish => POLISH_FILE,
        }
    }

    /// A pseudo-actor index no real actor has, so the phase's episodes
    /// replay neither the actors' nor the other phase's.
    fn stream(self) -> u64 {
        match self {
            Phase::Warmup => u64::from(u32::MAX),
            Phase::Polish => u64::from(u32::MAX) - 1,
        }
    }
}

/// Fits `policy` to the planner's actions by DAgger on the run's layouts
/// (envs and seeds of the phase's own), logging each round to the phase's
/// CSV in `out`.
pub(super) fn imitate(
    cfg: &TrainConfig,
    im: &ImitationConfig,
    phase: Phase,
    layouts: &[WeightedLayout],
    policy: &Policy,
    out: &Path,
) -> Result<(), TrainError> {
    let seed = seed::actor_env(cfg.run.seed, phase.stream(), 0);
    let env = env_config(cfg, seed);
    let kind = cfg.mode.obs_kind();
    // Cloning's gradient steps take the run's share of the cores, as PPO's
    // updates do.
    let _learning = cores::Learning::start();
    let im = &ImitationConfig {
        threads: cfg.update_threads(im.threads),
        ..im.clone()
    };
    let imitated = match layouts {
        [(map, _)] => {
            let mut venv = VecEnv::new(map.clone(), env, im.envs, kind, 1)?;
            buridan_imitate::dagger(im, policy, &mut venv, cfg.run.seed, &mut |_| {})
        }
        _ => {
            let mut venv = VecEnv::with_layouts(layouts, env, im.envs, kind, 1)?;
            buridan_imitate::dagger(im, policy, &mut venv, cfg.run.seed, &mut |_| {})
        }
    };
    let rounds = imitated.map_err(|e| TrainError::Imitation(Box::new(e)))?;
    let path = out.join(phase.file());
    let mut csv = csv::Writer::from_writer(Vec::new());
    for round in &rounds {
        csv.serialize(round)
            .map_err(|e| TrainError::io("cannot write", &path, std::io::Error::other(e)))?;
    }
    let bytes = csv
        .into_inner()
        .map_err(|e| TrainError::io("cannot write", &path, e.into_error()))?;
    std::fs::write(&path, bytes).map_err(|e| TrainError::io("cannot write", &path, e))
}
