//! The controllers a plant evaluation can run: the segment-reservation
//! and random baselines, and a policy trained with `learner train --plant`.

use std::path::Path;
use std::sync::Arc;

use buridan_env::{ObsKind, NUM_ACTIONS};
use buridan_plant::controllers::{RandomController, ReservationController};
use buridan_plant::{Plant, PlantEnv};
use buridan_policy::{checkpoint, ActMode, Mode};

use super::{eval_config, PlantEvalError, PlantEvalSpec};
use crate::policy::{load_for_agents, PolicyLoadError, PolicyRunner};

/// A trained policy driving all AGVs, loaded from a checkpoint of
/// `learner train --plant`.
pub struct PlantPolicy {
    runner: PolicyRunner,
    trained_on: String,
}

impl PlantPolicy {
    /// Loads the policy at `path` (a checkpoint or a run directory) for
    /// `agents` AGVs on `plant`, acting greedily or by sampling (`seed`).
    /// The checkpoint's `config.toml` must name a plant, and the policy's
    /// input must be the plant observation's size.
    pub fn load(
        path: &Path,
        plant: &Arc<Plant>,
        agents: usize,
        act_mode: ActMode,
        seed: u64,
    ) -> Result<Self, PlantEvalError> {
        let dir = checkpoint::resolve(path).map_err(|source| PolicyLoadError::Checkpoint {
            dir: path.to_path_buf(),
            source,
        })?;
        let trained_on = trained_plant(&dir)?;
        let (dir, policy, rows) = load_for_agents(&dir, agents, &buridan_policy::Device::Cpu)?;
        let spec = policy.spec().clone();
        let env = PlantEnv::new(
            plant.clone(),
            eval_config(&PlantEvalSpec {
                agents,
                episodes: 1,
                seed,
            }),
        )?;
        let (got, kind) = match spec.mode.obs_kind() {
            ObsKind::Local => (env.local_obs_dim(), "local"),
            ObsKind::Central => (env.central_obs_dim(), "central"),
        };
        if got != spec.obs_dim {
            return Err(PlantEvalError::ObsSize {
                dir,
                expected: spec.obs_dim,
                got,
                kind,
                agents,
            });
        }
        Ok(Self {
            runner: PolicyRunner::new(policy, rows, act_mode, seed),
            trained_on,
        })
    }

    /// The plant the policy was trained on, as its run named it
    /// (`plant:ID`).
    pub fn trained_on(&self) -> &str {
        &self.trained_on
    }

    fn begin_episode(&mut self) {
        self.runner.begin_episode();
    }

    fn act(&mut self, env: &PlantEnv, out: &mut [u8]) -> Result<(), PlantEvalError> {
        let (n, r) = (env.agents(), &mut self.runner);
        if r.mode == Mode::Cte {
            env.write_central_obs(&mut r.obs)?;
        } else {
            let d = env.local_obs_dim();
            for i in 0..n {
                env.write_local_obs(i, &mut r.obs[i * d..(i + 1) * d])?;
            }
        }
        for i in 0..n {
            env.write_mask(i, &mut r.masks[i * NUM_ACTIONS..(i + 1) * NUM_ACTIONS])?;
        }
        out.copy_from_slice(r.act()?.actions);
        Ok(())
    }

    fn after_step(&mut self, rewards: &[f32]) {
        self.runner.observe(rewards);
    }
}

/// The plant of checkpoint `dir`'s run (`plant:ID`), from its
/// `config.toml`; an error naming the grid layouts if it has none.
fn trained_plant(dir: &Path) -> Result<String, PlantEvalError> {
    let path = dir.join(checkpoint::CONFIG_FILE);
    let bad = |message: String| PlantEvalError::RunConfig {
        path: path.clone(),
        message,
    };
    let text = std::fs::read_to_string(&path).map_err(|e| bad(e.to_string()))?;
    let table: toml::Table = toml::from_str(&text).map_err(|e| bad(e.message().to_string()))?;
    if let Some(plant) = table.get("plant").and_then(toml::Value::as_str) {
        return Ok(format!("plant:{plant}"));
    }
    let trained_on = match (table.get("maps"), table.get("map")) {
        (Some(maps), _) => maps
            .as_array()
            .map(|list| {
                list.iter()
                    .filter_map(|m| m.get("name").and_then(toml::Value::as_str))
                    .collect::<Vec<_>>()
                    .join(", ")
            })
            .unwrap_or_default(),
        (None, Some(map)) => map.as_str().unwrap_or_default().to_string(),
        (None, None) => "rm-2.1".to_string(),
    };
    Err(PlantEvalError::NotAPlantPolicy {
        dir: dir.to_path_buf(),
        trained_on,
    })
}

/// A controller of all AGVs of a plant episode.
pub enum PlantController {
    /// The segment-reservation baseline ([`ReservationController`]).
    Reservation(ReservationController),
    /// Uniform choice among legal actions ([`RandomController`]), its
    /// stream drawn per episode from the evaluation seed.
    Random {
        /// The evaluation seed.
        seed: u64,
        /// This episode's controller.
        controller: Box<RandomController>,
    },
    /// A trained policy.
    Policy(Box<PlantPolicy>),
}

impl PlantController {
    /// Resolves `reservation`, `random` or `checkpoint:DIR` for episodes of
    /// `plant` with `agents` AGVs and evaluation seed `seed`; a checkpoint
    /// acts by `act_mode` (greedy or sampled).
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_eval::plant::{load_plant, PlantController};
    /// use buridan_policy::ActMode;
    /// let plant = Arc::new(load_plant("dissertation", None).unwrap());
    /// let c = PlantController::by_name("random", &plant, 2, 0, ActMode::Greedy).unwrap();
    /// assert_eq!(c.name(), "random");
    /// let err = PlantController::by_name("cbs", &plant, 2, 0, ActMode::Greedy).err().unwrap();
    /// assert!(err.to_string().contains("expected reservation, random or checkpoint:DIR"));
    /// ```
    pub fn by_name(
        name: &str,
        plant: &Arc<Plant>,
        agents: usize,
        seed: u64,
        act_mode: ActMode,
    ) -> Result<Self, PlantEvalError> {
        match name {
            "reservation" => Ok(Self::Reservation(ReservationController::new(agents))),
            "random" => Ok(Self::Random {
                seed,
                controller: Box::new(RandomController::for_episode(seed, 0)),
            }),
            _ => match name.strip_prefix("checkpoint:") {
                Some(dir) if !dir.is_empty() => Ok(Self::Policy(Box::new(PlantPolicy::load(
                    Path::new(dir),
                    plant,
                    agents,
                    act_mode,
                    seed,
                )?))),
                _ => Err(PlantEvalError::UnknownController {
                    name: name.to_string(),
                }),
            },
        }
    }

    /// The name in summaries: `reservation`, `random`, or
    /// `ctde-policy` (`cte-policy`, `dte-policy`).
    pub fn name(&self) -> String {
        match self {
            Self::Reservation(_) => "reservation".into(),
            Self::Random { .. } => "random".into(),
            Self::Policy(p) => format!("{:?}-policy", p.runner.mode).to_lowercase(),
        }
    }

    /// Prepares for episode `episode` (fresh grants, stream or state).
    pub fn begin_episode(&mut self, episode: u64) {
        match self {
            Self::Reservation(r) => r.reset(),
            Self::Random { seed, controller } => {
                **controller = RandomController::for_episode(*seed, episode)
            }
            Self::Policy(p) => p.begin_episode(),
        }
    }

    /// Writes one action per AGV of `env` into `out`.
    pub fn act(&mut self, env: &PlantEnv, out: &mut [u8]) -> Result<(), PlantEvalError> {
        match self {
            Self::Reservation(r) => r.actions(env, out)?,
            Self::Random { controller, .. } => controller.actions(env, out)?,
            Self::Policy(p) => p.act(env, out)?,
        }
        Ok(())
    }

    /// Tells the controller the rewards of the step it chose (a recurrent
    /// policy sees them next step).
    pub fn after_step(&mut self, rewards: &[f32]) {
        if let Self::Policy(p) = self {
            p.after_step(rewards);
        }
    }
}
