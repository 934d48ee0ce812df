//! Search spaces: which configuration keys a study varies, and over what.
//!
//! A space is a TOML table whose keys are dotted `TrainConfig` keys and whose
//! values name one domain each:
//!
//! ```toml
//! "ppo.lr"      = { choice = [1e-4, 3e-4, 5e-4, 1e-3] }
//! "ppo.epochs"  = { int = [5, 14] }
//! "ppo.clip"    = { uniform = [0.05, 0.3] }
//! "ppo.entropy_coeff" = { log_uniform = [1e-4, 1e-2] }
//! hidden        = { choice = [[32, 32], [64, 64], [256, 256]] }
//! ```
//!
//! Unquoted dotted keys (`ppo.lr = { … }`) are TOML sub-tables; they are
//! flattened back to `ppo.lr`, so both spellings mean the same.

use rand::Rng;
use serde::{Deserialize, Serialize};

/// The values one parameter may take.
///
/// ```
/// use buridan_study::space::Domain;
/// let d = Domain::Int { low: 5, high: 14, step: 1 };
/// assert_eq!(d.grid(100).len(), 10);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Domain {
    /// One of a list of TOML values (numbers, strings, arrays…).
    Choice(Vec<toml::Value>),
    /// A float drawn uniformly from `[low, high]`.
    Uniform {
        /// Lower bound.
        low: f64,
        /// Upper bound.
        high: f64,
    },
    /// A float whose logarithm is uniform on `[ln low, ln high]`.
    LogUniform {
        /// Lower bound (positive).
        low: f64,
        /// Upper bound.
        high: f64,
    },
    /// An integer in `low..=high` on a lattice of `step`.
    Int {
        /// Lowest value.
        low: i64,
        /// Highest value (inclusive; rounded down onto the lattice).
        high: i64,
        /// Lattice step (1 unless given).
        step: i64,
    },
}

/// One varied key and its domain.
///
/// ```
/// let s = buridan_study::SearchSpace::from_toml_str("\"ppo.lr\" = { uniform = [0.1, 0.2] }").unwrap();
/// assert_eq!(s.params()[0].key, "ppo.lr");
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Param {
    /// Dotted configuration key, e.g. `ppo.lr`.
    pub key: String,
    /// Its values.
    pub domain: Domain,
}

/// A parsed search space: parameters sorted by key.
///
/// ```
/// let s = buridan_study::SearchSpace::from_toml_str(r#"
///     ppo.epochs = { int = [5, 14] }
///     "ppo.lr" = { log_uniform = [1e-4, 1e-3] }
/// "#).unwrap();
/// let keys: Vec<_> = s.params().iter().map(|p| p.key.as_str()).collect();
/// assert_eq!(keys, ["ppo.epochs", "ppo.lr"]);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SearchSpace {
    params: Vec<Param>,
}

/// What is wrong with one entry of a search space.
///
/// ```
/// let e = buridan_study::SearchSpace::from_toml_str("x = { uniform = [2, 1] }").unwrap_err();
/// assert_eq!(e.key, "x");
/// assert!(matches!(e.problem, buridan_study::space::Problem::EmptyRange { .. }));
/// ```
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Problem {
    /// The text is not TOML.
    #[error("not valid TOML: {0}")]
    Toml(String),
    /// The value is not a table naming a domain.
    #[error("expected a table with one of `choice`, `uniform`, `log_uniform`, `int`")]
    NotADomain,
    /// The table names more than one domain.
    #[error("names more than one domain ({0})")]
    ManyDomains(String),
    /// A field no domain knows.
    #[error("unknown field `{0}`")]
    UnknownField(String),
    /// `choice = []`.
    #[error("`choice` is empty")]
    EmptyChoice,
    /// Bounds are not `[low, high]` of numbers (integers for `int`).
    #[error("expected `[low, high]` of two {0}")]
    BadBounds(&'static str),
    /// `low` is not below `high`.
    #[error("low {low} is not below high {high}")]
    EmptyRange {
        /// Given lower bound.
        low: f64,
        /// Given upper bound.
        high: f64,
    },
    /// A log-uniform bound is zero or negative.
    #[error("log-uniform bounds must be positive")]
    NonPositiveLog,
    /// `step` is not a positive integer.
    #[error("`step` must be a positive integer")]
    BadStep,
    /// A bound or a choice is NaN or infinite.
    #[error("bounds and choices must be finite")]
    NotFinite,
    /// An `int` range wider than 2^53: its values are not exact as the
    /// float coordinates samplers work in.
    #[error("int range [{low}, {high}] is wider than 2^53 (values must stay exact as floats)")]
    TooWide {
        /// Lower bound.
        low: i64,
        /// Upper bound.
        high: i64,
    },
    /// The space varies nothing.
    #[error("the search space has no parameters")]
    Empty,
}

/// A search-space error: the key (empty for the whole file) and the problem.
///
/// ```
/// let e = buridan_study::SearchSpace::from_toml_str("\"ppo.lr\" = { choice = [] }").unwrap_err();
/// assert_eq!(e.to_string(), "search space key `ppo.lr`: `choice` is empty");
/// ```
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("search space key `{key}`: {problem}")]
pub struct SpaceError {
    /// The dotted key at fault.
    pub key: String,
    /// What is wrong.
    pub problem: Problem,
}

const KINDS: [&str; 4] = ["choice", "uniform", "log_uniform", "int"];

impl SearchSpace {
    /// Parses a space from TOML text (the table of parameters itself).
    ///
    /// ```
    /// let s = buridan_study::SearchSpace::from_toml_str("hidden = { choice = [[64, 64]] }").unwrap();
    /// assert_eq!(s.params().len(), 1);
    /// ```
    pub fn from_toml_str(text: &str) -> Result<SearchSpace, SpaceError> {
        let table: toml::Table = toml::from_str(text).map_err(|e| SpaceError {
            key: String::new(),
            problem: Problem::Toml(e.message().to_string()),
        })?;
        SearchSpace::from_table(&table)
    }

    /// Parses a space from an already-parsed TOML table.
    ///
    /// ```
    /// let t: toml::Table = toml::from_str("lr = { uniform = [0.0, 1.0] }").unwrap();
    /// assert!(buridan_study::SearchSpace::from_table(&t).is_ok());
    /// ```
    pub fn from_table(table: &toml::Table) -> Result<SearchSpace, SpaceError> {
        let mut params = Vec::new();
        collect(table, "", &mut params)?;
        if params.is_empty() {
            return Err(SpaceError {
                key: String::new(),
                problem: Problem::Empty,
            });
        }
        params.sort_by(|a, b| a.key.cmp(&b.key));
        Ok(SearchSpace { params })
    }

    /// Builds a space from parameters already checked by the caller (sorted by key).
    ///
    /// ```
    /// use buridan_study::space::{Domain, Param};
    /// let s = buridan_study::SearchSpace::new(vec![Param { key: "x".into(), domain: Domain::Uniform { low: 0.0, high: 1.0 } }]);
    /// assert_eq!(s.params().len(), 1);
    /// ```
    pub fn new(mut params: Vec<Param>) -> SearchSpace {
        params.sort_by(|a, b| a.key.cmp(&b.key));
        SearchSpace { params }
    }

    /// The parameters, sorted by key.
    ///
    /// ```
    /// let s = buridan_study::SearchSpace::from_toml_str("b = { int = [1, 2] }\na = { int = [1, 2] }").unwrap();
    /// assert_eq!(s.params()[0].key, "a");
    /// ```
    pub fn params(&self) -> &[Param] {
        &self.params
    }
}

fn collect(table: &toml::Table, prefix: &str, out: &mut Vec<Param>) -> Result<(), SpaceError> {
    for (name, value) in table {
        let key = if prefix.is_empty() {
            name.clone()
        } else {
            format!("{prefix}.{name}")
        };
        let Some(inner) = value.as_table() else {
            return Err(SpaceError {
                key,
                problem: Problem::NotADomain,
            });
        };
        if inner.keys().any(|k| KINDS.contains(&k.as_str())) {
            let domain = parse_domain(inner).map_err(|problem| SpaceError {
                key: key.clone(),
                problem,
            })?;
            out.push(Param { key, domain });
        } else if inner.is_empty() {
            return Err(SpaceError {
                key,
                problem: Problem::NotADomain,
            });
        } else {
            collect(inner, &key, out)?;
        }
    }
    Ok(())
}

/// Whether every float in `v` (arrays and tables included) is finite.
fn all_finite(v: &toml::Value) -> bool {
    match v {
        toml::Value::Float(x) => x.is_finite(),
        toml::Value::Array(a) => a.iter().all(all_finite),
        toml::Value::Table(t) => t.values().all(all_finite),
        _ => true,
    }
}

fn parse_domain(t: &toml::Table) -> Result<Domain, Problem> {
    let kinds: Vec<&str> = t
        .keys()
        .map(String::as_str)
        .filter(|k| KINDS.contains(k))
        .collect();
    if kinds.len() > 1 {
        return Err(Problem::ManyDomains(kinds.join(", ")));
    }
    let kind = kinds[0];
    for k in t.keys() {
        if k != kind && !(kind == "int" && k == "step") {
            return Err(Problem::UnknownField(k.clone()));
        }
    }
    let v = &t[kind];
    match kind {
        "choice" => {
            let list = v.as_array().ok_or(Problem::EmptyChoice)?;
            if list.is_empty() {
                return Err(Problem::EmptyChoice);
            }
            // NaN equals nothing, itself included: a sampled NaN has no
            // coordinate (found by study/tests/fuzz.rs).
            if !list.iter().all(all_finite) {
                return Err(Problem::NotFinite);
            }
            Ok(Domain::Choice(list.clone()))
        }
        "int" => {
            let b = v.as_array().filter(|a| a.len() == 2);
            let (low, high) = b
                .and_then(|a| Some((a[0].as_integer()?, a[1].as_integer()?)))
                .ok_or(Problem::BadBounds("integers"))?;
            if low > high {
                return Err(Problem::EmptyRange {
                    low: low as f64,
                    high: high as f64,
                });
            }
            // Coordinates are floats: beyond 2^53 a lattice index rounds to
            // a value outside the range (found by study/tests/fuzz.rs), and
            // `high - low` overflows.
            if high.checked_sub(low).is_none_or(|span| span > 1 << 53) {
                return Err(Problem::TooWide { low, high });
            }
            let step = match t.get("step") {
                None => 1,
                Some(s) => s.as_integer().filter(|&s| s > 0).ok_or(Problem::BadStep)?,
            };
            Ok(Domain::Int { low, high, step })
        }
        _ => {
            let num = |x: &toml::Value| x.as_float().or_else(|| x.as_integer().map(|i| i as f64));
            let (low, high) = v
                .as_array()
                .filter(|a| a.len() == 2)
                .and_then(|a| Some((num(&a[0])?, num(&a[1])?)))
                .ok_or(Problem::BadBounds("numbers"))?;
            if !low.is_finite() || !high.is_finite() {
                return Err(Problem::NotFinite);
            }
            if low >= high {
                return Err(Problem::EmptyRange { low, high });
            }
            if kind == "uniform" {
                Ok(Domain::Uniform { low, high })
            } else if low <= 0.0 {
                Err(Problem::NonPositiveLog)
            } else {
                Ok(Domain::LogUniform { low, high })
            }
        }
    }
}

impl Domain {
    /// Draws a value uniformly (log-uniformly for `LogUniform`).
    ///
    /// ```
    /// use rand::SeedableRng;
    /// let d = buridan_study::space::Domain::LogUniform { low: 1e-4, high: 1e-2 };
    /// let v = d.sample(&mut rand_chacha::ChaCha8Rng::seed_from_u64(1)).as_float().unwrap();
    /// assert!((1e-4..=1e-2).contains(&v));
    /// ```
    pub fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> toml::Value {
        match self {
            Domain::Choice(list) => list[rng.random_range(0..list.len())].clone(),
            Domain::Int { .. } => {
                let n = self.lattice_len();
                self.value_at(rng.random_range(0..n) as f64)
            }
            _ => {
                let (lo, hi) = self.internal_bounds();
                self.value_at(lo + (hi - lo) * rng.random::<f64>())
            }
        }
    }

    /// Number of categories of a `Choice`, `None` for numeric domains.
    ///
    /// ```
    /// use buridan_study::space::Domain;
    /// assert_eq!(Domain::Choice(vec![1.into(), 2.into()]).categories(), Some(2));
    /// assert_eq!(Domain::Uniform { low: 0.0, high: 1.0 }.categories(), None);
    /// ```
    pub fn categories(&self) -> Option<usize> {
        match self {
            Domain::Choice(list) => Some(list.len()),
            _ => None,
        }
    }

    /// Bounds of the internal coordinate samplers model: the value for
    /// `Uniform`, its logarithm for `LogUniform`, the lattice index for
    /// `Int`, the category index for `Choice`.
    ///
    /// ```
    /// use buridan_study::space::Domain;
    /// assert_eq!(Domain::Int { low: 5, high: 14, step: 1 }.internal_bounds(), (0.0, 9.0));
    /// ```
    pub fn internal_bounds(&self) -> (f64, f64) {
        match self {
            Domain::Choice(list) => (0.0, (list.len() - 1) as f64),
            Domain::Uniform { low, high } => (*low, *high),
            Domain::LogUniform { low, high } => (low.ln(), high.ln()),
            Domain::Int { .. } => (0.0, (self.lattice_len() - 1) as f64),
        }
    }

    fn lattice_len(&self) -> usize {
        match self {
            Domain::Int { low, high, step } => ((high - low) / step.max(&1)) as usize + 1,
            Domain::Choice(list) => list.len(),
            _ => 0,
        }
    }

    /// The value at internal coordinate `x` (clamped to the bounds, rounded
    /// for `Int` and `Choice`).
    ///
    /// ```
    /// use buridan_study::space::Domain;
    /// let d = Domain::Int { low: 0, high: 10, step: 2 };
    /// assert_eq!(d.value_at(2.4), toml::Value::Integer(4));
    /// assert_eq!(d.value_at(99.0), toml::Value::Integer(10));
    /// ```
    pub fn value_at(&self, x: f64) -> toml::Value {
        let (lo, hi) = self.internal_bounds();
        let x = if x.is_nan() { lo } else { x.clamp(lo, hi) };
        match self {
            Domain::Choice(list) => list[x.round() as usize].clone(),
            Domain::Uniform { .. } => toml::Value::Float(x),
            Domain::LogUniform { low, high } => {
                toml::Value::Float(round_significant(x.exp(), 10).clamp(*low, *high))
            }
            Domain::Int { low, step, .. } => toml::Value::Integer(low + step * x.round() as i64),
        }
    }

    /// The internal coordinate of a value, `None` if it is not in the domain.
    ///
    /// ```
    /// use buridan_study::space::Domain;
    /// let d = Domain::Choice(vec!["a".into(), "b".into()]);
    /// assert_eq!(d.coordinate(&"b".into()), Some(1.0));
    /// assert_eq!(d.coordinate(&"c".into()), None);
    /// ```
    pub fn coordinate(&self, v: &toml::Value) -> Option<f64> {
        let num = v.as_float().or_else(|| v.as_integer().map(|i| i as f64));
        match self {
            Domain::Choice(list) => list.iter().position(|c| c == v).map(|i| i as f64),
            Domain::Uniform { low, high } => num.filter(|x| (*low..=*high).contains(x)),
            Domain::LogUniform { low, high } => num
                .filter(|x| (*low * (1.0 - 1e-12)..=*high * (1.0 + 1e-12)).contains(x))
                .map(f64::ln),
            Domain::Int { low, high, step } => {
                let i = v.as_integer()?;
                ((*low..=*high).contains(&i) && (i - low) % step == 0)
                    .then(|| ((i - low) / step) as f64)
            }
        }
    }

    /// Evenly spaced values for a grid: every choice and every lattice
    /// point (up to `resolution` of them), `resolution` points of a float
    /// range (geometric for `LogUniform`).
    ///
    /// ```
    /// use buridan_study::space::Domain;
    /// let g = Domain::LogUniform { low: 1e-4, high: 1e-2 }.grid(3);
    /// let v: Vec<f64> = g.iter().map(|x| x.as_float().unwrap()).collect();
    /// assert_eq!(v, [1e-4, 1e-3, 1e-2]);
    /// ```
    pub fn grid(&self, resolution: usize) -> Vec<toml::Value> {
        let resolution = resolution.max(1);
        match self {
            Domain::Choice(list) => list.clone(),
            Domain::Int { .. } if self.lattice_len() <= resolution => (0..self.lattice_len())
                .map(|i| self.value_at(i as f64))
                .collect(),
            _ => {
                let (lo, hi) = self.internal_bounds();
                if resolution == 1 {
                    return vec![self.value_at((lo + hi) / 2.0)];
                }
                let mut out: Vec<toml::Value> = (0..resolution)
                    .map(|i| self.value_at(lo + (hi - lo) * i as f64 / (resolution - 1) as f64))
                    .collect();
                out.dedup();
                out
            }
        }
    }
}

/// `x` rounded to `digits` significant digits, so that `exp(ln 1e-3)` reads
/// `0.001` in files and flags.
fn round_significant(x: f64, digits: i32) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    let scale = 10f64.powi(digits - 1 - x.abs().log10().floor() as i32);
    let r = (x * scale).round() / scale;
    if r.is_finite() {
        r
    } else {
        x
    }
}
