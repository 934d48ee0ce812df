//! The name of a generated map, `FAMILY/HEIGHTxWIDTH[/KEY=VALUE…]/seed=S`:
//! one parser ([`GeneratedMap::from_str`](std::str::FromStr)) and one
//! printer ([`std::fmt::Display`]) that round-trip.

use std::fmt;
use std::str::FromStr;

use super::{Braid, MapGenerator, Maze, RandomObstacles, Warehouse};
use crate::map::{Grid, Map};

/// The generator families, as spelled in a spec.
pub const FAMILIES: &[&str] = &["maze", "braid", "random", "warehouse"];

/// The largest height or width a spec may ask for.
const MAX_SIDE: usize = 1024;

/// The most seeds a range may name ([`GeneratedMap::expand`]).
const MAX_SEEDS: u64 = 10_000;

/// A generator with its settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Family {
    /// [`Maze`]: `maze/HxW[/density=F][/walls=N][/straight=F]`.
    Maze(Maze),
    /// [`Braid`]: `braid/HxW[/loops=F]` (odd H and W).
    Braid(Braid),
    /// [`RandomObstacles`]: `random/HxW[/density=F]`.
    Random(RandomObstacles),
    /// [`Warehouse`]: `warehouse/HxW[/shelf=N][/gap=N][/aisle=N][/margin=N][/edge=N][/missing=F]`.
    Warehouse(Warehouse),
}

/// One setting's value, as a spec writes it.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Setting {
    /// A share or chance.
    Share(f64),
    /// A count of cells or walls.
    Count(usize),
}

impl fmt::Display for Setting {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Setting::Share(v) => write!(f, "{v}"),
            Setting::Count(v) => write!(f, "{v}"),
        }
    }
}

impl Family {
    /// Each family at its defaults, in [`FAMILIES`]' order.
    pub fn defaults() -> [Family; 4] {
        [
            Family::Maze(Maze::default()),
            Family::Braid(Braid::default()),
            Family::Random(RandomObstacles::default()),
            Family::Warehouse(Warehouse::default()),
        ]
    }

    /// This family at its defaults.
    fn at_defaults(&self) -> Family {
        let [maze, braid, random, warehouse] = Family::defaults();
        match self {
            Family::Maze(_) => maze,
            Family::Braid(_) => braid,
            Family::Random(_) => random,
            Family::Warehouse(_) => warehouse,
        }
    }

    /// The family's keys with their values here, in the order a spec
    /// prints them.
    fn settings(&self) -> Vec<(&'static str, Setting)> {
        use Setting::{Count, Share};
        match *self {
            Family::Maze(m) => vec![
                ("density", Share(m.density)),
                ("walls", Count(m.walls)),
                ("straight", Share(m.straight)),
            ],
            Family::Braid(b) => vec![("loops", Share(b.loops))],
            Family::Random(r) => vec![("density", Share(r.density))],
            Family::Warehouse(w) => vec![
                ("shelf", Count(w.shelf)),
                ("gap", Count(w.gap)),
                ("aisle", Count(w.aisle)),
                ("margin", Count(w.margin)),
                ("edge", Count(w.edge)),
                ("missing", Share(w.missing)),
            ],
        }
    }

    /// The spec's form for this family, with its keys at their defaults.
    ///
    /// ```
    /// use buridan_env::generate::Family;
    /// let [maze, ..] = Family::defaults();
    /// assert_eq!(maze.form(), "maze/HxW[/density=0.3][/walls=8][/straight=0.8]/seed=S");
    /// ```
    pub fn form(&self) -> String {
        let keys: String = (self.at_defaults().settings().iter())
            .map(|(key, value)| format!("[/{key}={value}]"))
            .collect();
        format!("{}/HxW{keys}/seed=S", self.name())
    }

    /// The family's name in a spec ([`FAMILIES`]).
    pub fn name(&self) -> &'static str {
        match self {
            Family::Maze(_) => "maze",
            Family::Braid(_) => "braid",
            Family::Random(_) => "random",
            Family::Warehouse(_) => "warehouse",
        }
    }
}

impl MapGenerator for Family {
    fn generate(&self, height: usize, width: usize, seed: u64) -> Grid {
        match self {
            Family::Maze(g) => g.generate(height, width, seed),
            Family::Braid(g) => g.generate(height, width, seed),
            Family::Random(g) => g.generate(height, width, seed),
            Family::Warehouse(g) => g.generate(height, width, seed),
        }
    }
}

/// One generated map: a family's settings, the size and the seed.
///
/// ```
/// use buridan_env::generate::GeneratedMap;
/// let spec: GeneratedMap = "warehouse/20x30/missing=0.25/shelf=4/seed=3".parse().unwrap();
/// // Printed in one order, defaults left out.
/// assert_eq!(spec.to_string(), "warehouse/20x30/shelf=4/missing=0.25/seed=3");
/// let err = "braid/20x19/seed=1".parse::<GeneratedMap>().unwrap_err();
/// assert_eq!(
///     err.to_string(),
///     "map spec 'braid/20x19/seed=1': a braid maze's height and width are odd (its rooms sit on even rows and columns), not 20x19"
/// );
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GeneratedMap {
    /// The generator and its settings.
    pub family: Family,
    /// Rows.
    pub height: usize,
    /// Columns.
    pub width: usize,
    /// Which of the family's layouts.
    pub seed: u64,
}

impl GeneratedMap {
    /// The grid this spec names.
    pub fn grid(&self) -> Grid {
        self.family.generate(self.height, self.width, self.seed)
    }

    /// The map this spec names: its grid, named by the spec, no fixed
    /// scenario.
    pub fn map(&self) -> Map {
        Map {
            name: self.to_string(),
            grid: self.grid(),
            scenario: None,
        }
    }

    /// The maps of a spec whose seed may be a range, `seed=A..B` (A up to,
    /// not including, B; at most 10,000 seeds): one per seed, in order. A
    /// plain spec gives itself.
    ///
    /// ```
    /// use buridan_env::generate::GeneratedMap;
    /// let maps = GeneratedMap::expand("maze/19x19/seed=3..6").unwrap();
    /// let names: Vec<String> = maps.iter().map(|m| m.to_string()).collect();
    /// assert_eq!(names, ["maze/19x19/seed=3", "maze/19x19/seed=4", "maze/19x19/seed=5"]);
    /// assert_eq!(GeneratedMap::expand("maze/19x19/seed=3").unwrap().len(), 1);
    /// assert!(GeneratedMap::expand("maze/19x19/seed=6..6").is_err());
    /// ```
    pub fn expand(text: &str) -> Result<Vec<GeneratedMap>, SpecError> {
        let seed = text.split('/').find_map(|part| part.strip_prefix("seed="));
        let Some((seed, (from, to))) = seed.and_then(|s| Some((s, s.split_once("..")?))) else {
            return Ok(vec![text.parse()?]);
        };
        let bad = || SpecError {
            spec: text.to_string(),
            problem: SpecProblem::SeedRange(format!("{from}..{to}")),
        };
        let (from, to) = (
            from.parse::<u64>().map_err(|_| bad())?,
            to.parse::<u64>().map_err(|_| bad())?,
        );
        if from >= to || to - from > MAX_SEEDS {
            return Err(bad());
        }
        let first: GeneratedMap = text
            .replace(&format!("seed={seed}"), &format!("seed={from}"))
            .parse()?;
        Ok((from..to)
            .map(|seed| GeneratedMap { seed, ..first })
            .collect())
    }

    /// Whether `name` is meant as a spec: its first `/`-separated part is
    /// a family's name ([`FAMILIES`]).
    ///
    /// ```
    /// use buridan_env::generate::GeneratedMap;
    /// assert!(GeneratedMap::is_spec("maze/19x19/seed=0"));
    /// assert!(GeneratedMap::is_spec("random/oops"));
    /// assert!(!GeneratedMap::is_spec("rm-2.1"));
    /// assert!(!GeneratedMap::is_spec("maps/maze.map"));
    /// ```
    pub fn is_spec(name: &str) -> bool {
        name.split_once('/')
            .is_some_and(|(family, _)| FAMILIES.contains(&family))
    }
}

/// A spec that does not parse: the spec and what is wrong with it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("map spec '{spec}': {problem}")]
pub struct SpecError {
    /// The spec as given.
    pub spec: String,
    /// What is wrong.
    pub problem: SpecProblem,
}

/// What is wrong with a spec.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SpecProblem {
    /// Too few parts.
    #[error("the form is FAMILY/HEIGHTxWIDTH[/KEY=VALUE...]/seed=SEED (families: maze, braid, random, warehouse; e.g. maze/19x19/seed=0)")]
    Form,
    /// The first part is not a family.
    #[error("unknown family '{0}' (known: maze, braid, random, warehouse)")]
    UnknownFamily(String),
    /// The size part is not `HEIGHTxWIDTH` within 1..=1024.
    #[error("the size is HEIGHTxWIDTH, each 1 to 1024 (e.g. 19x19), not '{0}'")]
    Size(String),
    /// A braid maze with an even side.
    #[error(
        "a braid maze's height and width are odd (its rooms sit on even rows and columns), not {0}x{1}"
    )]
    EvenBraid(usize, usize),
    /// A part that is not `KEY=VALUE`.
    #[error("'{0}' is not KEY=VALUE")]
    NotKeyValue(String),
    /// A key the family does not have.
    #[error("{family} has no key '{key}' (its keys: {})", keys_of(family))]
    UnknownKey {
        /// The family.
        family: &'static str,
        /// The key given.
        key: String,
    },
    /// A key given twice.
    #[error("'{0}' is given twice")]
    Repeated(String),
    /// A value out of its range or not a number.
    #[error("{key} = '{value}' is not {expected}")]
    Value {
        /// The key.
        key: String,
        /// The value given.
        value: String,
        /// What it must be, in words.
        expected: &'static str,
    },
    /// No `seed=` part.
    #[error("seed=SEED is missing (the last part, e.g. .../seed=0)")]
    NoSeed,
    /// A seed range that is not `A..B` with A < B and at most 10,000
    /// seeds ([`GeneratedMap::expand`]).
    #[error("the seed range {0} is not A..B with A < B and at most 10000 seeds")]
    SeedRange(String),
    /// A seed range where one map is named.
    #[error("seed={0} names several maps: a range belongs in a list of layouts (--maps), one map takes one seed")]
    RangeForOneMap(String),
    /// A warehouse's settings leave no room for a shelf.
    #[error(
        "no shelf fits in {height}x{width} with shelf={shelf}, margin={margin} and edge={edge}"
    )]
    NoShelf {
        /// Rows.
        height: usize,
        /// Columns.
        width: usize,
        /// Shelf cells per block.
        shelf: usize,
        /// Free columns at each end.
        margin: usize,
        /// Free rows at top and bottom.
        edge: usize,
    },
}

/// The keys of the family named `family`, comma separated.
fn keys_of(family: &str) -> String {
    let family = Family::defaults().into_iter().find(|f| f.name() == family);
    let keys = family.map(|f| f.settings().into_iter().map(|(k, _)| k).collect::<Vec<_>>());
    keys.unwrap_or_default().join(", ")
}

impl FromStr for GeneratedMap {
    type Err = SpecError;

    fn from_str(spec: &str) -> Result<Self, SpecError> {
        parse(spec).map_err(|problem| SpecError {
            spec: spec.to_string(),
            problem,
        })
    }
}

/// The parts of a spec after the size, as key and value, checked for
/// repeats and for `seed`.
struct Settings<'a> {
    pairs: Vec<(&'a str, &'a str)>,
}

impl<'a> Settings<'a> {
    fn new(parts: &[&'a str]) -> Result<Self, SpecProblem> {
        let mut pairs: Vec<(&str, &str)> = Vec::new();
        for part in parts {
            let (key, value) = part
                .split_once('=')
                .ok_or_else(|| SpecProblem::NotKeyValue(part.to_string()))?;
            if pairs.iter().any(|&(k, _)| k == key) {
                return Err(SpecProblem::Repeated(key.to_string()));
            }
            pairs.push((key, value));
        }
        Ok(Self { pairs })
    }

    /// Refuses a key that `family` does not have (seed aside).
    fn check_keys(&self, family: Family) -> Result<(), SpecProblem> {
        let keys: Vec<&str> = family.settings().iter().map(|(k, _)| *k).collect();
        match self
            .pairs
            .iter()
            .find(|(k, _)| *k != "seed" && !keys.contains(k))
        {
            Some((key, _)) => Err(SpecProblem::UnknownKey {
                family: family.name(),
                key: key.to_string(),
            }),
            None => Ok(()),
        }
    }

    /// `key`'s value parsed and checked by `ok`, or `default`.
    fn get<T: FromStr + Copy>(
        &self,
        key: &str,
        default: T,
        ok: impl Fn(T) -> bool,
        expected: &'static str,
    ) -> Result<T, SpecProblem> {
        let Some(&(_, value)) = self.pairs.iter().find(|(k, _)| *k == key) else {
            return Ok(default);
        };
        value
            .parse::<T>()
            .ok()
            .filter(|&v| ok(v))
            .ok_or_else(|| SpecProblem::Value {
                key: key.to_string(),
                value: value.to_string(),
                expected,
            })
    }
}

const UNIT: &str = "a number from 0 to 1";
const BELOW_ONE: &str = "a number from 0 up to (not including) 1";
const POSITIVE: &str = "a whole number from 1 to 1024";

fn unit(v: f64) -> bool {
    (0.0..=1.0).contains(&v)
}

fn below_one(v: f64) -> bool {
    (0.0..1.0).contains(&v)
}

fn parse(spec: &str) -> Result<GeneratedMap, SpecProblem> {
    let parts: Vec<&str> = spec.split('/').collect();
    let [family, size, rest @ ..] = parts.as_slice() else {
        return Err(SpecProblem::Form);
    };
    let (height, width) = parse_size(size)?;
    let settings = Settings::new(rest)?;
    let Some(&(_, seed)) = settings.pairs.iter().find(|(k, _)| *k == "seed") else {
        return Err(SpecProblem::NoSeed);
    };
    if seed.contains("..") {
        return Err(SpecProblem::RangeForOneMap(seed.to_string()));
    }
    let seed = settings.get("seed", 0u64, |_| true, "a whole number from 0 to 2^64 - 1")?;
    let family = match *family {
        "maze" => {
            let d = Maze::default();
            settings.check_keys(Family::Maze(d))?;
            Family::Maze(Maze {
                density: settings.get("density", d.density, below_one, BELOW_ONE)?,
                walls: settings.get(
                    "walls",
                    d.walls,
                    |v: usize| (1..=MAX_SIDE).contains(&v),
                    POSITIVE,
                )?,
                straight: settings.get("straight", d.straight, unit, UNIT)?,
            })
        }
        "braid" => {
            settings.check_keys(Family::Braid(Braid::default()))?;
            if height % 2 == 0 || width % 2 == 0 {
                return Err(SpecProblem::EvenBraid(height, width));
            }
            let loops = settings.get("loops", Braid::default().loops, unit, UNIT)?;
            Family::Braid(Braid { loops })
        }
        "random" => {
            settings.check_keys(Family::Random(RandomObstacles::default()))?;
            let density = settings.get(
                "density",
                RandomObstacles::default().density,
                below_one,
                BELOW_ONE,
            )?;
            Family::Random(RandomObstacles { density })
        }
        "warehouse" => {
            let d = Warehouse::default();
            settings.check_keys(Family::Warehouse(d))?;
            let positive = |v: usize| (1..=MAX_SIDE).contains(&v);
            let small = |v: usize| v <= MAX_SIDE;
            const SMALL: &str = "a whole number from 0 to 1024";
            let w = Warehouse {
                shelf: settings.get("shelf", d.shelf, positive, POSITIVE)?,
                gap: settings.get("gap", d.gap, positive, POSITIVE)?,
                aisle: settings.get("aisle", d.aisle, positive, POSITIVE)?,
                margin: settings.get("margin", d.margin, small, SMALL)?,
                edge: settings.get("edge", d.edge, small, SMALL)?,
                missing: settings.get("missing", d.missing, unit, UNIT)?,
            };
            let (rows, blocks) = w.fits(height, width);
            if rows == 0 || blocks == 0 {
                return Err(SpecProblem::NoShelf {
                    height,
                    width,
                    shelf: w.shelf,
                    margin: w.margin,
                    edge: w.edge,
                });
            }
            Family::Warehouse(w)
        }
        other => return Err(SpecProblem::UnknownFamily(other.to_string())),
    };
    Ok(GeneratedMap {
        family,
        height,
        width,
        seed,
    })
}

fn parse_size(size: &str) -> Result<(usize, usize), SpecProblem> {
    let bad = || SpecProblem::Size(size.to_string());
    let (h, w) = size.split_once('x').ok_or_else(bad)?;
    let side = |s: &str| {
        s.parse::<usize>()
            .ok()
            .filter(|v| (1..=MAX_SIDE).contains(v))
            .ok_or_else(bad)
    };
    Ok((side(h)?, side(w)?))
}

impl fmt::Display for GeneratedMap {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}x{}", self.family.name(), self.height, self.width)?;
        // Each setting away from its default, in the family's key order.
        let defaults = self.family.at_defaults().settings();
        for ((key, value), (_, default)) in self.family.settings().into_iter().zip(defaults) {
            if value != default {
                write!(f, "/{key}={value}")?;
            }
        }
        write!(f, "/seed={}", self.seed)
    }
}
