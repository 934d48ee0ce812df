//! The actor–learner gRPC API (`proto/buridan/v1/learner.proto`), the
//! environment API external simulators serve (`proto/buridan/v1/env.proto`)
//! and the fleet control API (`proto/buridan/v1/control.proto`), generated
//! at build time, and conversions between their messages and the crate
//! types ([`convert`], [`env_convert`], [`control_convert`]).
//!
//! ```
//! use buridan_proto::v1;
//! let join = v1::JoinRequest { api_version: v1::ApiVersion::V2 as u32, ..Default::default() };
//! assert_eq!(join.api_version, 2);
//! ```

/// `$ty { … }` built from `$src`, copying the ten statistics an episode
/// carries under the same names in `buridan_env::EpisodeStats` and on both
/// wires (`v1::EpisodeStats`, `v1::FinishedEpisode`); `$rest` names the
/// other fields. A macro: the four types share field names, not a trait.
macro_rules! with_episode_fields {
    ($ty:path, $src:expr, { $($rest:tt)* }) => {{
        let s = $src;
        $ty {
            episode: s.episode,
            reward: s.reward,
            length: s.length,
            success: s.success,
            agents_at_goal: s.agents_at_goal,
            blocked_moves: s.blocked_moves,
            goals_reached: s.goals_reached,
            deadlock_steps: s.deadlock_steps,
            livelock_steps: s.livelock_steps,
            deadlock_events: s.deadlock_events,
            $($rest)*
        }
    }};
}

pub mod codec;
pub mod control_convert;
pub mod convert;
pub mod env_convert;
pub mod obs_codes;
pub mod obs_encoding;

/// Generated messages, the `Learner` client and server, the
/// `Environment` client and server, and the `FleetControl` client and
/// server.
pub mod v1 {
    tonic::include_proto!("buridan.v1");
}

pub use convert::{check_fragment, ConvertError};
