//! The run's settings ↔ messages: weights, env settings, failure replay
//! and map texts.

use buridan_env::replay::ReplayConfig;
use buridan_env::{EnvConfig, MapSource, ObsFeatures, Shaping, Starts};
use buridan_policy::{NamedTensor, Weights};

use super::ConvertError;
use crate::v1;

/// Weights for the wire.
pub fn weights_to_message(w: &Weights, run_id: &str) -> v1::Parameters {
    v1::Parameters {
        run_id: run_id.to_string(),
        version: w.version,
        tensors: w
            .tensors
            .iter()
            .map(|t| v1::Tensor {
                name: t.name.clone(),
                shape: t.shape.iter().map(|&d| d as u32).collect(),
                data: t.data.clone(),
            })
            .collect(),
        finished: false,
    }
}

/// Weights from the wire, with each tensor's data checked against its shape
/// and for finite values (names and shapes are checked against the model
/// when the weights are loaded).
pub fn weights_from_message(m: v1::Parameters) -> Result<Weights, ConvertError> {
    let mut tensors = Vec::with_capacity(m.tensors.len());
    for t in m.tensors {
        let shape: Vec<usize> = t.shape.iter().map(|&d| d as usize).collect();
        // Checked: dimensions near u32::MAX multiply past usize, and a
        // wrapped product could match the data (found by proto/tests/fuzz.rs).
        let expected = if shape.contains(&0) {
            Some(0)
        } else {
            shape.iter().try_fold(1usize, |n, &d| n.checked_mul(d))
        };
        if expected != Some(t.data.len()) {
            return Err(ConvertError::Invalid(format!(
                "tensor '{}' has shape {shape:?} but {} values",
                t.name,
                t.data.len()
            )));
        }
        if let Some(index) = t.data.iter().position(|x| !x.is_finite()) {
            return Err(ConvertError::Invalid(format!(
                "tensor '{}' value {index} is {}",
                t.name, t.data[index]
            )));
        }
        tensors.push(NamedTensor {
            name: t.name,
            shape,
            data: t.data,
        });
    }
    Ok(Weights {
        version: m.version,
        tensors,
    })
}

/// Env settings for the wire (the seed travels separately).
pub fn env_to_message(e: &EnvConfig) -> v1::EnvSettings {
    v1::EnvSettings {
        agents: e.agents as u32,
        t_max: e.t_max,
        starts: match e.starts {
            Starts::Random => "random".into(),
            Starts::Fixed => "fixed".into(),
        },
        sensor_range: e.sensor_range as u32,
        lifelong: e.lifelong,
        stall_window: e.stall_window,
        path_feature: e.features.path,
        priority_feature: e.features.priority,
        pressure_feature: e.features.pressure,
        intent_feature: e.features.intent,
        order_feature: e.features.order,
        shaping: e.shaping.map_or(0.0, |s| s.coeff),
        shaping_gamma: e.shaping.map_or(0.0, |s| s.gamma),
        rules: e.rules.name().into(),
        delay: e.delay,
    }
}

/// Env settings from the wire, with `seed`.
pub fn env_from_message(m: &v1::EnvSettings, seed: u64) -> Result<EnvConfig, ConvertError> {
    let starts = m.starts.parse::<Starts>().map_err(ConvertError::Invalid)?;
    let rules = match m.rules.as_str() {
        // A peer from before the field existed.
        "" => buridan_env::Rules::Thesis,
        name => name
            .parse()
            .map_err(|e: buridan_env::rules::UnknownRules| ConvertError::Invalid(e.to_string()))?,
    };
    Ok(EnvConfig {
        agents: m.agents as usize,
        t_max: m.t_max,
        rules,
        starts,
        seed,
        sensor_range: m.sensor_range as usize,
        lifelong: m.lifelong,
        stall_window: m.stall_window,
        features: ObsFeatures {
            path: m.path_feature,
            priority: m.priority_feature,
            pressure: m.pressure_feature,
            intent: m.intent_feature,
            order: m.order_feature,
        },
        shaping: (m.shaping > 0.0).then_some(Shaping {
            coeff: m.shaping,
            gamma: m.shaping_gamma,
        }),
        delay: m.delay,
    })
}

/// Failure-replay settings for the wire: `None` when replay is off.
///
/// ```
/// use buridan_env::replay::ReplayConfig;
/// use buridan_proto::convert::{replay_from_message, replay_to_message};
/// assert!(replay_to_message(&ReplayConfig::default()).is_none());
/// let on = ReplayConfig { share: 0.5, ..ReplayConfig::default() };
/// assert_eq!(replay_from_message(&replay_to_message(&on).unwrap()), on);
/// ```
pub fn replay_to_message(r: &ReplayConfig) -> Option<v1::FailureReplay> {
    r.enabled().then(|| v1::FailureReplay {
        share: r.share,
        tries: r.tries,
        capacity: u32::try_from(r.capacity).unwrap_or(u32::MAX),
    })
}

/// Failure-replay settings from the wire (the env checks their ranges
/// when it wraps its slots).
pub fn replay_from_message(m: &v1::FailureReplay) -> ReplayConfig {
    ReplayConfig {
        share: m.share,
        tries: m.tries,
        capacity: m.capacity as usize,
    }
}

/// A map's texts for the wire.
pub fn map_to_message(m: &MapSource) -> v1::MapSource {
    v1::MapSource {
        name: m.name.clone(),
        map_text: m.map_text.clone(),
        scen_text: m.scen_text.clone(),
    }
}

/// A map's texts from the wire.
pub fn map_from_message(m: v1::MapSource) -> MapSource {
    MapSource {
        name: m.name,
        map_text: m.map_text,
        scen_text: m.scen_text,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn weights_round_trip_and_checks() {
        let w = Weights {
            version: 3,
            tensors: vec![NamedTensor {
                name: "a".into(),
                shape: vec![2, 1],
                data: vec![1.0, 2.0],
            }],
        };
        let m = weights_to_message(&w, "r");
        assert_eq!(weights_from_message(m.clone()).unwrap(), w);
        let mut bad = m.clone();
        bad.tensors[0].data.push(3.0);
        assert!(weights_from_message(bad).is_err());
        let mut nan = m;
        nan.tensors[0].data[0] = f32::NAN;
        assert!(weights_from_message(nan).is_err());
    }

    #[test]
    fn env_settings_carry_the_rule_set() {
        let pogema = EnvConfig::for_rules(buridan_env::Rules::Pogema);
        let m = env_to_message(&pogema);
        assert_eq!((m.rules.as_str(), m.t_max), ("pogema", 128));
        let back = env_from_message(&m, 7).unwrap();
        assert_eq!(
            (back.rules, back.t_max, back.seed),
            (buridan_env::Rules::Pogema, 128, 7)
        );
        // A peer from before the field: thesis.
        let old = v1::EnvSettings {
            rules: String::new(),
            ..m.clone()
        };
        assert_eq!(
            env_from_message(&old, 0).unwrap().rules,
            buridan_env::Rules::Thesis
        );
        let bad = v1::EnvSettings {
            rules: "chess".into(),
            ..m
        };
        let err = env_from_message(&bad, 0).unwrap_err();
        assert!(err.to_string().contains("unknown rules 'chess'"), "{err}");
    }
}
