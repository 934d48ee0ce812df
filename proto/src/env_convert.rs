//! The environment API (`env.proto`) ↔ crate types: the batch's shape as a
//! checked [`EnvSpec`], replies built from any [`BatchedEnv`] (what a
//! server sends), and the checks a client runs on every reply before it
//! uses the buffers (lengths against the spec, finite floats, flags and
//! masks 0 or 1, episodes only of envs that ended).
//!
//! Buffers move: a reply's `obs`, `masks`, `rewards` and flags are the
//! vectors a client keeps as its env buffers, so a step costs the decode
//! and nothing more.
//!
//! ```
//! use buridan_env::ObsKind;
//! use buridan_proto::env_convert::{check_actions, spec_from_message, spec_to_message, EnvSpec};
//! let spec = EnvSpec {
//!     num_envs: 8,
//!     agents: 2,
//!     kind: ObsKind::Local,
//!     obs_dim: 11,
//!     num_actions: 3,
//!     t_max: 1000,
//!     name: "plant:dissertation".into(),
//! };
//! assert_eq!(spec_from_message(&spec_to_message(&spec)).unwrap(), spec);
//! assert_eq!((spec.rows(), spec.obs_len(), spec.mask_len()), (16, 176, 48));
//! assert!(check_actions(&spec, &[0u8; 16]).is_ok());
//! let err = check_actions(&spec, &[0u8; 15]).unwrap_err();
//! assert_eq!(err.to_string(), "actions holds 15 values, expected 16");
//! ```

use buridan_env::{BatchedEnv, EpisodeStats, ObsKind};

use crate::convert::{check_below, check_finite, ConvertError};
use crate::v1;

/// Most values a buffer of a batch may hold (observations, masks): 2²⁶,
/// 256 MB of floats — far above any sensible batch, far below what a
/// forged spec could make a client allocate.
pub const MAX_BUFFER_VALUES: usize = 1 << 26;

/// Most actions per agent: an action is one byte.
pub const MAX_ACTIONS: usize = 256;

/// The shape of a served batch of envs, checked: every count at least 1
/// and every buffer at most [`MAX_BUFFER_VALUES`] values.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EnvSpec {
    /// Envs per step.
    pub num_envs: usize,
    /// Agents per env.
    pub agents: usize,
    /// One observation row per agent, or per env.
    pub kind: ObsKind,
    /// Floats per observation row.
    pub obs_dim: usize,
    /// Actions per agent (mask bytes per agent).
    pub num_actions: usize,
    /// Steps before truncation (0: none on time).
    pub t_max: u32,
    /// Free-form name of simulator and model.
    pub name: String,
}

impl EnvSpec {
    /// The spec of a local batch `env` with `num_actions` actions per agent.
    pub fn of<E: BatchedEnv + ?Sized>(env: &E, num_actions: usize, t_max: u32, name: &str) -> Self {
        Self {
            num_envs: env.num_envs(),
            agents: env.agents(),
            kind: env.kind(),
            obs_dim: env.obs_dim(),
            num_actions,
            t_max,
            name: name.to_string(),
        }
    }

    /// Rows per env: agents (local) or 1 (central).
    pub fn rows_per_env(&self) -> usize {
        self.kind.rows_per_env(self.agents)
    }

    /// Rows of the batch.
    pub fn rows(&self) -> usize {
        self.num_envs * self.rows_per_env()
    }

    /// Agents of the batch: actions per step, rewards per step.
    pub fn agent_slots(&self) -> usize {
        self.num_envs * self.agents
    }

    /// Floats of one batch of observations.
    pub fn obs_len(&self) -> usize {
        self.rows() * self.obs_dim
    }

    /// Bytes of one batch of masks.
    pub fn mask_len(&self) -> usize {
        self.agent_slots() * self.num_actions
    }
}

/// The spec for the wire.
pub fn spec_to_message(s: &EnvSpec) -> v1::EnvSpec {
    v1::EnvSpec {
        num_envs: s.num_envs as u32,
        agents: s.agents as u32,
        obs_kind: match s.kind {
            ObsKind::Local => v1::ObsKind::Local,
            ObsKind::Central => v1::ObsKind::Central,
        } as i32,
        obs_dim: s.obs_dim as u32,
        num_actions: s.num_actions as u32,
        t_max: s.t_max,
        name: s.name.clone(),
    }
}

/// A spec from the wire: counts at least 1, a known observation kind, at
/// most [`MAX_ACTIONS`] actions, buffers of at most [`MAX_BUFFER_VALUES`]
/// values (products in overflow-checked arithmetic).
pub fn spec_from_message(m: &v1::EnvSpec) -> Result<EnvSpec, ConvertError> {
    let kind = match v1::ObsKind::try_from(m.obs_kind) {
        Ok(v1::ObsKind::Local) => ObsKind::Local,
        Ok(v1::ObsKind::Central) => ObsKind::Central,
        _ => {
            return Err(ConvertError::Invalid(format!(
                "spec.obs_kind = {} is neither OBS_KIND_LOCAL (1) nor OBS_KIND_CENTRAL (2)",
                m.obs_kind
            )))
        }
    };
    for (field, value) in [
        ("num_envs", m.num_envs),
        ("agents", m.agents),
        ("obs_dim", m.obs_dim),
        ("num_actions", m.num_actions),
    ] {
        if value == 0 {
            return Err(ConvertError::Invalid(format!(
                "spec.{field} is 0 (must be at least 1)"
            )));
        }
    }
    if m.num_actions as usize > MAX_ACTIONS {
        return Err(ConvertError::Invalid(format!(
            "spec.num_actions = {} is more than an action byte holds ({MAX_ACTIONS})",
            m.num_actions
        )));
    }
    let (envs, agents) = (m.num_envs as usize, m.agents as usize);
    let rows = envs.checked_mul(kind.rows_per_env(agents));
    let obs = rows.and_then(|r| r.checked_mul(m.obs_dim as usize));
    let masks = envs
        .checked_mul(agents)
        .and_then(|a| a.checked_mul(m.num_actions as usize));
    for (what, len) in [("observation", obs), ("mask", masks)] {
        if len.is_none_or(|n| n > MAX_BUFFER_VALUES) {
            return Err(ConvertError::Invalid(format!(
                "spec: a batch of {} envs x {} agents x {} {} values is larger than {MAX_BUFFER_VALUES}",
                m.num_envs,
                m.agents,
                if what == "mask" { m.num_actions } else { m.obs_dim },
                what
            )));
        }
    }
    Ok(EnvSpec {
        num_envs: envs,
        agents,
        kind,
        obs_dim: m.obs_dim as usize,
        num_actions: m.num_actions as usize,
        t_max: m.t_max,
        name: m.name.clone(),
    })
}

/// Checks a step's actions (what a server runs first): one per agent of
/// every env, each below `num_actions`.
pub fn check_actions(spec: &EnvSpec, actions: &[u8]) -> Result<(), ConvertError> {
    check_len("actions", spec.agent_slots(), actions.len())?;
    check_below("actions", actions, spec.num_actions as u64)
}

/// The reply to a reset: the session and `env`'s first observations and
/// masks (copied into the message).
pub fn reset_reply<E: BatchedEnv + ?Sized>(session: u64, env: &E) -> v1::ResetReply {
    v1::ResetReply {
        session,
        obs: env.obs().to_vec(),
        masks: env.masks().to_vec(),
    }
}

/// The reply to a step of `env`: its buffers copied into the message, the
/// final observations of the envs that ended gathered in env order, and
/// `episodes` (built with [`finished_episode`]).
pub fn step_reply<E: BatchedEnv + ?Sized>(
    env: &E,
    episodes: Vec<v1::FinishedEpisode>,
) -> v1::StepReply {
    let (per_env, d) = (env.rows_per_env(), env.obs_dim());
    let (term, trunc) = (env.terminated(), env.truncated());
    let mut final_obs = Vec::new();
    for e in ended(term, trunc) {
        final_obs.extend_from_slice(&env.final_obs()[e * per_env * d..(e + 1) * per_env * d]);
    }
    v1::StepReply {
        obs: env.obs().to_vec(),
        masks: env.masks().to_vec(),
        rewards: env.rewards().to_vec(),
        terminated: term.to_vec(),
        truncated: trunc.to_vec(),
        final_obs,
        episodes,
    }
}

/// The envs whose episode ended (terminated or truncated), in order.
pub fn ended<'a>(terminated: &'a [u8], truncated: &'a [u8]) -> impl Iterator<Item = usize> + 'a {
    terminated
        .iter()
        .zip(truncated)
        .enumerate()
        .filter(|(_, (&a, &b))| a != 0 || b != 0)
        .map(|(e, _)| e)
}

/// One finished episode of env `env` for the wire, with its KPIs by name.
///
/// ```
/// use buridan_env::EpisodeStats;
/// use buridan_proto::env_convert::{episode_from_message, finished_episode};
/// let stats = EpisodeStats { episode: 3, reward: -12.5, length: 1000, goals_reached: 7, ..Default::default() };
/// let m = finished_episode(1, &stats, [("deliveries".to_string(), 7.0)]);
/// let (back, kpis) = episode_from_message(&m).unwrap();
/// assert_eq!(back, stats);
/// assert_eq!(kpis, [("deliveries".to_string(), 7.0)]);
/// ```
pub fn finished_episode(
    env: usize,
    e: &EpisodeStats,
    kpis: impl IntoIterator<Item = (String, f64)>,
) -> v1::FinishedEpisode {
    with_episode_fields!(v1::FinishedEpisode, e, {
        env: env as u32,
        kpis: kpis.into_iter().collect(),
    })
}

/// A finished episode from the wire: its statistics (layout 0) and its
/// KPIs sorted by name; the reward and every KPI must be finite.
pub fn episode_from_message(
    m: &v1::FinishedEpisode,
) -> Result<(EpisodeStats, Vec<(String, f64)>), ConvertError> {
    check_finite("episodes.reward", &[m.reward])?;
    let mut kpis: Vec<(String, f64)> = m.kpis.iter().map(|(k, &v)| (k.clone(), v)).collect();
    kpis.sort_by(|a, b| a.0.cmp(&b.0));
    if let Some((name, value)) = kpis.iter().find(|(_, v)| !v.is_finite()) {
        return Err(ConvertError::Invalid(format!(
            "episodes.kpis[{name:?}] is {value} (must be finite)"
        )));
    }
    let stats = with_episode_fields!(EpisodeStats, m, { layout: 0, replay: 0 });
    Ok((stats, kpis))
}

/// Checks a reset reply against `spec`: a session other than 0, and
/// observations and masks of the spec's sizes.
pub fn check_reset_reply(spec: &EnvSpec, m: &v1::ResetReply) -> Result<(), ConvertError> {
    if m.session == 0 {
        return Err(ConvertError::Invalid(
            "reset reply: session 0 (a session is never 0)".into(),
        ));
    }
    check_observation(spec, &m.obs, &m.masks)
}

/// Checks a step reply against `spec`: every buffer of the spec's size,
/// floats finite, masks and flags 0 or 1, final observations for exactly
/// the envs that ended, episodes only of those envs (each at most once).
pub fn check_step_reply(spec: &EnvSpec, m: &v1::StepReply) -> Result<(), ConvertError> {
    check_observation(spec, &m.obs, &m.masks)?;
    check_len("rewards", spec.agent_slots(), m.rewards.len())?;
    check_finite("rewards", &m.rewards)?;
    for (field, flags) in [("terminated", &m.terminated), ("truncated", &m.truncated)] {
        check_len(field, spec.num_envs, flags.len())?;
        check_below(field, flags, 2)?;
    }
    let ended: Vec<usize> = ended(&m.terminated, &m.truncated).collect();
    check_len(
        "final_obs",
        ended.len() * spec.rows_per_env() * spec.obs_dim,
        m.final_obs.len(),
    )?;
    check_finite("final_obs", &m.final_obs)?;
    let mut seen = vec![false; spec.num_envs];
    for (i, e) in m.episodes.iter().enumerate() {
        let env = e.env as usize;
        if ended.binary_search(&env).is_err() || std::mem::replace(&mut seen[env], true) {
            return Err(ConvertError::Invalid(format!(
                "episodes[{i}].env = {} is not an env whose episode ended in this step (or is reported twice)",
                e.env
            )));
        }
        episode_from_message(e)?;
    }
    Ok(())
}

fn check_observation(spec: &EnvSpec, obs: &[f32], masks: &[u8]) -> Result<(), ConvertError> {
    check_len("obs", spec.obs_len(), obs.len())?;
    check_finite("obs", obs)?;
    check_len("masks", spec.mask_len(), masks.len())?;
    check_below("masks", masks, 2)
}

fn check_len(field: &'static str, expected: usize, got: usize) -> Result<(), ConvertError> {
    if expected == got {
        Ok(())
    } else {
        Err(ConvertError::Length {
            field,
            expected,
            got,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> EnvSpec {
        EnvSpec {
            num_envs: 2,
            agents: 2,
            kind: ObsKind::Local,
            obs_dim: 3,
            num_actions: 3,
            t_max: 10,
            name: "test".into(),
        }
    }

    fn reply() -> v1::StepReply {
        v1::StepReply {
            obs: vec![0.5; 12],
            masks: vec![1; 12],
            rewards: vec![-0.01; 4],
            terminated: vec![0, 0],
            truncated: vec![0, 1],
            final_obs: vec![0.25; 6],
            episodes: vec![finished_episode(
                1,
                &EpisodeStats {
                    length: 10,
                    ..Default::default()
                },
                [],
            )],
        }
    }

    #[test]
    fn a_consistent_step_reply_passes() {
        check_step_reply(&spec(), &reply()).unwrap();
    }

    #[test]
    fn each_inconsistency_is_named() {
        let s = spec();
        let refused = |edit: &dyn Fn(&mut v1::StepReply)| {
            let mut m = reply();
            edit(&mut m);
            check_step_reply(&s, &m).unwrap_err().to_string()
        };
        assert_eq!(
            refused(&|m| m.obs.pop().map(drop).unwrap()),
            "obs holds 11 values, expected 12"
        );
        assert!(refused(&|m| m.obs[4] = f32::NAN).starts_with("obs[4] is NaN"));
        assert_eq!(
            refused(&|m| m.masks[2] = 2),
            "masks[2] = 2 is out of range (must be < 2)"
        );
        assert_eq!(
            refused(&|m| m.truncated[1] = 0),
            "final_obs holds 6 values, expected 0"
        );
        assert!(refused(&|m| m.episodes[0].env = 0).contains("episodes[0].env = 0"));
        assert!(refused(&|m| m.episodes.push(m.episodes[0].clone())).contains("episodes[1]"));
        assert!(refused(&|m| {
            m.episodes[0].kpis.insert("x".into(), f64::INFINITY);
        })
        .contains("kpis[\"x\"]"));
        assert_eq!(
            refused(&|m| m.rewards.push(0.0)),
            "rewards holds 5 values, expected 4"
        );
    }

    #[test]
    fn specs_that_cannot_be_served_are_refused() {
        let ok = spec_to_message(&spec());
        let refused = |edit: &dyn Fn(&mut v1::EnvSpec)| {
            let mut m = ok.clone();
            edit(&mut m);
            spec_from_message(&m).unwrap_err().to_string()
        };
        assert!(refused(&|m| m.num_envs = 0).contains("num_envs is 0"));
        assert!(refused(&|m| m.obs_kind = 7).contains("obs_kind = 7"));
        assert!(refused(&|m| m.num_actions = 257).contains("num_actions = 257"));
        assert!(refused(&|m| {
            m.num_envs = u32::MAX;
            m.obs_dim = u32::MAX;
        })
        .contains("larger than"));
        let central = EnvSpec {
            kind: ObsKind::Central,
            ..spec()
        };
        assert_eq!(
            spec_from_message(&spec_to_message(&central)).unwrap(),
            central
        );
        assert_eq!((central.rows(), central.mask_len()), (2, 12));
    }

    #[test]
    fn actions_out_of_range_are_named() {
        let err = check_actions(&spec(), &[0, 1, 3, 2]).unwrap_err();
        assert_eq!(
            err.to_string(),
            "actions[2] = 3 is out of range (must be < 3)"
        );
    }

    #[test]
    fn a_reset_reply_needs_a_session() {
        let m = v1::ResetReply {
            session: 0,
            obs: vec![0.0; 12],
            masks: vec![1; 12],
        };
        assert!(check_reset_reply(&spec(), &m).is_err());
        check_reset_reply(&spec(), &v1::ResetReply { session: 9, ..m }).unwrap();
    }
}
