//! What the learning recipe adds to the dissertation's env: observation
//! features that carry the layout's structure, and reward shaping on the
//! shortest-path distance. Both are off by default, so the `thesis` setup
//! stays bit-for-bit the dissertation's.
//!
//! # The path feature
//!
//! The local window shows 5×5 cells; on a 20×30 layout the way to a goal
//! often leads away from it first (around a rack, out of a dead-end aisle),
//! which no window and no goal offset reveals. With [`ObsFeatures::path`] the
//! local observation ends with [`PATH_FEATURE_DIM`] more floats:
//!
//! | offset (after the base observation) | content |
//! |---|---|
//! | `0..4` | 1 if moving up / right / down / left leads one step closer to the goal on the static layout (a shortest-path direction), else 0 |
//! | `4` | the goal distance in steps / (height + width), the cost-to-go |
//!
//! Distances come from the map's cached breadth-first search, ignoring other
//! agents, so the field is the same for every policy and costs one table
//! lookup per neighbour.
//!
//! # The priority feature
//!
//! Two agents with the same observation and one shared policy choose the
//! same action: face to face in an aisle, both wait forever (Buridan's
//! donkey). Sampling breaks the tie by chance; a greedy policy needs a
//! reason to act differently. With [`ObsFeatures::priority`] each agent
//! gets PIBT's priority (Okumura et al., 2022): the steps it has been off
//! its goal since it last stood on it, ties going to the lower index (the
//! agent that moves first under the env's rules). The observation then ends
//! with [`priority_feature_dim`]`(R)` floats:
//!
//! | offset | content |
//! |---|---|
//! | `0..(2R+1)²` | per window cell (row-major, as the window): +1 if another agent stands there and outranks the observer, −1 if the observer outranks it, else 0 |
//! | `(2R+1)²` | the observer's own urgency: steps off goal / `T_max`, at most 1 |
//!
//! Priorities need no random draws, so episodes stay reproducible and the
//! dynamics stay the dissertation's.
//!
//! # The pressure feature
//!
//! With [`ObsFeatures::pressure`], [`PRESSURE_FEATURE_DIM`] more floats: for
//! each neighbour up / right / down / left, 1 if another agent stands there
//! whose shortest path to its goal leads through the observer's cell (the
//! observer is in its way), else 0 — the blocking pressure the
//! dissertation's author later added to the reference env.
//!
//! # The intent feature
//!
//! The window shows where the other agents stand, not where they are
//! going: two agents bound for one dead-end aisle must enter it deepest
//! goal first, and nothing in the observer's view says which goal is
//! whose. With [`ObsFeatures::intent`] each window cell holding another
//! agent carries that agent's own path feature — its shortest-path
//! directions and cost-to-go —, so the observation ends with
//! [`intent_feature_dim`]`(R)` floats:
//!
//! | offset | content |
//! |---|---|
//! | `5k .. 5k+5` | window cell `k` (row-major, as the window): the path feature of the other agent standing there (0 on its goal), zeros if the cell holds no other agent |
//!
//! The observer's own directions are the path feature's; its centre cell
//! stays zero.
//!
//! # The order feature
//!
//! Intent shows each neighbour's cost-to-go, which mixes where it stands
//! with where it goes. Which of two agents bound for one dead-end aisle
//! must enter first is a fact about their goals alone: the one whose goal
//! the other passes on its way. With [`ObsFeatures::order`] each window
//! cell holding another agent `j` carries two flags, so the observation
//! ends with [`order_feature_dim`]`(R)` floats:
//!
//! | offset | content |
//! |---|---|
//! | `2k` | window cell `k`: 1 if `j`'s goal lies on a shortest path from the observer to its own goal (the observer's goal is the deeper one: it goes first), else 0 |
//! | `2k + 1` | 1 if the observer's goal lies on a shortest path from `j` to `j`'s goal (`j` goes first), else 0 |
//!
//! "On a shortest path" is `d(a, g) + d(g, b) = d(a, b)` on the map's
//! cached distance tables, so a flag costs three lookups. Two agents with
//! one goal cell flag nothing; an agent on its goal flags nothing as the
//! observer (its way is empty) but is still flagged by others.
//!
//! The features follow one another in this order: path, priority,
//! pressure, intent, order.
//!
//! # Shaping
//!
//! With [`Shaping`] each agent's reward gets `coeff · (γ·Φ(s′) − Φ(s))`, with
//! the potential `Φ = −(goal distance)`: potential-based shaping (Ng, Harada
//! and Russell, 1999), which leaves the optimal policies of the discounted
//! task unchanged while rewarding every step towards the goal. Reported
//! episode returns stay the unshaped ones, so they compare with the
//! dissertation's.

use serde::{Deserialize, Serialize};

/// Floats the path feature appends to a local observation.
pub const PATH_FEATURE_DIM: usize = 5;

/// Floats the pressure feature appends to a local observation.
pub const PRESSURE_FEATURE_DIM: usize = 4;

/// Floats the priority feature appends to a local observation with sensor
/// range `r`: one per window cell and the own urgency.
///
/// ```
/// assert_eq!(buridan_env::priority_feature_dim(2), 26);
/// ```
pub const fn priority_feature_dim(sensor_range: usize) -> usize {
    let side = 2 * sensor_range + 1;
    side * side + 1
}

/// Floats the intent feature appends to a local observation with sensor
/// range `r`: the path feature of the agent in each window cell.
///
/// ```
/// assert_eq!(buridan_env::intent_feature_dim(2), 125);
/// ```
pub const fn intent_feature_dim(sensor_range: usize) -> usize {
    let side = 2 * sensor_range + 1;
    side * side * PATH_FEATURE_DIM
}

/// Floats the order feature appends to a local observation with sensor
/// range `r`: two flags per window cell.
///
/// ```
/// assert_eq!(buridan_env::order_feature_dim(2), 50);
/// ```
pub const fn order_feature_dim(sensor_range: usize) -> usize {
    let side = 2 * sensor_range + 1;
    side * side * 2
}

/// Optional local-observation features (none by default: the dissertation's
/// observation).
///
/// ```
/// use buridan_env::ObsFeatures;
/// assert_eq!(ObsFeatures::default().extra_dim(2), 0);
/// let path = ObsFeatures { path: true, ..ObsFeatures::default() };
/// assert_eq!(path.extra_dim(2), 5);
/// let all = ObsFeatures { path: true, priority: true, pressure: true, intent: true, order: true };
/// assert_eq!(all.extra_dim(2), 5 + 26 + 4 + 125 + 50);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ObsFeatures {
    /// The shortest-path direction field and the cost-to-go (module docs).
    pub path: bool,
    /// PIBT's priorities of the agents in the window (module docs).
    pub priority: bool,
    /// Which neighbours the observer stands in the way of (module docs).
    pub pressure: bool,
    /// Where the agents in the window are headed (module docs).
    pub intent: bool,
    /// Whose goal lies on whose way, for the agents in the window (module
    /// docs).
    pub order: bool,
}

/// One observation feature: the registry of what the recipe can add to a
/// local observation, in observation order ([`Feature::ALL`]). Each
/// feature's size, name and switch in [`ObsFeatures`] are written here
/// once; the observation writer appends the features that are on in this
/// order.
///
/// ```
/// use buridan_env::recipe::Feature;
/// let names: Vec<_> = Feature::ALL.iter().map(|f| f.name()).collect();
/// assert_eq!(names, ["path", "priority", "pressure", "intent", "order"]);
/// assert_eq!(Feature::Intent.dim(2), 125);
/// assert_eq!("order".parse::<Feature>(), Ok(Feature::Order));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Feature {
    /// The shortest-path direction field and the cost-to-go.
    Path,
    /// PIBT's priorities of the agents in the window.
    Priority,
    /// Which neighbours the observer stands in the way of.
    Pressure,
    /// Where the agents in the window are headed.
    Intent,
    /// Whose goal lies on whose way, for the agents in the window.
    Order,
}

impl Feature {
    /// Every feature, in observation order.
    pub const ALL: [Feature; 5] = [
        Feature::Path,
        Feature::Priority,
        Feature::Pressure,
        Feature::Intent,
        Feature::Order,
    ];

    /// Its name in configs and the Python package.
    pub const fn name(self) -> &'static str {
        match self {
            Feature::Path => "path",
            Feature::Priority => "priority",
            Feature::Pressure => "pressure",
            Feature::Intent => "intent",
            Feature::Order => "order",
        }
    }

    /// Floats it adds to one local observation with sensor range
    /// `sensor_range`.
    pub const fn dim(self, sensor_range: usize) -> usize {
        match self {
            Feature::Path => PATH_FEATURE_DIM,
            Feature::Priority => priority_feature_dim(sensor_range),
            Feature::Pressure => PRESSURE_FEATURE_DIM,
            Feature::Intent => intent_feature_dim(sensor_range),
            Feature::Order => order_feature_dim(sensor_range),
        }
    }
}

impl std::str::FromStr for Feature {
    type Err = UnknownFeature;
    fn from_str(name: &str) -> Result<Self, Self::Err> {
        Feature::ALL
            .into_iter()
            .find(|f| f.name() == name)
            .ok_or_else(|| UnknownFeature(name.to_string()))
    }
}

impl ObsFeatures {
    /// Whether `feature` is on.
    pub const fn has(&self, feature: Feature) -> bool {
        match feature {
            Feature::Path => self.path,
            Feature::Priority => self.priority,
            Feature::Pressure => self.pressure,
            Feature::Intent => self.intent,
            Feature::Order => self.order,
        }
    }

    fn switch(&mut self, feature: Feature) -> &mut bool {
        match feature {
            Feature::Path => &mut self.path,
            Feature::Priority => &mut self.priority,
            Feature::Pressure => &mut self.pressure,
            Feature::Intent => &mut self.intent,
            Feature::Order => &mut self.order,
        }
    }

    /// The features that are on, in observation order.
    pub fn on(&self) -> impl Iterator<Item = Feature> + '_ {
        Feature::ALL.into_iter().filter(|&f| self.has(f))
    }

    /// Floats these features add to one local observation with sensor range
    /// `sensor_range`.
    pub const fn extra_dim(&self, sensor_range: usize) -> usize {
        let mut dim = 0;
        let mut k = 0;
        while k < Feature::ALL.len() {
            if self.has(Feature::ALL[k]) {
                dim += Feature::ALL[k].dim(sensor_range);
            }
            k += 1;
        }
        dim
    }

    /// True if no feature is on.
    pub const fn is_none(&self) -> bool {
        !(self.path || self.priority || self.pressure || self.intent || self.order)
    }

    /// Every feature's name, in observation order: the names a Python user
    /// passes and [`Self::names`] returns.
    pub const NAMES: [&'static str; 5] = [
        Feature::Path.name(),
        Feature::Priority.name(),
        Feature::Pressure.name(),
        Feature::Intent.name(),
        Feature::Order.name(),
    ];

    /// The features named (any order, repeats allowed).
    ///
    /// ```
    /// use buridan_env::ObsFeatures;
    /// let f = ObsFeatures::from_names(["intent", "path"]).unwrap();
    /// assert!(f.path && f.intent && !f.priority);
    /// assert_eq!(f.names(), ["path", "intent"]);
    /// assert!(ObsFeatures::from_names(["paths"]).unwrap_err().to_string().contains("'paths'"));
    /// ```
    pub fn from_names<S: AsRef<str>>(
        names: impl IntoIterator<Item = S>,
    ) -> Result<Self, UnknownFeature> {
        let mut f = Self::default();
        for name in names {
            *f.switch(name.as_ref().parse()?) = true;
        }
        Ok(f)
    }

    /// The names of the features that are on, in observation order (the
    /// inverse of [`Self::from_names`]).
    pub fn names(&self) -> Vec<&'static str> {
        self.on().map(Feature::name).collect()
    }
}

/// An observation feature name that is none of [`ObsFeatures::NAMES`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown observation feature '{0}' (expected path, priority, pressure, intent or order)")]
pub struct UnknownFeature(pub String);

/// Potential-based reward shaping on the goal distance (module docs).
///
/// ```
/// use buridan_env::Shaping;
/// let s = Shaping { coeff: 0.1, gamma: 1.0 };
/// // One step closer: +0.1; one step away: −0.1; waiting: 0.
/// assert!((s.bonus(10, 9) - 0.1).abs() < 1e-6);
/// assert!((s.bonus(9, 10) + 0.1).abs() < 1e-6);
/// assert_eq!(s.bonus(9, 9), 0.0);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Shaping {
    /// Reward per step of distance gained.
    pub coeff: f32,
    /// The learner's discount γ (the shaping is policy-invariant only with
    /// the same γ).
    pub gamma: f32,
}

impl Shaping {
    /// The shaping reward of a transition from goal distance `before` to
    /// `after` (in steps).
    pub fn bonus(&self, before: u16, after: u16) -> f32 {
        let (phi, phi_next) = (-(before as f32), -(after as f32));
        self.coeff * (self.gamma * phi_next - phi)
    }

    /// Checks that the coefficient and γ are usable.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.coeff.is_finite() && self.coeff >= 0.0) {
            return Err(format!(
                "shaping coefficient must be finite and ≥ 0, got {}",
                self.coeff
            ));
        }
        if !(self.gamma > 0.0 && self.gamma <= 1.0) {
            return Err(format!(
                "shaping gamma must be in (0, 1], got {}",
                self.gamma
            ));
        }
        Ok(())
    }
}
