//! What a run trains on, as a type: one grid map, a weighted mixture of
//! grid layouts, or an AGV plant. A config file names it by one of the keys
//! `map`, `maps` and `plant` ([`Task::KEYS`]); a file that sets two of them
//! is refused naming both.

use super::WeightedMap;

/// What a run trains on: exactly one of a grid map, a weighted mixture of
/// grid layouts, or an AGV plant ([`super::TrainConfig::task`]).
///
/// In TOML it is one of three top-level keys, as before the type: `map =
/// "rm-2.1"`, `[[maps]]` (or `maps = [...]`), or `plant = "hall"`; a file
/// that sets none trains on the grid map `rm-2.1` ([`Task::default`]).
///
/// ```
/// use buridan_learner::train::{Task, TrainConfig, WeightedMap};
/// let cfg: TrainConfig = toml::from_str("plant = \"hall\"").unwrap();
/// assert_eq!(cfg.task, Task::Plant("hall".into()));
/// assert!(cfg.task.is_plant() && cfg.task.grid_map().is_none());
/// let cfg: TrainConfig = toml::from_str("maps = [{ name = \"rm-2.2\" }]").unwrap();
/// assert_eq!(cfg.task.maps().map(<[WeightedMap]>::len), Some(1));
/// assert_eq!(TrainConfig::default().task.grid_map(), Some("rm-2.1"));
/// let err = toml::from_str::<TrainConfig>("map = \"rm-2.1\"\nplant = \"hall\"").unwrap_err();
/// assert!(err.to_string().contains("sets plant together with map or maps"), "{err}");
/// ```
#[derive(Debug, Clone, PartialEq)]
pub enum Task {
    /// One grid layout, TOML `map`: a reference model id (`rm-2.1`, the
    /// default) or a MovingAI `.map` path.
    Grid(String),
    /// Several grid layouts with weights, TOML `maps` (`[[maps]]`): each
    /// env draws the layout of every episode from them. CTDE and DTE only.
    Mixture(Vec<WeightedMap>),
    /// An AGV plant, TOML `plant`: a bundled plant id (`dissertation`,
    /// `hall`) or a plant file path (`buridan_plant::Plant::load`). A plant
    /// run excludes `[imitation]`, `features` and `shaping`; `starts`,
    /// `rules` and `sensor_range` do not apply. Its label is `plant:ID`.
    Plant(String),
}

/// The grid map of a file that names no task.
const DEFAULT_MAP: &str = "rm-2.1";

impl Default for Task {
    /// The grid map `rm-2.1`.
    fn default() -> Self {
        Task::Grid(DEFAULT_MAP.into())
    }
}

/// Why the task keys of a configuration name no single task.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum TaskKeysError {
    /// Both `map` and `maps` are set.
    #[error("config sets both map and maps: use one (maps lists several layouts with weights)")]
    MapAndMaps,
    /// `plant` is set together with `map` or `maps`.
    #[error("config sets plant together with map or maps: a run trains on a plant or on grid layouts, not both")]
    PlantAndMap,
}

impl Task {
    /// The TOML keys that name a task, one per form: `map`, `maps`, `plant`.
    pub const KEYS: [&'static str; 3] = ["map", "maps", "plant"];

    /// Checks which task keys a configuration sets: at most one of `map`,
    /// `maps` and `plant`.
    ///
    /// ```
    /// use buridan_learner::train::{Task, TaskKeysError};
    /// assert_eq!(Task::check_keys(true, false, false), Ok(()));
    /// assert_eq!(Task::check_keys(true, true, false), Err(TaskKeysError::MapAndMaps));
    /// assert_eq!(Task::check_keys(false, true, true), Err(TaskKeysError::PlantAndMap));
    /// ```
    pub fn check_keys(map: bool, maps: bool, plant: bool) -> Result<(), TaskKeysError> {
        if map && maps {
            return Err(TaskKeysError::MapAndMaps);
        }
        if plant && (map || maps) {
            return Err(TaskKeysError::PlantAndMap);
        }
        Ok(())
    }

    /// The task the keys of a file name (none: [`Task::default`]).
    pub(super) fn from_keys(
        map: Option<String>,
        maps: Option<Vec<WeightedMap>>,
        plant: Option<String>,
    ) -> Result<Self, TaskKeysError> {
        Self::check_keys(map.is_some(), maps.is_some(), plant.is_some())?;
        Ok(match (map, maps, plant) {
            (_, _, Some(plant)) => Task::Plant(plant),
            (_, Some(maps), _) => Task::Mixture(maps),
            (Some(map), _, _) => Task::Grid(map),
            (None, None, None) => Task::default(),
        })
    }

    /// The task as the keys of a file: exactly one of them set.
    pub(super) fn into_keys(self) -> (Option<String>, Option<Vec<WeightedMap>>, Option<String>) {
        match self {
            Task::Grid(map) => (Some(map), None, None),
            Task::Mixture(maps) => (None, Some(maps), None),
            Task::Plant(plant) => (None, None, Some(plant)),
        }
    }

    /// Makes a TOML table in which `key` was just set name one task: when
    /// `key` is one of [`Task::KEYS`], the other two are removed (as
    /// `--map` replaces a config's `maps` or `plant`). Other keys leave the
    /// table as it is.
    ///
    /// ```
    /// use buridan_learner::train::Task;
    /// let mut t: toml::Table = toml::from_str("map = \"rm-2.1\"\nplant = \"hall\"\nagents = 2").unwrap();
    /// Task::keep_only(&mut t, "plant");
    /// assert_eq!(t.keys().collect::<Vec<_>>(), ["agents", "plant"]);
    /// ```
    pub fn keep_only(table: &mut toml::Table, key: &str) {
        if Self::KEYS.contains(&key) {
            table.retain(|k, _| k == key || !Self::KEYS.contains(&k));
        }
    }

    /// The grid map of a [`Task::Grid`].
    pub fn grid_map(&self) -> Option<&str> {
        match self {
            Task::Grid(map) => Some(map),
            _ => None,
        }
    }

    /// The layouts of a [`Task::Mixture`].
    pub fn maps(&self) -> Option<&[WeightedMap]> {
        match self {
            Task::Mixture(maps) => Some(maps),
            _ => None,
        }
    }

    /// The plant id or file of a [`Task::Plant`].
    pub fn plant(&self) -> Option<&str> {
        match self {
            Task::Plant(plant) => Some(plant),
            _ => None,
        }
    }

    /// Whether the run trains on an AGV plant.
    pub fn is_plant(&self) -> bool {
        matches!(self, Task::Plant(_))
    }

    /// The grid layouts with their weights: the mixture's, or the one map
    /// with weight 1; none for a plant.
    pub fn layouts(&self) -> Vec<WeightedMap> {
        match self {
            Task::Grid(map) => vec![WeightedMap {
                name: map.clone(),
                weight: 1.0,
            }],
            Task::Mixture(maps) => maps.clone(),
            Task::Plant(_) => Vec::new(),
        }
    }

    /// What the run trains on, in one word: the map, the
    /// [`WeightedMap::label`] of a mixture, or `plant:ID`.
    ///
    /// ```
    /// use buridan_learner::train::{Task, WeightedMap};
    /// assert_eq!(Task::Grid("rm-1.1".into()).map_label(), "rm-1.1");
    /// let mix = Task::Mixture(WeightedMap::parse_list("rm-2.2:2,rm-3.1").unwrap());
    /// assert_eq!(mix.map_label(), "rm-2.2:2+rm-3.1:1");
    /// assert_eq!(Task::Plant("hall".into()).map_label(), "plant:hall");
    /// ```
    pub fn map_label(&self) -> String {
        match self {
            Task::Grid(map) => map.clone(),
            Task::Mixture(maps) => WeightedMap::label(maps),
            Task::Plant(plant) => format!("plant:{plant}"),
        }
    }
}
