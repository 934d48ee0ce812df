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

/// Optional local-observation features (none by default: the dissertation's
/// observation).
///
/// ```
/// use buridan_env::ObsFeatures;
/// assert_eq!(ObsFeatures::default().extra_dim(), 0);
/// assert_eq!(ObsFeatures { path: true }.extra_dim(), 5);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ObsFeatures {
    /// The shortest-path direction field and the cost-to-go (module docs).
    pub path: bool,
}

impl ObsFeatures {
    /// Floats these features add to one local observation.
    pub const fn extra_dim(&self) -> usize {
        if self.path {
            PATH_FEATURE_DIM
        } else {
            0
        }
    }

    /// True if no feature is on.
    pub const fn is_none(&self) -> bool {
        !self.path
    }
}

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
