//! Fragments ↔ messages: the buffers moved or copied once, observations
//! packed as the learner accepts, and everything from the wire checked
//! (shapes, finite numbers, value ranges), recurrent states and finished
//! episodes included.

use buridan_env::EpisodeStats;
use buridan_policy::{Fragment, PolicyError, RecurrentState};

use super::{check_below, check_finite, f32_to_le_bytes, le_bytes_to_f32, ConvertError, WireTag};
use crate::obs_encoding::{self, DEFAULT_MAX_DECODED_BYTES};
use crate::v1;
use crate::v1::ObsEncoding;

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
    with_episode_fields!(v1::EpisodeStats, e, { layout: e.layout, replay: e.replay })
}

fn episode_from_message(m: &v1::EpisodeStats) -> EpisodeStats {
    with_episode_fields!(EpisodeStats, m, { layout: m.layout, replay: m.replay })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::obs_encoding::ObsDecodeError;

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

    /// The error a good fragment's message gets refused with once `spoil`
    /// has changed it.
    fn refusal(spoil: impl FnOnce(&mut v1::Fragment)) -> ConvertError {
        let mut m = fragment_to_message(fragment(), &tag());
        spoil(&mut m);
        fragment_from_message(m).unwrap_err()
    }

    #[test]
    fn nan_observation_is_named() {
        let err = refusal(|m| m.obs[20..24].copy_from_slice(&f32::NAN.to_le_bytes()));
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
        let err = refusal(|m| m.rewards[1] = f32::INFINITY);
        assert_eq!(err.to_string(), "rewards[1] is inf (must be finite)");
    }

    #[test]
    fn short_buffer_is_a_shape_error() {
        let err = refusal(|m| m.obs.truncate(m.obs.len() - 4));
        assert_eq!(err.to_string(), "fragment obs: expected 12 values, got 11");
    }

    #[test]
    fn float_bytes_must_be_whole_values() {
        let err = refusal(|m| {
            m.last_obs.pop();
        });
        assert_eq!(
            err.to_string(),
            "last_obs holds 23 bytes, not a whole number of f32 values"
        );
    }

    #[test]
    fn action_out_of_range_is_refused() {
        let err = refusal(|m| m.actions[3] = 5);
        assert_eq!(
            err.to_string(),
            "actions[3] = 5 is out of range (must be < 5)"
        );
    }

    #[test]
    fn env_steps_must_match_the_shape() {
        let err = refusal(|m| m.env_steps = 1_000_000);
        assert!(err
            .to_string()
            .contains("env_steps 1000000 does not match len × envs = 2"));
    }

    #[test]
    fn final_obs_must_point_at_truncations() {
        let err = refusal(|m| m.final_obs_index = vec![0, 3]);
        assert!(err.to_string().contains("final_obs_index[0] = 0"));
    }

    #[test]
    fn zero_shape_is_refused() {
        let m = v1::Fragment::default();
        assert!(fragment_from_message(m)
            .unwrap_err()
            .to_string()
            .starts_with("empty shape"));
    }
}
