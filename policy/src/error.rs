//! Errors of the policy crate.

use std::path::PathBuf;

/// What can go wrong building, running, saving or loading a policy.
#[derive(Debug, thiserror::Error)]
pub enum PolicyError {
    /// The model spec is inconsistent.
    #[error("invalid model spec: {0}")]
    InvalidSpec(String),
    /// A checkpoint file is missing.
    #[error("checkpoint {dir}: missing file {file}")]
    MissingFile {
        /// The checkpoint directory.
        dir: PathBuf,
        /// The missing file's name.
        file: &'static str,
    },
    /// A checkpoint file could not be read or written.
    #[error("checkpoint file {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A directory holds no checkpoint (no spec, no `checkpoints/` with one).
    #[error("{} holds no checkpoint (no spec.json, no checkpoints/ folder with one)", dir.display())]
    NoCheckpoint {
        /// The directory searched.
        dir: PathBuf,
    },
    /// `model:NAME` names no pretrained model (`checkpoint::models_dirs`).
    #[error(
        "no pretrained model '{name}' (available: {}; models are the folders of models/ in the current directory, of $BURIDAN_MODELS or of the checkout)",
        if available.is_empty() { "none found".to_owned() } else { available.join(", ") }
    )]
    UnknownModel {
        /// The name asked for.
        name: String,
        /// The names found.
        available: Vec<String>,
    },
    /// The spec file is not valid JSON/TOML for a [`crate::ModelSpec`].
    #[error("spec file {path}: {message}")]
    BadSpecFile {
        /// The file.
        path: PathBuf,
        /// The parse error.
        message: String,
    },
    /// The spec of a checkpoint differs from the one expected by the caller.
    #[error("checkpoint spec does not match: expected {expected}, found {found}")]
    SpecMismatch {
        /// The expected spec (JSON).
        expected: String,
        /// The checkpoint's spec (JSON).
        found: String,
    },
    /// The weights file lacks a tensor the spec requires.
    #[error("weights lack tensor '{name}'")]
    MissingTensor {
        /// Tensor name.
        name: String,
    },
    /// A tensor in the weights has the wrong shape for the spec.
    #[error("tensor '{name}' has shape {found:?}, the spec needs {expected:?}")]
    ShapeMismatch {
        /// Tensor name.
        name: String,
        /// Shape required by the spec.
        expected: Vec<usize>,
        /// Shape found.
        found: Vec<usize>,
    },
    /// The weights hold a tensor the spec does not know.
    #[error("weights hold unexpected tensor '{name}'")]
    UnexpectedTensor {
        /// Tensor name.
        name: String,
    },
    /// Input buffers of the wrong length.
    #[error("{what}: expected {expected} values, got {got}")]
    WrongLength {
        /// Which buffer.
        what: &'static str,
        /// Expected length.
        expected: usize,
        /// Actual length.
        got: usize,
    },
    /// A row has no legal action in some head (the env always allows stay,
    /// so this means a corrupted mask).
    #[error("row {row}, head {head}: the action mask allows no action")]
    EmptyMask {
        /// Row index.
        row: usize,
        /// Head index.
        head: usize,
    },
    /// A GPU asked of a binary built without the `cuda` feature.
    #[error("device cuda:{ordinal}: this binary was built without the `cuda` feature (scripts/build-cuda.sh builds one)")]
    CudaNotBuilt {
        /// The GPU ordinal asked for.
        ordinal: usize,
    },
    /// The CUDA driver found no such GPU, or failed to open it.
    #[error("device {device} is not available: {message}")]
    DeviceUnavailable {
        /// The device asked for, as named.
        device: String,
        /// What the driver said.
        message: String,
    },
    /// An error from candle.
    #[error(transparent)]
    Candle(#[from] candle_core::Error),
}
