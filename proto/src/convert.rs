//! Messages ↔ crate types. Byte and integer buffers move between the two;
//! float buffers that travel as bytes (observations, logits) are copied
//! once, into bytes on the way out and into floats on the way in —
//! observations LZ4-compressed if the learner accepts that
//! ([`fragment_to_message_encoded`], [`crate::obs_encoding`]).
//! Everything arriving from the wire is checked: shapes, finite numbers,
//! value ranges.
//!
//! ```
//! use buridan_policy::Fragment;
//! use buridan_proto::convert::{fragment_from_message, fragment_to_message, WireTag};
//! let mut f = Fragment::with_capacity(0, 3, 1, 1, 1, 2, 1, 5);
//! f.len = 1;
//! f.obs = vec![0.5, 1.0];
//! f.masks = vec![1; 5];
//! f.actions = vec![2];
//! f.behaviour_logits = vec![0.0; 5];
//! f.behaviour_logp = vec![-1.6];
//! f.rewards = vec![-0.1];
//! f.terminated = vec![0];
//! f.truncated = vec![0];
//! f.last_obs = vec![0.5, 0.0];
//! f.env_steps = 1;
//! let tag = WireTag { run_id: "run".into(), session: 7, seq: 1 };
//! let msg = fragment_to_message(f.clone(), &tag);
//! let (back_tag, back) = fragment_from_message(msg).unwrap();
//! assert_eq!((back_tag, back), (tag, f));
//! ```

use buridan_env::replay::ReplayConfig;
use buridan_env::{EnvConfig, EpisodeStats, MapSource, ObsFeatures, Shaping, Starts};
use buridan_policy::{Fragment, NamedTensor, PolicyError, RecurrentState, Weights};

use crate::obs_encoding::{self, ObsDecodeError, DEFAULT_MAX_DECODED_BYTES};
use crate::v1;
use crate::v1::ObsEncoding;

/// What is wrong with a message received from the wire.
#[derive(Debug, thiserror::Error)]
pub enum ConvertError {
    /// A buffer's length does not match the shape fields.
    #[error(transparent)]
    Shape(#[from] PolicyError),
    /// A float is NaN or infinite.
    #[error("{field}[{index}] is {value} (must be finite)")]
    NonFinite {
        /// The message field.
        field: &'static str,
        /// Position in the buffer.
        index: usize,
        /// The value found.
        value: f32,
    },
    /// An integer outside its allowed range.
    #[error("{field}[{index}] = {value} is out of range (must be < {limit})")]
    OutOfRange {
        /// The message field.
        field: &'static str,
        /// Position in the buffer.
        index: usize,
        /// The value found.
        value: u64,
        /// Exclusive upper bound.
        limit: u64,
    },
    /// A buffer holds a wrong number of values.
    #[error("{field} holds {got} values, expected {expected}")]
    Length {
        /// The message field.
        field: &'static str,
        /// The number the shape asks for.
        expected: usize,
        /// The number found.
        got: usize,
    },
    /// An observation buffer does not decode (unknown encoding, corrupt
    /// or oversized LZ4 block).
    #[error(transparent)]
    Obs(#[from] ObsDecodeError),
    /// Something else that makes the message unusable.
    #[error("{0}")]
    Invalid(String),
}

/// Where a fragment comes from: the run, the actor's session and the
/// fragment's sequence number within that session.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct WireTag {
    /// The learner incarnation the actor joined.
    pub run_id: String,
    /// The actor's session.
    pub session: u64,
    /// Sequence number within the session.
    pub seq: u64,
}

/// Wraps a fragment for the wire: masks, actions, flags and the small float
/// buffers move; observations and logits are copied once into raw bytes
/// (the format every learner reads).
pub fn fragment_to_message(f: Fragment, tag: &WireTag) -> v1::Fragment {
    fragment_to_message_encoded(f, tag, ObsEncoding::Raw)
}

/// [`fragment_to_message`] with the observation buffers (obs, final_obs,
/// last_obs) in `encoding`; send an encoding other than raw only to a
/// learner whose join reply lists it.
///
/// ```
/// use buridan_policy::Fragment;
/// use buridan_proto::convert::{fragment_from_message, fragment_to_message_encoded, WireTag};
/// use buridan_proto::v1::ObsEncoding;
/// let mut f = Fragment::with_capacity(0, 3, 1, 1, 1, 4, 1, 5);
/// f.len = 1;
/// f.obs = vec![0.0, 1.0, 0.0, 0.0];
/// f.masks = vec![1; 5];
/// f.actions = vec![2];
/// f.behaviour_logits = vec![0.0; 5];
/// f.behaviour_logp = vec![-1.6];
/// f.rewards = vec![-0.1];
/// f.terminated = vec![0];
/// f.truncated = vec![0];
/// f.last_obs = vec![0.0, 0.0, 1.0, 0.0];
/// f.env_steps = 1;
/// let msg = fragment_to_message_encoded(f.clone(), &WireTag::default(), ObsEncoding::Lz4);
/// assert_eq!(msg.obs_encoding, ObsEncoding::Lz4 as i32);
/// assert_eq!(fragment_from_message(msg).unwrap().1, f);
/// ```
pub fn fragment_to_message_encoded(
    f: Fragment,
    tag: &WireTag,
    encoding: ObsEncoding,
) -> v1::Fragment {
    v1::Fragment {
        run_id: tag.run_id.clone(),
        session: tag.session,
        seq: tag.seq,
        policy_version: f.policy_version,
        len: f.len as u32,
        rows: f.rows as u32,
        rows_per_env: f.rows_per_env as u32,
        obs_dim: f.obs_dim as u32,
        heads: f.heads as u32,
        actions_per_head: f.actions_per_head as u32,
        obs: obs_encoding::encode(&f.obs, encoding),
        masks: f.masks,
        actions: f.actions,
        behaviour_logits: f32_to_le_bytes(&f.behaviour_logits),
        behaviour_logp: f.behaviour_logp,
        rewards: f.rewards,
        terminated: f.terminated,
        truncated: f.truncated,
        final_obs: obs_encoding::encode(&f.final_obs, encoding),
        final_obs_index: f.final_obs_index,
        last_obs: obs_encoding::encode(&f.last_obs, encoding),
        initial_state: f.initial_state.map(state_to_message),
        episodes: f.episodes.iter().map(episode_to_message).collect(),
        env_steps: f.env_steps,
        obs_encoding: encoding as i32,
    }
}

/// Unwraps and checks a fragment from the wire: buffer lengths against the
/// shape fields, finite floats, actions and flags in range, `env_steps`
/// consistent with the shape. The actor id is left 0 (the learner knows it
/// from the session). Compressed observations may decode to at most
/// [`DEFAULT_MAX_DECODED_BYTES`] in all; [`fragment_from_message_within`]
/// sets another bound.
pub fn fragment_from_message(m: v1::Fragment) -> Result<(WireTag, Fragment), ConvertError> {
    fragment_from_message_within(m, DEFAULT_MAX_DECODED_BYTES)
}

/// [`fragment_from_message`] with compressed observation buffers allowed to
/// decode to at most `max_decoded_bytes` together. Each must decode to
/// exactly the size its shape fields ask for (obs: len × rows × obs_dim
/// values; last_obs: rows × obs_dim; final_obs: one obs_dim row per
/// `final_obs_index`); the bound is checked before anything is allocated.
///
/// ```
/// use buridan_proto::convert::{fragment_from_message_within, ConvertError};
/// use buridan_proto::v1;
/// let bomb = v1::Fragment {
///     len: 1000, rows: 1000, rows_per_env: 1, obs_dim: 1000, heads: 1, actions_per_head: 5,
///     obs: vec![0; 16], obs_encoding: v1::ObsEncoding::Lz4 as i32,
///     ..Default::default()
/// };
/// let e = fragment_from_message_within(bomb, 1 << 20).unwrap_err();
/// assert!(e.to_string().starts_with("obs would decode to 1000000000 values"));
/// ```
pub fn fragment_from_message_within(
    m: v1::Fragment,
    max_decoded_bytes: usize,
) -> Result<(WireTag, Fragment), ConvertError> {
    let encoding = obs_encoding::encoding_of(m.obs_encoding)?;
    let obs_dim = m.obs_dim as usize;
    let rows = m.rows as usize;
    let sizes = [
        (m.len as usize).checked_mul(rows),
        Some(m.final_obs_index.len()),
        Some(rows),
    ]
    .map(|n| n.and_then(|n| n.checked_mul(obs_dim)));
    let mut budget = max_decoded_bytes;
    let mut decode = |field: &'static str, bytes: &[u8], values: Option<usize>| {
        let out = obs_encoding::decode(field, bytes, encoding, values, budget)?;
        if encoding != ObsEncoding::Raw {
            budget -= out.len() * 4;
        }
        Ok::<_, ConvertError>(out)
    };
    let obs = decode("obs", &m.obs, sizes[0])?;
    let final_obs = decode("final_obs", &m.final_obs, sizes[1])?;
    let last_obs = decode("last_obs", &m.last_obs, sizes[2])?;
    let tag = WireTag {
        run_id: m.run_id,
        session: m.session,
        seq: m.seq,
    };
    let f = Fragment {
        actor: 0,
        policy_version: m.policy_version,
        len: m.len as usize,
        rows: m.rows as usize,
        rows_per_env: m.rows_per_env as usize,
        obs_dim: m.obs_dim as usize,
        heads: m.heads as usize,
        actions_per_head: m.actions_per_head as usize,
        obs,
        masks: m.masks,
        actions: m.actions,
        behaviour_logits: le_bytes_to_f32("behaviour_logits", &m.behaviour_logits)?,
        behaviour_logp: m.behaviour_logp,
        rewards: m.rewards,
        terminated: m.terminated,
        truncated: m.truncated,
        final_obs,
        final_obs_index: m.final_obs_index,
        last_obs,
        initial_state: m.initial_state.map(state_from_message).transpose()?,
        episodes: m.episodes.iter().map(episode_from_message).collect(),
        env_steps: m.env_steps,
    };
    check_fragment(&f)?;
    Ok((tag, f))
}

/// The checks [`fragment_from_message`] applies, for fragments from any source.
pub fn check_fragment(f: &Fragment) -> Result<(), ConvertError> {
    if f.len == 0 || f.rows == 0 || f.obs_dim == 0 || f.heads == 0 || f.actions_per_head == 0 {
        return Err(ConvertError::Invalid(format!(
            "empty shape: len {}, rows {}, obs_dim {}, heads {}, actions_per_head {}",
            f.len, f.rows, f.obs_dim, f.heads, f.actions_per_head
        )));
    }
    if f.rows_per_env == 0 || !f.rows.is_multiple_of(f.rows_per_env) {
        return Err(ConvertError::Invalid(format!(
            "rows {} is not a multiple of rows_per_env {}",
            f.rows, f.rows_per_env
        )));
    }
    f.validate()?;
    let expected_steps = (f.len * f.envs()) as u64;
    if f.env_steps != expected_steps {
        return Err(ConvertError::Invalid(format!(
            "env_steps {} does not match len × envs = {expected_steps}",
            f.env_steps
        )));
    }
    for (field, buf) in [
        ("obs", &f.obs),
        ("behaviour_logp", &f.behaviour_logp),
        ("rewards", &f.rewards),
        ("final_obs", &f.final_obs),
        ("last_obs", &f.last_obs),
    ] {
        check_finite(field, buf)?;
    }
    // Masked logits may be −∞ in principle; NaN never.
    if let Some(index) = f.behaviour_logits.iter().position(|x| x.is_nan()) {
        return Err(ConvertError::NonFinite {
            field: "behaviour_logits",
            index,
            value: f32::NAN,
        });
    }
    check_below("actions", &f.actions, f.actions_per_head as u64)?;
    check_below("masks", &f.masks, 2)?;
    check_below("terminated", &f.terminated, 2)?;
    check_below("truncated", &f.truncated, 2)?;
    let cells = (f.len * f.rows) as u64;
    let mut last = None;
    for (i, &k) in f.final_obs_index.iter().enumerate() {
        if u64::from(k) >= cells || f.truncated[k as usize] == 0 || last.is_some_and(|l| k <= l) {
            return Err(ConvertError::Invalid(format!(
                "final_obs_index[{i}] = {k} does not name a truncated step in increasing order"
            )));
        }
        last = Some(k);
    }
    if let Some(s) = &f.initial_state {
        if s.rows != f.rows || s.heads != f.heads {
            return Err(ConvertError::Invalid(format!(
                "initial_state has {} rows × {} heads, the fragment {} × {}",
                s.rows, s.heads, f.rows, f.heads
            )));
        }
        check_finite("initial_state.h", &s.h)?;
        check_finite("initial_state.c", &s.c)?;
        check_finite("initial_state.prev_rewards", &s.prev_rewards)?;
    }
    Ok(())
}

/// Floats as little-endian bytes, 4 per value.
pub fn f32_to_le_bytes(values: &[f32]) -> Vec<u8> {
    obs_encoding::to_le_bytes(values)
}

/// Little-endian bytes as floats; the length must be a multiple of 4.
pub fn le_bytes_to_f32(field: &'static str, bytes: &[u8]) -> Result<Vec<f32>, ConvertError> {
    Ok(obs_encoding::from_le_bytes(field, bytes)?)
}

pub(crate) fn check_finite(field: &'static str, buf: &[f32]) -> Result<(), ConvertError> {
    match buf.iter().position(|x| !x.is_finite()) {
        None => Ok(()),
        Some(index) => Err(ConvertError::NonFinite {
            field,
            index,
            value: buf[index],
        }),
    }
}

pub(crate) fn check_below(field: &'static str, buf: &[u8], limit: u64) -> Result<(), ConvertError> {
    match buf.iter().position(|&x| u64::from(x) >= limit) {
        None => Ok(()),
        Some(index) => Err(ConvertError::OutOfRange {
            field,
            index,
            value: u64::from(buf[index]),
            limit,
        }),
    }
}

fn state_to_message(s: RecurrentState) -> v1::RecurrentState {
    v1::RecurrentState {
        rows: s.rows as u32,
        cells: s.cells as u32,
        heads: s.heads as u32,
        h: s.h,
        c: s.c,
        prev_actions: s.prev_actions,
        prev_rewards: s.prev_rewards,
    }
}

fn state_from_message(m: v1::RecurrentState) -> Result<RecurrentState, ConvertError> {
    let (rows, cells, heads) = (m.rows as usize, m.cells as usize, m.heads as usize);
    for (what, expected, got) in [
        ("initial_state h", rows * cells, m.h.len()),
        ("initial_state c", rows * cells, m.c.len()),
        (
            "initial_state prev_actions",
            rows * heads,
            m.prev_actions.len(),
        ),
        ("initial_state prev_rewards", rows, m.prev_rewards.len()),
    ] {
        if expected != got {
            return Err(PolicyError::WrongLength {
                what,
                expected,
                got,
            }
            .into());
        }
    }
    Ok(RecurrentState {
        rows,
        cells,
        heads,
        h: m.h,
        c: m.c,
        prev_actions: m.prev_actions,
        prev_rewards: m.prev_rewards,
    })
}

fn episode_to_message(e: &EpisodeStats) -> v1::EpisodeStats {
    v1::EpisodeStats {
        episode: e.episode,
        reward: e.reward,
        length: e.length,
        success: e.success,
        agents_at_goal: e.agents_at_goal,
        blocked_moves: e.blocked_moves,
        goals_reached: e.goals_reached,
        deadlock_steps: e.deadlock_steps,
        livelock_steps: e.livelock_steps,
        deadlock_events: e.deadlock_events,
        layout: e.layout,
        replay: e.replay,
    }
}

fn episode_from_message(m: &v1::EpisodeStats) -> EpisodeStats {
    EpisodeStats {
        episode: m.episode,
        reward: m.reward,
        length: m.length,
        success: m.success,
        agents_at_goal: m.agents_at_goal,
        blocked_moves: m.blocked_moves,
        goals_reached: m.goals_reached,
        deadlock_steps: m.deadlock_steps,
        livelock_steps: m.livelock_steps,
        deadlock_events: m.deadlock_events,
        layout: m.layout,
        replay: m.replay,
    }
}

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

    fn fragment() -> Fragment {
        // 2 steps, 1 env of 2 agents, obs_dim 3, 1 head of 5 actions; row 1
        // truncated at t = 1.
        let mut f = Fragment::with_capacity(0, 4, 2, 2, 2, 3, 1, 5);
        f.len = 2;
        f.obs = (0..12).map(|x| x as f32 / 12.0).collect();
        f.masks = vec![1; 20];
        f.actions = vec![0, 1, 2, 4];
        f.behaviour_logits = vec![0.0; 20];
        f.behaviour_logp = vec![-1.0; 4];
        f.rewards = vec![-0.1, -0.1, 1.0, -0.1];
        f.terminated = vec![0; 4];
        f.truncated = vec![0, 0, 1, 1];
        f.final_obs_index = vec![2, 3];
        f.final_obs = vec![0.0; 6];
        f.last_obs = vec![0.0; 6];
        f.env_steps = 2;
        f.episodes = vec![EpisodeStats {
            episode: 3,
            reward: 0.8,
            length: 2,
            ..EpisodeStats::default()
        }];
        f
    }

    fn tag() -> WireTag {
        WireTag {
            run_id: "r".into(),
            session: 1,
            seq: 9,
        }
    }

    #[test]
    fn round_trip_keeps_everything() {
        let mut f = fragment();
        f.initial_state = Some(RecurrentState::new(2, 4, 1));
        let (t, back) = fragment_from_message(fragment_to_message(f.clone(), &tag())).unwrap();
        assert_eq!(t, tag());
        assert_eq!(back, f);
    }

    #[test]
    fn lz4_round_trip_is_bit_for_bit() {
        let mut f = fragment();
        f.obs[4] = -0.0;
        f.obs[7] = f32::MIN_POSITIVE / 2.0;
        f.final_obs[1] = 1.0;
        f.last_obs[5] = 0.5;
        let m = fragment_to_message_encoded(f.clone(), &tag(), ObsEncoding::Lz4);
        assert_eq!(m.obs_encoding, ObsEncoding::Lz4 as i32);
        let (t, back) = fragment_from_message(m).unwrap();
        assert_eq!(t, tag());
        for (a, b) in [
            (&back.obs, &f.obs),
            (&back.final_obs, &f.final_obs),
            (&back.last_obs, &f.last_obs),
        ] {
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(a), bits(b));
        }
        assert_eq!(back, f);
    }

    #[test]
    fn a_bad_lz4_buffer_is_named() {
        let good = fragment_to_message_encoded(fragment(), &tag(), ObsEncoding::Lz4);
        // Corrupt: the last_obs block of another size.
        let mut m = good.clone();
        m.last_obs = obs_encoding::encode(&[0.0; 7], ObsEncoding::Lz4);
        let err = fragment_from_message(m).unwrap_err();
        assert!(err.to_string().starts_with("last_obs "), "{err}");
        // Raw bytes labelled LZ4.
        let mut m = good.clone();
        m.obs = f32_to_le_bytes(&fragment().obs);
        let err = fragment_from_message(m).unwrap_err();
        assert!(err.to_string().starts_with("obs "), "{err}");
        // Over the decode budget: obs (48 bytes) fits 50, final_obs then does not.
        let err = fragment_from_message_within(good.clone(), 50).unwrap_err();
        assert_eq!(
            err.to_string(),
            "final_obs would decode to 6 values (24 bytes), over the limit of 2 bytes"
        );
        // An encoding from the future.
        let mut m = good;
        m.obs_encoding = 3;
        let err = fragment_from_message(m).unwrap_err();
        assert!(matches!(
            err,
            ConvertError::Obs(ObsDecodeError::UnknownEncoding(3))
        ));
    }

    #[test]
    fn nan_observation_is_named() {
        let mut m = fragment_to_message(fragment(), &tag());
        m.obs[20..24].copy_from_slice(&f32::NAN.to_le_bytes());
        let err = fragment_from_message(m).unwrap_err();
        assert!(matches!(
            err,
            ConvertError::NonFinite {
                field: "obs",
                index: 5,
                ..
            }
        ));
        assert_eq!(err.to_string(), "obs[5] is NaN (must be finite)");
    }

    #[test]
    fn infinite_reward_is_refused() {
        let mut m = fragment_to_message(fragment(), &tag());
        m.rewards[1] = f32::INFINITY;
        assert_eq!(
            fragment_from_message(m).unwrap_err().to_string(),
            "rewards[1] is inf (must be finite)"
        );
    }

    #[test]
    fn short_buffer_is_a_shape_error() {
        let mut m = fragment_to_message(fragment(), &tag());
        m.obs.truncate(m.obs.len() - 4);
        assert_eq!(
            fragment_from_message(m).unwrap_err().to_string(),
            "fragment obs: expected 12 values, got 11"
        );
    }

    #[test]
    fn float_bytes_must_be_whole_values() {
        let mut m = fragment_to_message(fragment(), &tag());
        m.last_obs.pop();
        assert_eq!(
            fragment_from_message(m).unwrap_err().to_string(),
            "last_obs holds 23 bytes, not a whole number of f32 values"
        );
    }

    #[test]
    fn action_out_of_range_is_refused() {
        let mut m = fragment_to_message(fragment(), &tag());
        m.actions[3] = 5;
        assert_eq!(
            fragment_from_message(m).unwrap_err().to_string(),
            "actions[3] = 5 is out of range (must be < 5)"
        );
    }

    #[test]
    fn env_steps_must_match_the_shape() {
        let mut m = fragment_to_message(fragment(), &tag());
        m.env_steps = 1_000_000;
        assert!(fragment_from_message(m)
            .unwrap_err()
            .to_string()
            .contains("env_steps 1000000 does not match len × envs = 2"));
    }

    #[test]
    fn final_obs_must_point_at_truncations() {
        let mut m = fragment_to_message(fragment(), &tag());
        m.final_obs_index = vec![0, 3];
        assert!(fragment_from_message(m)
            .unwrap_err()
            .to_string()
            .contains("final_obs_index[0] = 0"));
    }

    #[test]
    fn zero_shape_is_refused() {
        let m = v1::Fragment::default();
        assert!(fragment_from_message(m)
            .unwrap_err()
            .to_string()
            .starts_with("empty shape"));
    }

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
