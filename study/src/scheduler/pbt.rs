//! Population-based training's exploit-and-explore step (Jaderberg et al.,
//! "Population Based Training of Neural Networks", 2017) as a decision
//! function: members in the bottom quantile copy the checkpoint of a random
//! member of the top quantile (exploit) and perturb its hyperparameters
//! (explore). The caller restarts those members from the copied checkpoints.

use std::collections::BTreeMap;

use rand::Rng;
use serde::{Deserialize, Serialize};

use crate::overrides::Overrides;
use crate::space::{Domain, SearchSpace};

/// `TrainConfig` keys that shape the policy network (its `ModelSpec`: layer
/// sizes, recurrence, heads, inputs, value head): a checkpoint only loads
/// into a network of its own shape, so a PBT space cannot vary them.
pub const NETWORK_KEYS: &[&str] = &[
    "hidden",
    "lstm",
    "lstm_cells",
    "mode",
    "algo",
    "agents",
    "map",
    "sensor_range",
    "ppo.vf_share_layers",
];

/// The first key of `space` that PBT cannot vary ([`NETWORK_KEYS`]), if any.
///
/// ```
/// use buridan_study::{scheduler::pbt::network_key, SearchSpace};
/// let space = SearchSpace::from_toml_str("hidden = { choice = [[32], [64]] }\n\"impala.lr\" = { uniform = [0.1, 1] }").unwrap();
/// assert_eq!(network_key(&space), Some("hidden"));
/// assert_eq!(network_key(&SearchSpace::from_toml_str("\"impala.lr\" = { uniform = [0.1, 1] }").unwrap()), None);
/// ```
pub fn network_key(space: &SearchSpace) -> Option<&str> {
    space
        .params()
        .iter()
        .map(|p| p.key.as_str())
        .find(|k| NETWORK_KEYS.contains(k))
}

/// One member of the population at a synchronisation point.
///
/// ```
/// let m = buridan_study::scheduler::pbt::Member { trial: 0, score: 0.5, overrides: Default::default() };
/// assert_eq!(m.trial, 0);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Member {
    /// The member's trial id.
    pub trial: u64,
    /// Its current objective (higher is better).
    pub score: f64,
    /// Its current hyperparameters.
    pub overrides: Overrides,
}

/// Settings of exploit-and-explore, Ray Tune's defaults.
///
/// ```
/// assert_eq!(buridan_study::scheduler::pbt::PbtConfig::default().quantile, 0.25);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PbtConfig {
    /// Fraction of the population in the top and in the bottom group.
    pub quantile: f64,
    /// Probability of redrawing a parameter from its domain instead of perturbing it.
    pub resample_probability: f64,
    /// Factors a float is multiplied by (one chosen at random).
    pub factors: [f64; 2],
}

impl Default for PbtConfig {
    fn default() -> Self {
        PbtConfig {
            quantile: 0.25,
            resample_probability: 0.25,
            factors: [0.8, 1.2],
        }
    }
}

/// A bottom member's new start: copy `source`'s checkpoint, train on with `overrides`.
///
/// ```
/// let e = buridan_study::scheduler::pbt::Exploit { trial: 3, source: 0, overrides: Default::default() };
/// assert_eq!(e.source, 0);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Exploit {
    /// The member that restarts.
    pub trial: u64,
    /// The member whose checkpoint it copies.
    pub source: u64,
    /// The perturbed hyperparameters it continues with.
    pub overrides: Overrides,
}

/// Exploit-and-explore over a population: one [`Exploit`] per member of the
/// bottom quantile (at least one member when the population has two or
/// more) that scores below every member of the top quantile. A member tied
/// with the top (all at 0 % success early in training, say) copies no one:
/// that would only trade its hyperparameters for noise.
///
/// ```
/// use buridan_study::scheduler::pbt::{exploit_and_explore, Member, PbtConfig};
/// use rand::SeedableRng;
/// let space = buridan_study::SearchSpace::from_toml_str("lr = { log_uniform = [1e-4, 1e-2] }").unwrap();
/// let pop: Vec<Member> = (0..4)
///     .map(|i| Member { trial: i, score: i as f64, overrides: [("lr".to_string(), toml::Value::Float(1e-3))].into() })
///     .collect();
/// let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
/// let moves = exploit_and_explore(&pop, &space, &PbtConfig::default(), &mut rng);
/// assert_eq!(moves.len(), 1);
/// assert_eq!((moves[0].trial, moves[0].source), (0, 3)); // worst copies best
/// let tied: Vec<Member> = pop.iter().map(|m| Member { score: 0.0, ..m.clone() }).collect();
/// assert!(exploit_and_explore(&tied, &space, &PbtConfig::default(), &mut rng).is_empty());
/// ```
pub fn exploit_and_explore<R: Rng>(
    population: &[Member],
    space: &SearchSpace,
    config: &PbtConfig,
    rng: &mut R,
) -> Vec<Exploit> {
    if population.len() < 2 {
        return Vec::new();
    }
    let mut order: Vec<&Member> = population.iter().collect();
    order.sort_by(|a, b| b.score.total_cmp(&a.score).then(a.trial.cmp(&b.trial)));
    let k = ((config.quantile * order.len() as f64).round() as usize).clamp(1, order.len() / 2);
    let top = &order[..k];
    let weakest_top = top[k - 1].score;
    let bottom = &order[order.len() - k..];
    bottom
        .iter()
        .filter(|m| m.score < weakest_top)
        .map(|m| {
            let source = top[rng.random_range(0..top.len())];
            Exploit {
                trial: m.trial,
                source: source.trial,
                overrides: explore(&source.overrides, space, config, rng),
            }
        })
        .collect()
}

/// Perturbs each parameter of `overrides` that the space knows: redraw with
/// `resample_probability`, else scale floats by a factor (clamped to the
/// domain), move integers by the same factor (at least one lattice step), or
/// move a choice to a neighbouring one.
///
/// ```
/// use buridan_study::scheduler::pbt::{explore, PbtConfig};
/// use rand::SeedableRng;
/// let space = buridan_study::SearchSpace::from_toml_str("x = { uniform = [0, 10] }").unwrap();
/// let o = [("x".to_string(), toml::Value::Float(5.0))].into();
/// let cfg = PbtConfig { resample_probability: 0.0, ..Default::default() };
/// let x = explore(&o, &space, &cfg, &mut rand_chacha::ChaCha8Rng::seed_from_u64(1))["x"].as_float().unwrap();
/// assert!((x - 4.0).abs() < 1e-9 || (x - 6.0).abs() < 1e-9);
/// ```
pub fn explore<R: Rng>(
    overrides: &Overrides,
    space: &SearchSpace,
    config: &PbtConfig,
    rng: &mut R,
) -> Overrides {
    let domains: BTreeMap<&str, &Domain> = space
        .params()
        .iter()
        .map(|p| (p.key.as_str(), &p.domain))
        .collect();
    let mut out = overrides.clone();
    for (key, value) in out.iter_mut() {
        let Some(domain) = domains.get(key.as_str()) else {
            continue;
        };
        if rng.random::<f64>() < config.resample_probability {
            *value = domain.sample(rng);
            continue;
        }
        let factor = config.factors[rng.random_range(0..2)];
        let up = factor >= 1.0;
        *value = match domain {
            Domain::Choice(list) => {
                let i = domain.coordinate(value).unwrap_or(0.0) as usize;
                let j = if up {
                    (i + 1).min(list.len() - 1)
                } else {
                    i.saturating_sub(1)
                };
                list[j].clone()
            }
            Domain::Uniform { .. } | Domain::LogUniform { .. } => {
                let x = value
                    .as_float()
                    .or_else(|| value.as_integer().map(|i| i as f64));
                match (x, domain) {
                    (Some(x), Domain::LogUniform { .. }) => domain.value_at((x * factor).ln()),
                    (Some(x), _) => domain.value_at(x * factor),
                    (None, _) => domain.sample(rng),
                }
            }
            Domain::Int { low, step, .. } => {
                let Some(i) = value.as_integer() else {
                    *value = domain.sample(rng);
                    continue;
                };
                let scaled = (i as f64 * factor).round() as i64;
                let moved = if up {
                    scaled.max(i + step)
                } else {
                    scaled.min(i - step)
                };
                domain.value_at(((moved - low) as f64 / *step as f64).round())
            }
        };
    }
    out
}
