//! A training run's configuration from its arguments, exactly as `learner
//! train` resolves them: defaults (or the recipe), then the config file,
//! then the flags, then the `--set` overrides.

use std::path::PathBuf;

use buridan_env::{ObsFeatures, Rules, Starts};
use buridan_learner::train::{Algo, ConfigError, Task, TrainConfig, WeightedMap};
use buridan_policy::{Mode, PolicyError};

/// The arguments of a training run that decide its configuration (`learner
/// train`'s, less its presentation: bars, dashboard, metrics exporter).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunArgs {
    /// Reference model id or map file (replaces the config's maps or plant).
    pub map: Option<String>,
    /// An AGV plant id or file (replaces the config's map or maps).
    pub plant: Option<String>,
    /// Several layouts with weights, `NAME:WEIGHT,…`.
    pub maps: Option<String>,
    /// Agents per env.
    pub agents: Option<usize>,
    /// The algorithm.
    pub algo: Option<Algo>,
    /// CTDE, DTE or CTE.
    pub mode: Option<Mode>,
    /// Random or fixed starts.
    pub starts: Option<Starts>,
    /// The rule set (also sets `T_max` to the rule set's).
    pub rules: Option<Rules>,
    /// The TOML run configuration; none: the default recipe.
    pub config: Option<PathBuf>,
    /// Env-step budget.
    pub steps: Option<u64>,
    /// Seed.
    pub seed: Option<u64>,
    /// Where the learner's updates run (`cpu`, `cuda[:N]`).
    pub device: Option<buridan_policy::DeviceSpec>,
    /// A checkpoint directory or run to continue from; `auto`: `out`'s
    /// newest checkpoint if it has one.
    pub resume: Option<PathBuf>,
    /// `KEY=VALUE` overrides.
    pub overrides: Vec<String>,
    /// Leave out the imitation phases (`[imitation]` and `[polish]`).
    pub no_imitation: bool,
    /// Ignore the `[stop]` rule: train for the whole step budget.
    pub no_stop: bool,
    /// The run directory.
    pub out: PathBuf,
}

/// Why arguments do not resolve to a configuration.
#[derive(Debug, thiserror::Error)]
pub enum ResolveError {
    /// The config file, the map list or the result is out of range.
    #[error(transparent)]
    Config(Box<ConfigError>),
    /// The checkpoint to resume from is not there.
    #[error(transparent)]
    Resume(#[from] PolicyError),
    /// A `--set` assignment without `=`.
    #[error("--set '{0}': expected KEY=VALUE")]
    NoEquals(String),
    /// A `--set` assignment with an empty key.
    #[error("--set '{0}': empty key")]
    EmptyKey(String),
    /// A `--set` assignment through a key that holds a value.
    #[error("--set '{assignment}': '{part}' is not a section")]
    NotASection {
        /// The assignment.
        assignment: String,
        /// The key that is no section.
        part: String,
    },
    /// The configuration does not survive its own TOML.
    #[error("configuration round trip")]
    RoundTrip(#[source] toml::de::Error),
    /// The overrides do not form a configuration.
    #[error("invalid --set override")]
    Override(#[source] toml::de::Error),
    /// The plant's own `T_max` cannot be read.
    #[error("loading plant '{plant}'")]
    Plant {
        /// The plant id or file.
        plant: String,
        /// Why.
        source: Box<ConfigError>,
    },
}

impl From<ConfigError> for ResolveError {
    fn from(e: ConfigError) -> ResolveError {
        ResolveError::Config(Box::new(e))
    }
}

/// Sets the dotted `key` of a TOML table to `value` (parsed as TOML, else a string).
///
/// ```
/// let mut t: toml::Table = toml::from_str("[ppo]\nlr = 0.001").unwrap();
/// buridan_experiment::resolve::set_key(&mut t, "ppo.lr=5e-4").unwrap();
/// assert_eq!(t["ppo"]["lr"].as_float(), Some(5e-4));
/// assert!(buridan_experiment::resolve::set_key(&mut t, "no_equals_sign").is_err());
/// ```
pub fn set_key(table: &mut toml::Table, assignment: &str) -> Result<(), ResolveError> {
    let (key, raw) = assignment
        .split_once('=')
        .ok_or_else(|| ResolveError::NoEquals(assignment.to_string()))?;
    let value: toml::Value = toml::from_str::<toml::Table>(&format!("v = {raw}"))
        .ok()
        .and_then(|mut t| t.remove("v"))
        .unwrap_or_else(|| toml::Value::String(raw.to_string()));
    let mut parts: Vec<&str> = key.trim().split('.').collect();
    let last = parts
        .pop()
        .filter(|k| !k.is_empty())
        .ok_or_else(|| ResolveError::EmptyKey(assignment.to_string()))?;
    let mut node = table;
    for part in parts {
        node = node
            .entry(part)
            .or_insert_with(|| toml::Value::Table(toml::Table::new()))
            .as_table_mut()
            .ok_or_else(|| ResolveError::NotASection {
                assignment: assignment.to_string(),
                part: part.to_string(),
            })?;
    }
    node.insert(last.to_string(), value);
    Ok(())
}

/// The configuration of a run: defaults, then `config`, then flags, then overrides.
pub fn resolve(args: &RunArgs) -> Result<TrainConfig, ResolveError> {
    let mut cfg = match &args.config {
        Some(path) => TrainConfig::from_toml_file(path)?,
        None => TrainConfig::recipe(),
    };
    // Whether T_max was chosen (else a plant run takes its plant file's).
    let mut t_max_given = match &args.config {
        Some(path) => std::fs::read_to_string(path)
            .ok()
            .and_then(|text| toml::from_str::<toml::Table>(&text).ok())
            .is_some_and(|t| t.contains_key("t_max")),
        None => false,
    };
    // Each replaces the config's task; the last given wins (`--plant`).
    if let Some(v) = &args.map {
        cfg.task = Task::Grid(v.clone());
    }
    if let Some(v) = &args.maps {
        cfg.task = Task::Mixture(WeightedMap::parse_list(v)?);
    }
    if let Some(v) = &args.plant {
        cfg.task = Task::Plant(v.clone());
    }
    if let Some(v) = args.agents {
        cfg.agents = v;
    }
    if let Some(v) = args.algo {
        cfg.algorithm.switch_to(v);
    }
    if let Some(v) = args.mode {
        cfg.mode = v;
    }
    if args.config.is_none() {
        cfg.apply_recipe_mode();
    }
    if let Some(v) = args.starts {
        cfg.starts = v;
    }
    if let Some(v) = args.rules {
        cfg.rules = v;
        cfg.t_max = v.default_t_max();
    }
    if let Some(v) = args.steps {
        cfg.run.steps = v;
    }
    if let Some(v) = args.seed {
        cfg.run.seed = v;
    }
    if let Some(v) = args.device {
        cfg.run.device = v;
    }
    if let Some(v) = &args.resume {
        cfg.run.resume = if v.as_os_str() == "auto" {
            buridan_policy::checkpoint::resolve(&args.out).ok()
        } else {
            Some(buridan_policy::checkpoint::resolve(v)?)
        };
    }
    let mut set_keys = Vec::new();
    if !args.overrides.is_empty() {
        let mut table: toml::Table =
            toml::from_str(&cfg.to_toml()).map_err(ResolveError::RoundTrip)?;
        for o in &args.overrides {
            set_key(&mut table, o)?;
            let key = o.split_once('=').map(|(k, _)| k.trim());
            // Like the flags: naming a task (`map`, `maps` or `plant`)
            // replaces the config's.
            if let Some(key) = key {
                Task::keep_only(&mut table, key);
            }
            t_max_given |= key == Some("t_max");
            set_keys.extend(key.map(str::to_string));
        }
        cfg = table.try_into().map_err(ResolveError::Override)?;
    }
    if args.no_imitation {
        cfg.imitation = None;
        cfg.polish = None;
    }
    if args.no_stop {
        cfg.run.stop = None;
    }
    if cfg.task.maps().is_some()
        && args.config.is_none()
        && !set_keys.iter().any(|k| k.starts_with("stop"))
    {
        // The recipe's greedy check plays one map's held-out episodes.
        if let Some(stop) = &mut cfg.run.stop {
            stop.greedy = None;
        }
    }
    if cfg.task.is_plant() && args.config.is_none() {
        // The recipe's features and shaping are grid ones (a plant run
        // refuses them): left out unless set explicitly.
        if !set_keys.iter().any(|k| k.starts_with("features")) {
            cfg.features = ObsFeatures::default();
        }
        if !set_keys.iter().any(|k| k == "shaping") {
            cfg.shaping = 0.0;
        }
        // Its imitation asks grid planners for labels, its polish a grid
        // shield.
        if !set_keys.iter().any(|k| k.starts_with("imitation")) {
            cfg.imitation = None;
        }
        if !set_keys.iter().any(|k| k.starts_with("polish")) {
            cfg.polish = None;
        }
        // Plant episodes only truncate: no success for `[stop]` to hold.
        if !set_keys.iter().any(|k| k.starts_with("stop")) {
            cfg.run.stop = None;
        }
    }
    if !t_max_given {
        cfg.use_plant_t_max()
            .map_err(|source| ResolveError::Plant {
                plant: cfg.task.plant().unwrap_or_default().to_string(),
                source: Box::new(source),
            })?;
    }
    cfg.validate()?;
    Ok(cfg)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_recipe_keeps_its_features_in_every_mode() {
        let recipe = TrainConfig::recipe();
        for mode in [Mode::Ctde, Mode::Dte, Mode::Cte] {
            let args = RunArgs {
                map: Some("rm-2.1".into()),
                mode: Some(mode),
                out: PathBuf::from("unused"),
                ..RunArgs::default()
            };
            let cfg = resolve(&args).unwrap();
            assert_eq!(cfg.mode, mode);
            assert_eq!(cfg.features, recipe.features, "{mode:?}");
            assert_eq!(cfg.imitation, recipe.imitation, "{mode:?}");
            let warmup = if mode == Mode::Cte { 20_000 } else { 0 };
            assert_eq!(
                cfg.algorithm.ppo().unwrap().critic_warmup,
                warmup,
                "{mode:?}"
            );
        }
    }
}
