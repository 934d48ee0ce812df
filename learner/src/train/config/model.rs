//! The network a run trains ([`ModelConfig`]): layer sizes and the LSTM.

use serde::{Deserialize, Serialize};

/// The network's shape, TOML top-level keys `hidden`, `lstm`, `lstm_cells`
/// and `max_seq_len` (the file keeps them flat; [`super::TrainConfig`]
/// groups them here).
///
/// ```
/// use buridan_learner::train::{ModelConfig, TrainConfig};
/// let cfg: TrainConfig = toml::from_str("hidden = [32, 32]\nlstm = true").unwrap();
/// assert_eq!(cfg.model, ModelConfig { hidden: vec![32, 32], lstm: true, ..ModelConfig::default() });
/// assert_eq!((cfg.model.lstm_cells, cfg.model.max_seq_len), (64, 32));
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ModelConfig {
    /// Hidden layer sizes ([64, 64]).
    pub hidden: Vec<usize>,
    /// LSTM after the hidden layers (the comparison runs used one; off by
    /// default here because the feed-forward net trains several times faster).
    pub lstm: bool,
    /// LSTM cells (64).
    pub lstm_cells: usize,
    /// Truncated-BPTT length (RLlib `max_seq_len` 32).
    pub max_seq_len: usize,
}

impl Default for ModelConfig {
    fn default() -> Self {
        Self {
            hidden: vec![64, 64],
            lstm: false,
            lstm_cells: 64,
            max_seq_len: 32,
        }
    }
}
