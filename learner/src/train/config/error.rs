//! Why a training configuration cannot be used, as data.

use std::path::PathBuf;

use buridan_env::{EnvError, MapError};
use buridan_plant::PlantError;

/// Why a configuration cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file cannot be read.
    #[error("cannot read config {}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file is not a valid configuration (syntax, unknown key, type).
    #[error("invalid config {}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// What the TOML parser says.
        source: toml::de::Error,
    },
    /// A value is out of its range.
    #[error("invalid configuration: {0}")]
    Invalid(&'static str),
    /// The `[replay]` settings are out of range.
    #[error(transparent)]
    Replay(EnvError),
    /// A hyperparameter is not a number in its range (NaN, infinite, or
    /// e.g. a negative learning rate).
    #[error("invalid configuration: {key} = {value} must be {range}")]
    OutOfRange {
        /// The key, as in the file (`ppo.lr`).
        key: &'static str,
        /// Its value.
        value: f64,
        /// What it must be ("finite and positive", ...).
        range: &'static str,
    },
    /// The `[imitation]` or `[polish]` section is out of range.
    #[error("invalid configuration: [{section}]")]
    Imitation {
        /// `imitation` or `polish`.
        section: &'static str,
        /// What is wrong in it.
        #[source]
        source: Box<buridan_imitate::ImitationError>,
    },
    /// A file sets both `map` and `maps`.
    #[error("config {} sets both map and maps: use one (maps lists several layouts with weights)", path.display())]
    MapAndMaps {
        /// The file.
        path: PathBuf,
    },
    /// `maps` is an empty list.
    #[error("invalid configuration: maps is empty: name at least one layout (or use map)")]
    NoMaps,
    /// An entry of a `--maps` list is not `NAME` or `NAME:WEIGHT`.
    #[error("invalid maps entry '{entry}': expected NAME or NAME:WEIGHT, e.g. rm-2.2:1,rm-3.1:2")]
    BadMapsEntry {
        /// The entry.
        entry: String,
    },
    /// A generated map's spec with a seed range that does not expand.
    #[error("invalid maps entry: {source}")]
    BadMapSpec {
        /// What is wrong with the spec.
        source: buridan_env::generate::SpecError,
    },
    /// A layout's weight is not a positive finite number.
    #[error("invalid configuration: map '{map}' has weight {weight}: weights must be positive and finite")]
    BadWeight {
        /// The layout.
        map: String,
        /// Its weight.
        weight: f64,
    },
    /// A layout is listed twice.
    #[error("invalid configuration: map '{map}' is listed twice in maps")]
    DuplicateMap {
        /// The layout.
        map: String,
    },
    /// CTE with several layouts.
    #[error(
        "invalid configuration: cte cannot train on several layouts: its central observation \
         is 1 + 2·agents planes of the map's height × width cells, so its size (the network's \
         input) depends on the layout; use ctde or dte, whose local observations have one size on every layout"
    )]
    CentralOnSeveralMaps,
    /// A layout cannot be loaded.
    #[error("invalid configuration: map '{map}' cannot be loaded")]
    UnknownMap {
        /// The layout as named.
        map: String,
        /// Why.
        source: MapError,
    },
    /// A file sets `plant` together with `map` or `maps`.
    #[error("config {} sets plant together with map or maps: a run trains on a plant or on grid layouts, not both", path.display())]
    PlantAndMap {
        /// The file.
        path: PathBuf,
    },
    /// A plant run with an `[imitation]` or `[polish]` section.
    #[error("invalid configuration: [{section}] cannot be used with a plant: DAgger imitates grid planners, and the AGV plant has none")]
    PlantWithImitation {
        /// `imitation` or `polish`.
        section: &'static str,
    },
    /// A plant run with a grid-only option.
    #[error("invalid configuration: {what} applies to grid layouts only, not to the AGV plant (leave it out with plant)")]
    GridOnlyOption {
        /// The option (`features`, `shaping`, `shield_rollouts`, `replay`).
        what: &'static str,
    },
    /// The plant cannot be loaded.
    #[error("invalid configuration: plant '{plant}' cannot be loaded")]
    UnknownPlant {
        /// The plant as named.
        plant: String,
        /// Why.
        source: Box<PlantError>,
    },
    /// A layout cannot hold the configured agents.
    #[error("invalid configuration: {agents} agents do not fit map '{map}'")]
    AgentsDoNotFit {
        /// The layout.
        map: String,
        /// Agents configured.
        agents: usize,
        /// What the env says (too few free cells, too small a scenario).
        source: EnvError,
    },
}
