//! The run's description ↔ messages: the policy's [`ModelSpec`] as a typed
//! `ModelSpec` message, and the checks a `RunSpec` from the wire must pass
//! before an actor builds anything from it. Every refusal names the field
//! by its path in the join reply (`run.model.hidden[1]`).

use buridan_env::{ObsFeatures, Rules};
use buridan_policy::{Activation, LstmSpec, Mode, ModelSpec, ValueHead};

use super::ConvertError;
use crate::v1;

/// A count for the wire; counts past `u32::MAX` (never a real spec's)
/// saturate, and the receiving side refuses nothing for it.
fn wire_u32(n: usize) -> u32 {
    u32::try_from(n).unwrap_or(u32::MAX)
}

/// A model spec for the wire.
///
/// ```
/// use buridan_policy::{ModelSpec, Mode};
/// use buridan_proto::convert::{model_spec_from_message, model_spec_to_message};
/// let spec = ModelSpec::new(Mode::Cte, 4, 1800);
/// let m = model_spec_to_message(&spec);
/// assert_eq!(m.heads, 4);
/// assert_eq!(model_spec_from_message(&m).unwrap(), spec);
/// ```
pub fn model_spec_to_message(s: &ModelSpec) -> v1::ModelSpec {
    v1::ModelSpec {
        obs_dim: wire_u32(s.obs_dim),
        heads: wire_u32(s.heads),
        actions: wire_u32(s.actions),
        hidden: s.hidden.iter().map(|&h| wire_u32(h)).collect(),
        activation: match s.activation {
            Activation::Tanh => v1::Activation::Tanh,
            Activation::Relu => v1::Activation::Relu,
        } as i32,
        value: match s.value {
            ValueHead::Shared => v1::ValueHead::Shared,
            ValueHead::Separate => v1::ValueHead::Separate,
        } as i32,
        lstm: s.lstm.map(|l| v1::LstmSpec {
            cells: wire_u32(l.cells),
            prev_action: l.prev_action,
            prev_reward: l.prev_reward,
        }),
        mode: match s.mode {
            Mode::Cte => v1::Mode::Cte,
            Mode::Ctde => v1::Mode::Ctde,
            Mode::Dte => v1::Mode::Dte,
        } as i32,
        agents: wire_u32(s.agents),
        features: (!s.features.is_none()).then_some(v1::ObsFeatures {
            path: s.features.path,
            priority: s.features.priority,
            pressure: s.features.pressure,
            intent: s.features.intent,
            order: s.features.order,
        }),
        sensor_range: wire_u32(s.sensor_range),
        maps: s.maps.clone(),
        rules: match s.rules {
            Rules::Thesis => v1::Rules::Thesis,
            Rules::Pogema => v1::Rules::Pogema,
        } as i32,
    }
}

/// An enum field's value: known and not its UNSPECIFIED zero.
fn known<E>(field: &'static str, value: i32, unspecified: E) -> Result<E, ConvertError>
where
    E: TryFrom<i32> + PartialEq,
{
    match E::try_from(value) {
        Err(_) => Err(ConvertError::UnknownEnum { field, value }),
        Ok(e) if e == unspecified => Err(ConvertError::Missing { field }),
        Ok(e) => Ok(e),
    }
}

/// A size that must be positive.
fn positive(field: &'static str, n: u32) -> Result<usize, ConvertError> {
    if n == 0 {
        Err(ConvertError::Zero { field, index: None })
    } else {
        Ok(n as usize)
    }
}

/// A model spec from the wire, checked: every size positive (hidden layers:
/// at least one), every enum a value it defines and set, and the whole
/// consistent ([`ModelSpec::validate`]: heads that fit the mode).
///
/// ```
/// use buridan_policy::{ModelSpec, Mode};
/// use buridan_proto::convert::{model_spec_from_message, model_spec_to_message};
/// let mut m = model_spec_to_message(&ModelSpec::new(Mode::Ctde, 2, 11));
/// m.mode = 9;
/// let err = model_spec_from_message(&m).unwrap_err();
/// assert_eq!(err.to_string(), "run.model.mode = 9 is not a value its enum defines");
/// ```
pub fn model_spec_from_message(m: &v1::ModelSpec) -> Result<ModelSpec, ConvertError> {
    let obs_dim = positive("run.model.obs_dim", m.obs_dim)?;
    let heads = positive("run.model.heads", m.heads)?;
    let actions = positive("run.model.actions", m.actions)?;
    let agents = positive("run.model.agents", m.agents)?;
    if m.hidden.is_empty() {
        return Err(ConvertError::Missing {
            field: "run.model.hidden",
        });
    }
    if let Some(index) = m.hidden.iter().position(|&h| h == 0) {
        return Err(ConvertError::Zero {
            field: "run.model.hidden",
            index: Some(index),
        });
    }
    let activation = match known(
        "run.model.activation",
        m.activation,
        v1::Activation::Unspecified,
    )? {
        v1::Activation::Relu => Activation::Relu,
        _ => Activation::Tanh,
    };
    let value = match known("run.model.value", m.value, v1::ValueHead::Unspecified)? {
        v1::ValueHead::Separate => ValueHead::Separate,
        _ => ValueHead::Shared,
    };
    let mode = match known("run.model.mode", m.mode, v1::Mode::Unspecified)? {
        v1::Mode::Cte => Mode::Cte,
        v1::Mode::Dte => Mode::Dte,
        _ => Mode::Ctde,
    };
    let rules = match known("run.model.rules", m.rules, v1::Rules::Unspecified)? {
        v1::Rules::Pogema => Rules::Pogema,
        _ => Rules::Thesis,
    };
    let lstm = match &m.lstm {
        None => None,
        Some(l) => Some(LstmSpec {
            cells: positive("run.model.lstm.cells", l.cells)?,
            prev_action: l.prev_action,
            prev_reward: l.prev_reward,
        }),
    };
    let features = m
        .features
        .as_ref()
        .map_or_else(ObsFeatures::default, |f| ObsFeatures {
            path: f.path,
            priority: f.priority,
            pressure: f.pressure,
            intent: f.intent,
            order: f.order,
        });
    let spec = ModelSpec {
        obs_dim,
        heads,
        actions,
        hidden: m.hidden.iter().map(|&h| h as usize).collect(),
        activation,
        value,
        lstm,
        mode,
        agents,
        features,
        sensor_range: m.sensor_range as usize,
        maps: m.maps.clone(),
        rules,
    };
    spec.validate().map_err(|e| ConvertError::Field {
        field: "run.model",
        reason: e.to_string(),
    })?;
    Ok(spec)
}

impl From<&ModelSpec> for v1::ModelSpec {
    fn from(s: &ModelSpec) -> Self {
        model_spec_to_message(s)
    }
}

impl TryFrom<&v1::ModelSpec> for ModelSpec {
    type Error = ConvertError;
    fn try_from(m: &v1::ModelSpec) -> Result<Self, ConvertError> {
        model_spec_from_message(m)
    }
}

/// Checks a run spec from the wire and returns its model spec, typed: the
/// model is there and valid ([`model_spec_from_message`]), fragments have a
/// positive length, `greedy_mix` is a probability, and the run is either a
/// grid run (map and env settings, no plant) or a plant run (the plant's
/// settings, neither map nor env). The map, env settings and replay
/// settings are checked where they are converted
/// ([`super::map_from_message`], [`super::env_from_message`]).
///
/// ```
/// use buridan_policy::{ModelSpec, Mode};
/// use buridan_proto::convert::{check_run_spec, model_spec_to_message};
/// use buridan_proto::v1;
/// let spec = ModelSpec::new(Mode::Ctde, 2, 11);
/// let mut run = v1::RunSpec {
///     model: Some(model_spec_to_message(&spec)),
///     plant: Some(v1::PlantSettings { name: "plant:dissertation".into(), agents: 2, t_max: 1000 }),
///     fragment_len: 50,
///     ..Default::default()
/// };
/// assert_eq!(check_run_spec(&run).unwrap(), spec);
/// run.model = None;
/// assert_eq!(check_run_spec(&run).unwrap_err().to_string(), "run.model is missing");
/// ```
pub fn check_run_spec(m: &v1::RunSpec) -> Result<ModelSpec, ConvertError> {
    let spec = model_spec_from_message(
        m.model
            .as_ref()
            .ok_or(ConvertError::Missing { field: "run.model" })?,
    )?;
    positive("run.fragment_len", m.fragment_len)?;
    if !(0.0..=1.0).contains(&m.greedy_mix) {
        return Err(ConvertError::Field {
            field: "run.greedy_mix",
            reason: format!("{} is not a probability in [0, 1]", m.greedy_mix),
        });
    }
    match (&m.plant, &m.map, &m.env) {
        (Some(_), None, None) | (None, Some(_), Some(_)) => {}
        (Some(_), _, _) => {
            return Err(ConvertError::Field {
                field: "run.plant",
                reason: "set beside a map or env settings (a plant run has neither)".into(),
            })
        }
        (None, None, _) => return Err(ConvertError::Missing { field: "run.map" }),
        (None, _, None) => return Err(ConvertError::Missing { field: "run.env" }),
    }
    Ok(spec)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A spec with every field off its default.
    fn everything() -> ModelSpec {
        ModelSpec {
            hidden: vec![128, 32, 7],
            activation: Activation::Relu,
            value: ValueHead::Separate,
            lstm: Some(LstmSpec {
                cells: 16,
                prev_action: false,
                prev_reward: true,
            }),
            features: ObsFeatures {
                path: true,
                priority: false,
                pressure: true,
                intent: true,
                order: false,
            },
            sensor_range: 4,
            maps: vec!["rm-2.1".into(), "rm-3.2".into()],
            rules: Rules::Pogema,
            ..ModelSpec::new(Mode::Dte, 3, 412)
        }
    }

    #[test]
    fn model_specs_round_trip() {
        let mut specs = vec![everything()];
        for mode in [Mode::Cte, Mode::Ctde, Mode::Dte] {
            specs.push(ModelSpec::new(mode, 4, 129));
        }
        specs.push(ModelSpec {
            lstm: Some(LstmSpec::default()),
            ..ModelSpec::new(Mode::Ctde, 2, 11)
        });
        for spec in specs {
            let m = model_spec_to_message(&spec);
            assert_eq!(model_spec_from_message(&m).unwrap(), spec);
            assert_eq!(
                ModelSpec::try_from(&v1::ModelSpec::from(&spec)).unwrap(),
                spec
            );
        }
        // No extra features travel as no message.
        assert!(model_spec_to_message(&ModelSpec::new(Mode::Ctde, 2, 11))
            .features
            .is_none());
    }

    /// `edit` applied to a valid message gives exactly `expected`.
    fn refused(edit: impl FnOnce(&mut v1::ModelSpec), expected: &str) {
        let mut m = model_spec_to_message(&everything());
        edit(&mut m);
        let err = model_spec_from_message(&m).unwrap_err();
        assert_eq!(err.to_string(), expected);
    }

    #[test]
    fn zero_sizes_are_refused_naming_the_field() {
        refused(
            |m| m.obs_dim = 0,
            "run.model.obs_dim is 0 (must be positive)",
        );
        refused(|m| m.heads = 0, "run.model.heads is 0 (must be positive)");
        refused(
            |m| m.actions = 0,
            "run.model.actions is 0 (must be positive)",
        );
        refused(|m| m.agents = 0, "run.model.agents is 0 (must be positive)");
        refused(
            |m| m.hidden[1] = 0,
            "run.model.hidden[1] is 0 (must be positive)",
        );
        refused(
            |m| m.lstm.as_mut().unwrap().cells = 0,
            "run.model.lstm.cells is 0 (must be positive)",
        );
    }

    #[test]
    fn missing_parts_are_refused_naming_the_field() {
        refused(|m| m.hidden.clear(), "run.model.hidden is missing");
        refused(|m| m.mode = 0, "run.model.mode is missing");
        refused(|m| m.activation = 0, "run.model.activation is missing");
        refused(|m| m.value = 0, "run.model.value is missing");
        refused(|m| m.rules = 0, "run.model.rules is missing");
    }

    #[test]
    fn unknown_enum_values_are_refused_naming_the_field() {
        refused(
            |m| m.mode = 4,
            "run.model.mode = 4 is not a value its enum defines",
        );
        refused(
            |m| m.activation = -1,
            "run.model.activation = -1 is not a value its enum defines",
        );
        refused(
            |m| m.value = 3,
            "run.model.value = 3 is not a value its enum defines",
        );
        refused(
            |m| m.rules = i32::MAX,
            "run.model.rules = 2147483647 is not a value its enum defines",
        );
    }

    #[test]
    fn an_inconsistent_spec_is_refused() {
        // DTE has one head; two do not fit.
        refused(
            |m| m.heads = 2,
            "run.model: invalid model spec: mode dte with 3 agents needs 1 heads, spec has 2",
        );
    }

    fn grid_run() -> v1::RunSpec {
        v1::RunSpec {
            model: Some(model_spec_to_message(&everything())),
            map: Some(v1::MapSource::default()),
            env: Some(v1::EnvSettings::default()),
            fragment_len: 20,
            greedy_mix: 0.25,
            ..Default::default()
        }
    }

    #[test]
    fn run_specs_are_checked() {
        assert_eq!(check_run_spec(&grid_run()).unwrap(), everything());
        let plant = v1::RunSpec {
            map: None,
            env: None,
            plant: Some(v1::PlantSettings::default()),
            ..grid_run()
        };
        check_run_spec(&plant).unwrap();
        let cases: [(v1::RunSpec, &str); 8] = [
            (
                v1::RunSpec {
                    model: None,
                    ..grid_run()
                },
                "run.model is missing",
            ),
            (
                v1::RunSpec {
                    model: Some(v1::ModelSpec::default()),
                    ..grid_run()
                },
                "run.model.obs_dim is 0 (must be positive)",
            ),
            (
                v1::RunSpec {
                    fragment_len: 0,
                    ..grid_run()
                },
                "run.fragment_len is 0 (must be positive)",
            ),
            (
                v1::RunSpec {
                    greedy_mix: 1.5,
                    ..grid_run()
                },
                "run.greedy_mix: 1.5 is not a probability in [0, 1]",
            ),
            (
                v1::RunSpec {
                    greedy_mix: f32::NAN,
                    ..grid_run()
                },
                "run.greedy_mix: NaN is not a probability in [0, 1]",
            ),
            (
                v1::RunSpec {
                    map: None,
                    ..grid_run()
                },
                "run.map is missing",
            ),
            (
                v1::RunSpec {
                    env: None,
                    ..grid_run()
                },
                "run.env is missing",
            ),
            (
                v1::RunSpec {
                    plant: Some(v1::PlantSettings::default()),
                    ..grid_run()
                },
                "run.plant: set beside a map or env settings (a plant run has neither)",
            ),
        ];
        for (run, expected) in cases {
            assert_eq!(check_run_spec(&run).unwrap_err().to_string(), expected);
        }
    }
}
