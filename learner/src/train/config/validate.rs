//! Checks of a training configuration: every key in its range, the
//! combinations a run can train, each refusal naming the key.

use buridan_imitate::ImitationConfig;
use buridan_policy::Mode;

use super::{Algorithm, ConfigError, TrainConfig};
use crate::algo::schedule::Schedule;

fn ensure(ok: bool, why: &'static str) -> Result<(), ConfigError> {
    if ok {
        Ok(())
    } else {
        Err(ConfigError::Invalid(why))
    }
}

impl TrainConfig {
    /// Checks ranges.
    pub fn validate(&self) -> Result<(), ConfigError> {
        ensure(self.agents >= 1, "agents must be at least 1")?;
        ensure(
            self.shaping.is_finite() && self.shaping >= 0.0,
            "shaping must be finite and at least 0",
        )?;
        ensure(self.run.num_actors >= 1, "num_actors must be at least 1")?;
        ensure(
            self.run.envs_per_actor >= 1,
            "envs_per_actor must be at least 1",
        )?;
        ensure(self.run.actor_nice <= 19, "actor_nice must be at most 19")?;
        ensure(
            self.run.fragment_len >= 1,
            "fragment_len must be at least 1",
        )?;
        ensure(
            !self.model.hidden.is_empty() && !self.model.hidden.contains(&0),
            "hidden sizes must be positive",
        )?;
        ensure((0.0..=1.0).contains(&self.gamma), "gamma must be in [0, 1]")?;
        ensure(
            (0.0..1.0).contains(&self.delay),
            "delay must be a probability in [0, 1)",
        )?;
        match &self.algorithm {
            Algorithm::Ppo(p) => {
                ensure(p.epochs >= 1, "ppo.epochs must be at least 1")?;
                ensure(
                    p.train_batch >= 1 && p.minibatch >= 1,
                    "ppo batch sizes must be positive",
                )?;
            }
            Algorithm::Impala(i) => {
                ensure(i.train_batch >= 1, "impala.train_batch must be positive")?;
                ensure(
                    (0.0..1.0).contains(&i.greedy_mix),
                    "impala.greedy_mix must be in [0, 1)",
                )?;
            }
        }
        ensure(self.model.lstm_cells >= 1, "lstm_cells must be positive")?;
        self.replay.validate().map_err(ConfigError::Replay)?;
        if let Some(stop) = &self.run.stop {
            stop.validate().map_err(ConfigError::Invalid)?;
            ensure(
                stop.greedy.is_none() || self.task.grid_map().is_some(),
                "stop.greedy needs one grid map (`map`): it plays held-out episodes of that map",
            )?;
        }
        self.validate_hyperparameters()?;
        for (section, im) in self.imitation_phases() {
            im.validate().map_err(|e| ConfigError::Imitation {
                section,
                source: Box::new(e),
            })?;
        }
        self.validate_plant()?;
        self.validate_maps()
    }

    /// Checks the `maps` list without loading maps.
    fn validate_maps(&self) -> Result<(), ConfigError> {
        let Some(maps) = self.task.maps() else {
            return Ok(());
        };
        if maps.is_empty() {
            return Err(ConfigError::NoMaps);
        }
        for (i, m) in maps.iter().enumerate() {
            if !(m.weight.is_finite() && m.weight > 0.0) {
                return Err(ConfigError::BadWeight {
                    map: m.name.clone(),
                    weight: m.weight,
                });
            }
            if maps[..i].iter().any(|o| o.name == m.name) {
                return Err(ConfigError::DuplicateMap {
                    map: m.name.clone(),
                });
            }
        }
        if maps.len() > 1 && self.mode == Mode::Cte {
            return Err(ConfigError::CentralOnSeveralMaps);
        }
        Ok(())
    }

    /// Checks that every real-valued hyperparameter is a finite number in
    /// its range: a NaN learning rate would otherwise train on, silently
    /// turning every weight into NaN.
    fn validate_hyperparameters(&self) -> Result<(), ConfigError> {
        type Keys = Vec<(&'static str, f64)>;
        // An entropy coefficient may be negative: a penalty that pushes the
        // policy toward the deterministic one greedy execution runs.
        let (positive, mut non_negative, mut finite, unit): (Keys, Keys, Keys, Keys) =
            match &self.algorithm {
                Algorithm::Ppo(p) => (
                    vec![
                        ("ppo.lr", p.lr),
                        ("ppo.clip", p.clip.into()),
                        ("ppo.vf_clip", p.vf_clip.into()),
                        ("ppo.kl_target", p.kl_target),
                        ("ppo.grad_clip", p.grad_clip.unwrap_or(1.0)),
                    ],
                    vec![
                        ("ppo.vf_coeff", p.vf_coeff.into()),
                        ("ppo.kl_coeff", p.kl_coeff),
                    ],
                    vec![("ppo.entropy_coeff", p.entropy_coeff.into())],
                    vec![("ppo.lambda", p.lambda.into())],
                ),
                Algorithm::Impala(i) => (
                    vec![
                        ("impala.lr", i.lr),
                        ("impala.grad_clip", i.grad_clip.unwrap_or(1.0)),
                        ("impala.rho_bar", i.rho_bar.into()),
                        ("impala.c_bar", i.c_bar.into()),
                        ("impala.pg_rho_bar", i.pg_rho_bar.into()),
                    ],
                    vec![("impala.vf_coeff", i.vf_coeff.into())],
                    vec![("impala.entropy_coeff", i.entropy_coeff.into())],
                    vec![("impala.lambda", i.lambda.into())],
                ),
            };
        // A schedule's points stand in the range of the setting they replace,
        // except that a learning rate may decay to 0.
        let (lr, entropy) = self.algorithm.schedules();
        let (lr_key, entropy_key) = match &self.algorithm {
            Algorithm::Ppo(_) => ("ppo.lr_schedule", "ppo.entropy_schedule"),
            Algorithm::Impala(_) => ("impala.lr_schedule", "impala.entropy_schedule"),
        };
        let points = |s: Option<&Schedule>, key| {
            s.into_iter()
                .flat_map(|s| s.points().iter().map(move |&(_, v)| (key, v)))
                .collect::<Keys>()
        };
        non_negative.extend(points(lr, lr_key));
        finite.extend(points(entropy, entropy_key));
        let in_range = |keys: &[(&'static str, f64)], range, ok: fn(f64) -> bool| match keys
            .iter()
            .find(|(_, value)| !ok(*value))
        {
            Some(&(key, value)) => Err(ConfigError::OutOfRange { key, value, range }),
            None => Ok(()),
        };
        in_range(&positive, "finite and positive", |v| {
            v.is_finite() && v > 0.0
        })?;
        in_range(&non_negative, "finite and at least 0", |v| {
            v.is_finite() && v >= 0.0
        })?;
        in_range(&finite, "finite", f64::is_finite)?;
        in_range(&unit, "in [0, 1]", |v| (0.0..=1.0).contains(&v))
    }

    /// The run's imitation phases with their TOML section names: `imitation`
    /// before learning from rewards, `polish` after.
    fn imitation_phases(&self) -> impl Iterator<Item = (&'static str, &ImitationConfig)> {
        [("imitation", &self.imitation), ("polish", &self.polish)]
            .into_iter()
            .filter_map(|(section, im)| im.as_ref().map(|im| (section, im)))
    }

    /// Checks that a plant run sets nothing that only a grid run has.
    fn validate_plant(&self) -> Result<(), ConfigError> {
        if !self.task.is_plant() {
            return Ok(());
        }
        if let Some((section, _)) = self.imitation_phases().next() {
            return Err(ConfigError::PlantWithImitation { section });
        }
        if !self.features.is_none() {
            return Err(ConfigError::GridOnlyOption { what: "features" });
        }
        if self.shaping != 0.0 {
            return Err(ConfigError::GridOnlyOption { what: "shaping" });
        }
        if self.shield_rollouts {
            return Err(ConfigError::GridOnlyOption {
                what: "shield_rollouts",
            });
        }
        if self.replay.enabled() {
            return Err(ConfigError::GridOnlyOption { what: "replay" });
        }
        if self.delay != 0.0 {
            return Err(ConfigError::GridOnlyOption { what: "delay" });
        }
        ensure(self.t_max >= 1, "t_max must be at least 1")
    }
}
