//! The envs and policy a session collects with: built from the join reply,
//! or over an env server, checked against the run and reopened with
//! backoff when the server goes away.

use std::sync::Arc;

use buridan_env::error::error_chain;
use buridan_env::VecEnv;
use buridan_policy::{ActMode, Inference, ModelSpec, Policy};
use buridan_proto::convert::{
    check_run_spec, env_from_message, map_from_message, replay_from_message, ConvertError,
};
use buridan_proto::env_convert::EnvSpec;
use buridan_proto::v1;
use rand::Rng;
use tokio::sync::watch;

use super::{ActorError, ActorOptions, SessionEnd, SetupError, Update};
use crate::collector::{ActorEnv, Collector};
use crate::remote_env::{RemoteEnv, RemoteEnvError, RemoteEnvOptions};
use buridan_mapf::shield::rollout::RolloutShield;

/// The spec of the env server at `url` (a short connection of its own).
pub(super) async fn fetch_env_spec(
    url: &str,
    opts: &ActorOptions,
) -> Result<EnvSpec, RemoteEnvError> {
    let (url, options) = (url.to_string(), opts.env_options.clone());
    tokio::task::spawn_blocking(move || RemoteEnv::fetch_spec(&url, &options))
        .await
        .unwrap_or_else(|_| {
            Err(RemoteEnvError::Runtime(std::io::Error::other(
                "the env client task panicked",
            )))
        })
}

/// A collector over a new session on the env server at `url`, the
/// `attempt`-th of this learner session (the blocking connect runs off the
/// async threads).
pub(super) async fn open_remote(
    join: &v1::JoinReply,
    url: &str,
    opts: &ActorOptions,
    attempt: u64,
) -> Result<Collector<ActorEnv>, SetupError> {
    let (join, url, options) = (join.clone(), url.to_string(), opts.env_options.clone());
    tokio::task::spawn_blocking(move || build_remote_collector(&join, &url, &options, attempt))
        .await
        .unwrap_or_else(|_| {
            Err(SetupError::from(RemoteEnvError::Runtime(
                std::io::Error::other("the env client task panicked"),
            )))
        })
}

/// Opens env sessions on the env server at `url` with backoff until one
/// opens (`Ok(Ok(collector))`), the learner ends the session meanwhile
/// (`Ok(Err(end))`), or the server refuses for good (`Err`).
pub(super) async fn reconnect_env(
    join: &v1::JoinReply,
    url: &str,
    opts: &ActorOptions,
    attempt: &mut u64,
    latest: &mut watch::Receiver<Option<Update>>,
) -> Result<Result<Collector<ActorEnv>, SessionEnd>, ActorError> {
    let mut delay = opts.backoff_initial;
    loop {
        let wait = delay.mul_f64(rand::rng().random_range(0.8..1.2));
        tokio::time::sleep(wait).await;
        match latest.borrow().clone() {
            Some(Update::Finished) => return Ok(Err(SessionEnd::Finished)),
            Some(Update::Lost(why)) => return Ok(Err(SessionEnd::Lost(ActorError::Stream(why)))),
            _ => {}
        }
        *attempt += 1;
        match open_remote(join, url, opts, *attempt).await {
            Ok(c) => {
                tracing::info!(env = url, attempt = *attempt, "env session reopened");
                return Ok(Ok(c));
            }
            Err(e) if e.retryable() => {
                tracing::warn!("{}; retrying", error_chain(&e));
                delay = (delay * 2).min(opts.backoff_max);
            }
            Err(e) => return Err(ActorError::Setup(e)),
        }
    }
}

/// Checks an env server's spec against the run the learner described:
/// observation kind and size, agents, actions (at most the policy heads'
/// width; fewer are masked out), envs (the count joined with) and T_max.
///
/// ```
/// use buridan_actor::client::check_env_spec;
/// use buridan_env::ObsKind;
/// use buridan_policy::{ModelSpec, Mode};
/// use buridan_proto::env_convert::EnvSpec;
/// use buridan_proto::v1;
/// let model = ModelSpec::new(Mode::Ctde, 2, 11);
/// let join = v1::JoinReply {
///     envs: 8,
///     run: Some(v1::RunSpec {
///         plant: Some(v1::PlantSettings { name: "plant:dissertation".into(), agents: 2, t_max: 1000 }),
///         ..Default::default()
///     }),
///     ..Default::default()
/// };
/// let mut env = EnvSpec { num_envs: 8, agents: 2, kind: ObsKind::Local, obs_dim: 11, num_actions: 3, t_max: 1000, name: "plant:dissertation".into() };
/// check_env_spec(&env, &model, &join).unwrap();
/// env.obs_dim = 16;
/// let err = check_env_spec(&env, &model, &join).unwrap_err();
/// assert_eq!(err.to_string(), "the env server 'plant:dissertation' has obs_dim 16, the run 11");
/// ```
pub fn check_env_spec(
    env: &EnvSpec,
    model: &ModelSpec,
    join: &v1::JoinReply,
) -> Result<(), SetupError> {
    let mismatch = |what, env_value: String, run: String| SetupError::EnvSpec {
        name: env.name.clone(),
        what,
        env: env_value,
        run,
    };
    let run_kind = model.mode.obs_kind();
    if env.kind != run_kind {
        return Err(mismatch(
            "observation rows",
            format!("{:?}", env.kind).to_lowercase(),
            format!("{:?} ({} policy)", run_kind, model.mode).to_lowercase(),
        ));
    }
    let (plant, env_settings) = join
        .run
        .as_ref()
        .map_or((None, None), |r| (r.plant.as_ref(), r.env.as_ref()));
    let run_t_max = match (plant, env_settings) {
        (Some(p), _) => Some(p.t_max),
        (None, Some(e)) => Some(e.t_max),
        (None, None) => None,
    };
    for (what, got, want) in [
        ("obs_dim", env.obs_dim, Some(model.obs_dim)),
        ("agents", env.agents, Some(model.agents)),
        ("num_envs", env.num_envs, Some(join.envs as usize)),
        ("t_max", env.t_max as usize, run_t_max.map(|t| t as usize)),
    ] {
        if let Some(want) = want {
            if got != want {
                return Err(mismatch(what, got.to_string(), want.to_string()));
            }
        }
    }
    if env.num_actions > model.actions {
        return Err(mismatch(
            "num_actions",
            env.num_actions.to_string(),
            format!("at most {} (the policy heads' width)", model.actions),
        ));
    }
    if let Some(plant) = plant {
        if env.name != plant.name {
            tracing::warn!(
                env = %env.name,
                run = %plant.name,
                "the env server's name differs from the run's plant (shapes match, so training goes on)"
            );
        }
    }
    Ok(())
}

/// Envs and policy as the learner described them in a join reply, with
/// the envs stepped on the env server at `url` (a new session seeded from
/// the join's seed and `attempt`, checked by [`check_env_spec`]). Blocks:
/// call it off async contexts.
pub fn build_remote_collector(
    join: &v1::JoinReply,
    url: &str,
    options: &RemoteEnvOptions,
    attempt: u64,
) -> Result<Collector<ActorEnv>, SetupError> {
    let (run, spec) = run_spec(join)?;
    let options = RemoteEnvOptions {
        mask_slots: Some(spec.actions),
        ..options.clone()
    };
    let seed = buridan_env::seed::remote_env_session(join.seed, attempt);
    let venv = RemoteEnv::connect(url, seed, &options)?;
    check_env_spec(venv.spec(), &spec, join)?;
    collector_over(join, run, spec, Box::new(venv))
}

/// The run a join reply describes, checked ([`check_run_spec`]), and its
/// model spec.
///
/// ```
/// use buridan_actor::client::run_spec;
/// use buridan_proto::v1;
/// let join = v1::JoinReply { run: Some(v1::RunSpec::default()), ..Default::default() };
/// let err = run_spec(&join).unwrap_err();
/// assert_eq!(err.to_string(), "run.model is missing");
/// ```
pub fn run_spec(join: &v1::JoinReply) -> Result<(&v1::RunSpec, ModelSpec), SetupError> {
    let run = join
        .run
        .as_ref()
        .ok_or(ConvertError::Missing { field: "run" })?;
    Ok((run, check_run_spec(run)?))
}

/// The collector of a join reply over `venv`.
fn collector_over(
    join: &v1::JoinReply,
    run: &v1::RunSpec,
    spec: ModelSpec,
    venv: ActorEnv,
) -> Result<Collector<ActorEnv>, SetupError> {
    if venv.obs_dim() != spec.obs_dim {
        return Err(SetupError::ObsDim {
            env: venv.obs_dim(),
            model: spec.obs_dim,
        });
    }
    let rows = venv.rows();
    let policy = Policy::new(spec, join.seed)?;
    Ok(Collector {
        id: join.actor_id,
        inference: Inference::new(policy, rows, buridan_env::seed::session_sampling(join.seed)),
        behaviour: ActMode::rollout(run.greedy_mix),
        venv,
        fragment_len: run.fragment_len as usize,
        // Nothing loaded yet: the first weights always load.
        version: u64::MAX,
        shield: run
            .shield_rollouts
            .then(|| RolloutShield::new(buridan_env::seed::session_sampling(join.seed))),
    })
}

/// Envs and policy as the learner described them in a join reply: the
/// grid envs of its map (a plant run's envs are external: see
/// [`build_remote_collector`]).
pub fn build_collector(join: &v1::JoinReply) -> Result<Collector<ActorEnv>, SetupError> {
    let (run, spec) = run_spec(join)?;
    if let Some(plant) = &run.plant {
        return Err(SetupError::NeedsEnv {
            plant: plant.name.clone(),
            agents: plant.agents,
        });
    }
    let map = map_from_message(run.map.clone().ok_or(SetupError::Missing("map"))?).parse()?;
    let env = env_from_message(
        run.env
            .as_ref()
            .ok_or(SetupError::Missing("env settings"))?,
        join.seed,
    )?;
    let kind = spec.mode.obs_kind();
    let replay = run
        .replay
        .as_ref()
        .map(replay_from_message)
        .unwrap_or_default();
    let venv = VecEnv::new(Arc::new(map), env, join.envs as usize, kind, 1)?.boxed(replay)?;
    collector_over(join, run, spec, venv)
}
