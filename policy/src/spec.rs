//! The model specification: everything needed to rebuild a network from a
//! checkpoint's weights.

use buridan_env::{ObsFeatures, Rules};
use serde::{Deserialize, Serialize};

use crate::error::PolicyError;

/// Actions per categorical head (0 stay, 1 up, 2 right, 3 down, 4 left).
pub const ACTIONS_PER_HEAD: usize = 5;

/// Training/execution mode (SPEC §3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// Centralized training and execution: one controller, central
    /// observation, one head per agent (joint action).
    Cte,
    /// Centralized training, decentralized execution: one policy shared by
    /// all agents, local observations, one head.
    Ctde,
    /// Decentralized training and execution: one independent policy (own
    /// weights) per agent id, local observations, one head.
    Dte,
}

impl Mode {
    /// The observations the mode consumes: central for CTE, local otherwise.
    ///
    /// ```
    /// use buridan_env::ObsKind;
    /// use buridan_policy::Mode;
    /// assert_eq!(Mode::Cte.obs_kind(), ObsKind::Central);
    /// assert_eq!(Mode::Dte.obs_kind(), ObsKind::Local);
    /// ```
    pub fn obs_kind(self) -> buridan_env::ObsKind {
        match self {
            Mode::Cte => buridan_env::ObsKind::Central,
            Mode::Ctde | Mode::Dte => buridan_env::ObsKind::Local,
        }
    }
}

impl std::str::FromStr for Mode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "cte" => Ok(Mode::Cte),
            "ctde" => Ok(Mode::Ctde),
            "dte" => Ok(Mode::Dte),
            other => Err(format!("unknown mode '{other}': expected cte, ctde or dte")),
        }
    }
}

impl std::fmt::Display for Mode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Mode::Cte => "cte",
            Mode::Ctde => "ctde",
            Mode::Dte => "dte",
        })
    }
}

/// Hidden-layer activation. Only tanh is used by the dissertation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Activation {
    /// Hyperbolic tangent.
    #[default]
    Tanh,
    /// Rectified linear unit.
    Relu,
}

/// Where the value function gets its features.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ValueHead {
    /// A linear value head on the policy's last hidden layer (IMPALA;
    /// RLlib `vf_share_layers=True`). With an LSTM the value head always
    /// reads the LSTM output, as RLlib's LSTM wrapper does.
    #[default]
    Shared,
    /// A separate value MLP with the same hidden sizes (PPO; RLlib's
    /// default `vf_share_layers=False`).
    Separate,
}

/// The optional LSTM after the hidden layers (RLlib `use_lstm`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LstmSpec {
    /// LSTM cells (64 in the dissertation).
    pub cells: usize,
    /// Previous action (one-hot per head, zeros at an episode start) as
    /// extra LSTM input.
    pub prev_action: bool,
    /// Previous reward as extra LSTM input.
    pub prev_reward: bool,
}

impl Default for LstmSpec {
    fn default() -> Self {
        Self {
            cells: 64,
            prev_action: true,
            prev_reward: true,
        }
    }
}

/// A network's architecture; saved as `spec.json` beside `model.safetensors`.
///
/// ```
/// use buridan_policy::{ModelSpec, Mode};
/// let spec = ModelSpec::new(Mode::Ctde, 2, 129);
/// assert_eq!(spec.heads, 1);
/// assert_eq!(spec.nets(), 1);
/// assert_eq!(ModelSpec::new(Mode::Dte, 3, 129).nets(), 3);
/// assert_eq!(ModelSpec::new(Mode::Cte, 4, 1800).heads, 4);
/// spec.validate().unwrap();
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelSpec {
    /// Floats per observation row.
    pub obs_dim: usize,
    /// Categorical heads: 1 for CTDE/DTE, `agents` for CTE.
    pub heads: usize,
    /// Actions per head (5).
    pub actions: usize,
    /// Hidden layer sizes.
    #[serde(default = "default_hidden")]
    pub hidden: Vec<usize>,
    /// Hidden activation.
    #[serde(default)]
    pub activation: Activation,
    /// Shared or separate value function.
    #[serde(default)]
    pub value: ValueHead,
    /// Optional LSTM after the hidden layers.
    #[serde(default)]
    pub lstm: Option<LstmSpec>,
    /// CTE, CTDE or DTE.
    pub mode: Mode,
    /// Agents per env.
    pub agents: usize,
    /// Extra observation features the policy was trained with (its
    /// evaluation env must write them too).
    #[serde(default, skip_serializing_if = "ObsFeatures::is_none")]
    pub features: ObsFeatures,
    /// The local window's radius the policy was trained with (its
    /// evaluation env must use it too); 2 (5×5) if not recorded.
    #[serde(
        default = "default_sensor_range",
        skip_serializing_if = "is_default_sensor_range"
    )]
    pub sensor_range: usize,
    /// The layouts the policy was trained on (a record: a policy with
    /// local observations runs on any layout). Empty if unknown.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub maps: Vec<String>,
    /// The rule set the policy was trained under (a record, like `maps`:
    /// the network runs under either; evaluations report a mismatch).
    /// `thesis` if not recorded.
    #[serde(default, skip_serializing_if = "is_thesis")]
    pub rules: Rules,
}

fn is_thesis(r: &Rules) -> bool {
    *r == Rules::Thesis
}

fn default_sensor_range() -> usize {
    buridan_env::EnvConfig::default().sensor_range
}

fn is_default_sensor_range(r: &usize) -> bool {
    *r == default_sensor_range()
}

fn default_hidden() -> Vec<usize> {
    vec![64, 64]
}

impl ModelSpec {
    /// The default architecture for a mode: heads from the mode, hidden
    /// [64, 64], tanh, shared value head, no LSTM.
    pub fn new(mode: Mode, agents: usize, obs_dim: usize) -> Self {
        Self {
            obs_dim,
            heads: if mode == Mode::Cte { agents } else { 1 },
            actions: ACTIONS_PER_HEAD,
            hidden: default_hidden(),
            activation: Activation::Tanh,
            value: ValueHead::Shared,
            lstm: None,
            mode,
            agents,
            features: ObsFeatures::default(),
            sensor_range: default_sensor_range(),
            maps: Vec::new(),
            rules: Rules::Thesis,
        }
    }

    /// Number of weight sets: one per agent id in DTE, else one.
    pub fn nets(&self) -> usize {
        match self.mode {
            Mode::Dte => self.agents,
            _ => 1,
        }
    }

    /// Logits per row: `heads · actions`.
    pub fn logits_dim(&self) -> usize {
        self.heads * self.actions
    }

    /// Which weight set acts for observation row `row` (rows are env-major:
    /// in DTE row `e·n + i` is agent `i` of env `e`).
    pub fn net_of_row(&self, row: usize) -> usize {
        match self.mode {
            Mode::Dte => row % self.agents,
            _ => 0,
        }
    }

    /// Checks internal consistency.
    pub fn validate(&self) -> Result<(), PolicyError> {
        let bad = |m: String| Err(PolicyError::InvalidSpec(m));
        if self.obs_dim == 0 {
            return bad("obs_dim must be positive".into());
        }
        if self.actions == 0 {
            return bad("actions must be positive".into());
        }
        if self.agents == 0 {
            return bad("agents must be positive".into());
        }
        let want_heads = if self.mode == Mode::Cte {
            self.agents
        } else {
            1
        };
        if self.heads != want_heads {
            return bad(format!(
                "mode {} with {} agents needs {} heads, spec has {}",
                self.mode, self.agents, want_heads, self.heads
            ));
        }
        if self.hidden.is_empty() || self.hidden.contains(&0) {
            return bad(format!(
                "hidden sizes must be non-empty and positive, got {:?}",
                self.hidden
            ));
        }
        if let Some(l) = &self.lstm {
            if l.cells == 0 {
                return bad("lstm cells must be positive".into());
            }
        }
        Ok(())
    }

    /// Whether `other` describes the same network (everything but the
    /// records of training layouts and rules), so that its weights fit.
    ///
    /// ```
    /// use buridan_policy::{ModelSpec, Mode};
    /// let a = ModelSpec::new(Mode::Ctde, 4, 129);
    /// let b = ModelSpec { maps: vec!["rm-2.2".into(), "rm-3.1".into()], ..a.clone() };
    /// assert!(a.same_network(&b));
    /// assert!(!a.same_network(&ModelSpec::new(Mode::Dte, 4, 129)));
    /// ```
    pub fn same_network(&self, other: &ModelSpec) -> bool {
        let strip = |s: &ModelSpec| ModelSpec {
            maps: Vec::new(),
            rules: Rules::Thesis,
            ..s.clone()
        };
        strip(self) == strip(other)
    }

    /// Whether the network is recurrent.
    pub fn is_recurrent(&self) -> bool {
        self.lstm.is_some()
    }
}
