//! Buridan's policy network: the one definition used by actors (inference)
//! and the learner (training).
//!
//! - [`spec`]: [`ModelSpec`], the architecture, saved as `spec.json`.
//! - [`net`]: [`Net`], one weight set: tanh MLP, optional LSTM (previous
//!   action and reward as extra inputs), logits and value heads.
//! - [`policy`]: [`Policy`], all weight sets of a spec (one per agent id in
//!   DTE), weight snapshots ([`Weights`]) and checkpoints.
//! - [`dist`]: masked categorical heads — log-probs, joint log-prob (sum
//!   over heads), entropy, KL, sampling, greedy choice.
//! - [`lstm`]: the LSTM recurrence over a whole sequence as one fused op
//!   with a hand-derived backward pass.
//! - [`infer`]: [`Inference`], an actor's batched action selection.
//! - [`fragment`]: [`Fragment`], `T` steps of experience as plain data.
//! - [`checkpoint`]: where a run keeps its checkpoints, and which one a
//!   path names.
//! - [`shards`]: one gradient on several threads (the shares every trainer
//!   cuts its batch into).
//! - [`threads`]: pinning candle's CPU thread count.
//! - [`device`]: [`DeviceSpec`], where the weights live (`cpu`, `cuda:N`).
//!
//! ```
//! use buridan_policy::{ActMode, Inference, ModelSpec, Mode, Policy};
//! let spec = ModelSpec::new(Mode::Cte, 2, 10);
//! let mut inf = Inference::new(Policy::new(spec, 0).unwrap(), 1, 0);
//! let (mut actions, mut logp) = ([0u8; 2], [0f32; 1]);
//! inf.act(&[0.0; 10], &[1; 10], ActMode::Greedy, &mut actions, &mut logp).unwrap();
//! assert!(actions.iter().all(|&a| a < 5));
//! ```

pub mod activation;
pub mod checkpoint;
pub mod device;
pub mod dist;
pub mod error;
pub mod fragment;
pub mod infer;
pub mod lstm;
pub mod net;
pub mod policy;
pub mod shards;
pub mod spec;
pub mod threads;

pub use candle_core::Device;
pub use device::DeviceSpec;
pub use error::PolicyError;
pub use fragment::{Fragment, DEFAULT_FRAGMENT_LEN};
pub use infer::{ActMode, Inference, RecurrentState, NO_ACTION};
pub use net::{Net, NetOutput, RecurrentInput, UnrollOutput};
pub use policy::{NamedTensor, Policy, Weights, MODEL_FILE, SPEC_FILE};
pub use spec::{Activation, LstmSpec, Mode, ModelSpec, ValueHead, ACTIONS_PER_HEAD};
