//! The fleet control API (`control.proto`) ↔ crate types: an Open request
//! as a checked [`FleetOpen`], a Step's report as checked cells, and a
//! Step's answer as a checked [`FleetAnswer`] (what a Rust client reads).
//! Everything arriving from the wire is checked for its shape here (a
//! field set, one goal per robot, a move per robot and in range); whether
//! a cell is free, on the map and at most one step from the robot's last
//! is the env's to say ([`buridan_env::GridEnv::report`]).
//!
//! ```
//! use buridan_env::{Cell, Rules};
//! use buridan_proto::control_convert::{
//!     open_from_message, open_to_message, report_from_message, FleetMapSource, FleetOpen,
//! };
//! let open = FleetOpen {
//!     map: FleetMapSource::Id("rm-2.1".into()),
//!     rules: Rules::Thesis,
//!     controller: "pibt".into(),
//!     positions: vec![Cell::new(1, 1), Cell::new(1, 2)],
//!     goals: vec![Cell::new(8, 1), Cell::new(8, 2)],
//!     seed: 7,
//!     shared_goals: false,
//! };
//! assert_eq!(open_from_message(open_to_message(&open)).unwrap(), open);
//! let msg = open_to_message(&open);
//! let err = report_from_message(&msg.positions, &msg.goals[..1], 2).unwrap_err();
//! assert_eq!(err.to_string(), "goals holds 1 values, expected 2");
//! ```

use buridan_env::map::MapSource;
use buridan_env::{Cell, Rules, NUM_ACTIONS};

use crate::convert::{check_below, ConvertError};
use crate::v1;

/// Where a fleet's map comes from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum FleetMapSource {
    /// A bundled reference model id or a generated map's spec.
    Id(String),
    /// A MovingAI map's text.
    Text(MapSource),
}

/// An Open request, checked: a map, a known rule set, a controller named,
/// at least one robot and one goal per robot.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FleetOpen {
    /// The map.
    pub map: FleetMapSource,
    /// The rule set.
    pub rules: Rules,
    /// The controller in the controller grammar (parsed by the server).
    pub controller: String,
    /// Each robot's cell.
    pub positions: Vec<Cell>,
    /// Each robot's goal.
    pub goals: Vec<Cell>,
    /// Seeds the controller's draws.
    pub seed: u64,
    /// Whether robots may share a goal cell.
    pub shared_goals: bool,
}

/// A Step's answer, checked: one move per robot, each in `0..5`;
/// override flags for every robot or none.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct FleetAnswer {
    /// One move per robot (0 stay, 1 up, 2 right, 3 down, 4 left).
    pub moves: Vec<u8>,
    /// Per robot, whether the shield changed the policy's choice; `None`
    /// when the controller reports no such thing.
    pub overridden: Option<Vec<bool>>,
    /// Why every robot waits (a planner found no plan), if so.
    pub note: Option<String>,
    /// Steps the session has answered, this one included.
    pub step: u64,
}

/// A cell for the wire.
pub fn cell_to_message(c: Cell) -> v1::GridCell {
    // Grids are far smaller than 2³² cells a side (MovingAI sizes are
    // u32 too), so the casts are exact.
    v1::GridCell {
        row: c.row as u32,
        col: c.col as u32,
    }
}

/// A cell from the wire.
pub fn cell_from_message(c: &v1::GridCell) -> Cell {
    Cell::new(c.row as usize, c.col as usize)
}

fn rules_to_message(rules: Rules) -> v1::Rules {
    match rules {
        Rules::Thesis => v1::Rules::Thesis,
        Rules::Pogema => v1::Rules::Pogema,
    }
}

/// An Open request for the wire.
pub fn open_to_message(o: &FleetOpen) -> v1::FleetOpenRequest {
    let source = match &o.map {
        FleetMapSource::Id(id) => v1::fleet_map::Source::Id(id.clone()),
        FleetMapSource::Text(src) => v1::fleet_map::Source::Text(v1::MapSource {
            name: src.name.clone(),
            map_text: src.map_text.clone(),
            scen_text: src.scen_text.clone(),
        }),
    };
    v1::FleetOpenRequest {
        map: Some(v1::FleetMap {
            source: Some(source),
        }),
        rules: rules_to_message(o.rules) as i32,
        controller: o.controller.clone(),
        positions: o.positions.iter().map(|&c| cell_to_message(c)).collect(),
        goals: o.goals.iter().map(|&c| cell_to_message(c)).collect(),
        seed: o.seed,
        shared_goals: o.shared_goals,
    }
}

/// An Open request from the wire, checked (see [`FleetOpen`]); an unset
/// rule set is `thesis`.
pub fn open_from_message(m: v1::FleetOpenRequest) -> Result<FleetOpen, ConvertError> {
    let map = match m.map.and_then(|map| map.source) {
        None => return Err(ConvertError::Missing { field: "map" }),
        Some(v1::fleet_map::Source::Id(id)) if id.trim().is_empty() => {
            return Err(ConvertError::Missing { field: "map.id" })
        }
        Some(v1::fleet_map::Source::Id(id)) => FleetMapSource::Id(id),
        Some(v1::fleet_map::Source::Text(src)) => {
            if src.map_text.trim().is_empty() {
                return Err(ConvertError::Missing {
                    field: "map.text.map_text",
                });
            }
            FleetMapSource::Text(MapSource {
                name: if src.name.is_empty() {
                    "fleet".into()
                } else {
                    src.name
                },
                map_text: src.map_text,
                // The robots come with the request, not from a scenario.
                scen_text: None,
            })
        }
    };
    let rules = match v1::Rules::try_from(m.rules) {
        Ok(v1::Rules::Unspecified | v1::Rules::Thesis) => Rules::Thesis,
        Ok(v1::Rules::Pogema) => Rules::Pogema,
        Err(_) => {
            return Err(ConvertError::UnknownEnum {
                field: "rules",
                value: m.rules,
            })
        }
    };
    if m.controller.trim().is_empty() {
        return Err(ConvertError::Missing {
            field: "controller",
        });
    }
    if m.positions.is_empty() {
        return Err(ConvertError::Field {
            field: "positions",
            reason: "no robots (a session needs at least one)".into(),
        });
    }
    let (positions, goals) = report_from_message(&m.positions, &m.goals, m.positions.len())?;
    Ok(FleetOpen {
        map,
        rules,
        controller: m.controller,
        positions,
        goals,
        seed: m.seed,
        shared_goals: m.shared_goals,
    })
}

/// A Step's report from the wire: `agents` positions and as many goals.
pub fn report_from_message(
    positions: &[v1::GridCell],
    goals: &[v1::GridCell],
    agents: usize,
) -> Result<(Vec<Cell>, Vec<Cell>), ConvertError> {
    for (field, cells) in [("positions", positions), ("goals", goals)] {
        if cells.len() != agents {
            return Err(ConvertError::Length {
                field,
                expected: agents,
                got: cells.len(),
            });
        }
    }
    Ok((
        positions.iter().map(cell_from_message).collect(),
        goals.iter().map(cell_from_message).collect(),
    ))
}

/// A Step request for the wire.
pub fn report_to_message(session: u64, positions: &[Cell], goals: &[Cell]) -> v1::FleetStepRequest {
    v1::FleetStepRequest {
        session,
        positions: positions.iter().map(|&c| cell_to_message(c)).collect(),
        goals: goals.iter().map(|&c| cell_to_message(c)).collect(),
    }
}

/// A Step's answer for the wire.
pub fn answer_to_message(a: &FleetAnswer) -> v1::FleetStepReply {
    v1::FleetStepReply {
        moves: a.moves.clone(),
        overridden: a.overridden.clone().unwrap_or_default(),
        note: a.note.clone().unwrap_or_default(),
        step: a.step,
    }
}

/// A Step's answer from the wire, checked for a session of `agents`
/// robots: one move per robot, each below 5; no flags or one per robot.
///
/// ```
/// use buridan_proto::control_convert::answer_from_message;
/// use buridan_proto::v1::FleetStepReply;
/// let reply = FleetStepReply { moves: vec![0, 2], overridden: vec![false, true], step: 1, ..Default::default() };
/// let answer = answer_from_message(reply, 2).unwrap();
/// assert_eq!(answer.overridden, Some(vec![false, true]));
/// let bad = FleetStepReply { moves: vec![0, 5], ..Default::default() };
/// assert_eq!(answer_from_message(bad, 2).unwrap_err().to_string(), "moves[1] = 5 is out of range (must be < 5)");
/// ```
pub fn answer_from_message(
    m: v1::FleetStepReply,
    agents: usize,
) -> Result<FleetAnswer, ConvertError> {
    if m.moves.len() != agents {
        return Err(ConvertError::Length {
            field: "moves",
            expected: agents,
            got: m.moves.len(),
        });
    }
    check_below("moves", &m.moves, NUM_ACTIONS as u64)?;
    let overridden = match m.overridden.len() {
        0 => None,
        n if n == agents => Some(m.overridden),
        got => {
            return Err(ConvertError::Length {
                field: "overridden",
                expected: agents,
                got,
            })
        }
    };
    Ok(FleetAnswer {
        moves: m.moves,
        overridden,
        note: (!m.note.is_empty()).then_some(m.note),
        step: m.step,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn open() -> FleetOpen {
        FleetOpen {
            map: FleetMapSource::Text(MapSource {
                name: "tiny".into(),
                map_text: "type octile\nheight 1\nwidth 3\nmap\n...\n".into(),
                scen_text: None,
            }),
            rules: Rules::Pogema,
            controller: "lacam".into(),
            positions: vec![Cell::new(0, 0)],
            goals: vec![Cell::new(0, 2)],
            seed: 1,
            shared_goals: true,
        }
    }

    #[test]
    fn an_open_request_round_trips_and_is_checked() {
        let o = open();
        assert_eq!(open_from_message(open_to_message(&o)).unwrap(), o);
        let mut m = open_to_message(&o);
        m.rules = 0;
        assert_eq!(open_from_message(m).unwrap().rules, Rules::Thesis);
        let mut m = open_to_message(&o);
        m.rules = 9;
        assert_eq!(
            open_from_message(m).unwrap_err().to_string(),
            "rules = 9 is not a value its enum defines"
        );
        let mut m = open_to_message(&o);
        m.map = None;
        assert_eq!(
            open_from_message(m).unwrap_err().to_string(),
            "map is missing"
        );
        let mut m = open_to_message(&o);
        m.controller = " ".into();
        assert_eq!(
            open_from_message(m).unwrap_err().to_string(),
            "controller is missing"
        );
        let mut m = open_to_message(&o);
        m.positions.clear();
        m.goals.clear();
        assert!(open_from_message(m)
            .unwrap_err()
            .to_string()
            .contains("no robots"));
        let mut m = open_to_message(&o);
        m.goals.push(v1::GridCell { row: 0, col: 1 });
        assert_eq!(
            open_from_message(m).unwrap_err().to_string(),
            "goals holds 2 values, expected 1"
        );
    }

    #[test]
    fn an_answer_round_trips_and_is_checked() {
        let a = FleetAnswer {
            moves: vec![1, 0, 4],
            overridden: Some(vec![true, false, false]),
            note: None,
            step: 3,
        };
        assert_eq!(answer_from_message(answer_to_message(&a), 3).unwrap(), a);
        let waits = FleetAnswer {
            moves: vec![0; 3],
            overridden: None,
            note: Some("no plan".into()),
            step: 4,
        };
        assert_eq!(
            answer_from_message(answer_to_message(&waits), 3).unwrap(),
            waits
        );
        assert!(answer_from_message(answer_to_message(&a), 2).is_err());
        let mut m = answer_to_message(&a);
        m.overridden.pop();
        assert_eq!(
            answer_from_message(m, 3).unwrap_err().to_string(),
            "overridden holds 2 values, expected 3"
        );
    }
}
