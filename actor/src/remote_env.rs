//! [`RemoteEnv`]: a batch of envs served by another process over the env
//! API (`proto/buridan/v1/env.proto`) — a plant simulator, or
//! `plant-server` — as one more [`BatchedEnv`], so the collector drives it
//! exactly as it drives the built-in grid and plant envs.
//!
//! The data path per step: the collector's actions → `StepRequest` (one
//! copy into the message) → the simulator → `StepReply`, checked against
//! the spec ([`check_step_reply`]) and then *moved* into this env's buffers
//! (observations, masks, rewards and flags are the decoded vectors
//! themselves); only the final observations of ended envs are scattered
//! into their rows, and masks are widened if the policy's heads have more
//! slots than the simulator has actions.
//!
//! **Why a runtime of its own.** [`BatchedEnv::step`] is synchronous and
//! the collector runs on a blocking thread (`spawn_blocking` in the actor,
//! plain threads in embedded training). A `RemoteEnv` therefore owns a
//! current-thread tokio runtime and `block_on`s each call on the calling
//! thread: the channel's connection task lives on that runtime, so a step
//! is one request and one reply on the collector's own thread, with no
//! hop to another runtime's worker and back (a `Handle::block_on` on the
//! actor's runtime would wake its worker thread twice per step), and the
//! env works the same in any process, with or without a runtime of its
//! own. The cost: it must be created and used off async contexts (inside
//! `spawn_blocking`), and it shuts its runtime down in the background when
//! dropped, which is allowed anywhere.
//!
//! ```no_run
//! use buridan_actor::remote_env::{RemoteEnv, RemoteEnvOptions};
//! use buridan_env::BatchedEnv;
//! let mut env = RemoteEnv::connect("http://127.0.0.1:50061", 42, &RemoteEnvOptions::default()).unwrap();
//! let actions = vec![0u8; env.num_envs() * env.agents()];
//! env.step(&actions).unwrap(); // a disconnect: Err(EnvError::Remote { retryable: true, .. })
//! println!("{} rewards", env.rewards().len());
//! ```

use std::time::Duration;

use buridan_env::{batched_env_buffers, BatchedEnv, EnvError, ObsKind, StepBuffers};
use buridan_proto::env_convert::{
    check_reset_reply, check_step_reply, ended, episode_from_message, spec_from_message, EnvSpec,
};
use buridan_proto::v1;
use buridan_proto::v1::environment_client::EnvironmentClient;
use tonic::transport::Channel;
use tonic::{Code, Status};

/// Why a remote env could not be opened or stepped.
#[derive(Debug, thiserror::Error)]
pub enum RemoteEnvError {
    /// The URL is not `http(s)://HOST:PORT`.
    #[error("invalid env server URL '{url}': expected http://HOST:PORT")]
    Url {
        /// The URL given.
        url: String,
    },
    /// The client's runtime could not start.
    #[error("cannot start the env client's runtime")]
    Runtime(#[source] std::io::Error),
    /// No connection to the env server.
    #[error("cannot connect to the env server at {url}")]
    Connect {
        /// Where to.
        url: String,
        /// Why not.
        source: tonic::transport::Error,
    },
    /// A call failed: the server refused it or went away.
    #[error("the env server at {url} failed the {call} call: {}: {}", status.code(), status.message())]
    Rpc {
        /// The server.
        url: String,
        /// "Spec", "Reset" or "Step".
        call: &'static str,
        /// Its status (boxed: a status is large, the error's other
        /// variants small).
        status: Box<Status>,
    },
    /// A reply does not fit the server's own spec (or the spec is unusable).
    #[error("the env server at {url} sent a malformed {what}")]
    Malformed {
        /// The server.
        url: String,
        /// "spec", "reset reply" or "step reply".
        what: &'static str,
        /// What is wrong.
        source: Box<buridan_proto::ConvertError>,
    },
    /// The server's actions do not fit the policy's heads.
    #[error("the env server at {url} has {actions} actions per agent, more than the {slots} slots of the policy's heads")]
    TooManyActions {
        /// The server.
        url: String,
        /// Its actions per agent.
        actions: usize,
        /// Mask slots the client asked for.
        slots: usize,
    },
}

impl RemoteEnvError {
    /// Whether a new connection and session may help: the server went
    /// away, timed out, restarted or dropped the session — as opposed to a
    /// refusal or a malformed reply (a bug on one side).
    pub fn retryable(&self) -> bool {
        match self {
            RemoteEnvError::Connect { .. } => true,
            RemoteEnvError::Rpc { status, .. } => matches!(
                status.code(),
                Code::Unavailable
                    | Code::NotFound
                    | Code::Cancelled
                    | Code::Unknown
                    | Code::Aborted
                    | Code::DeadlineExceeded
                    | Code::ResourceExhausted
                    | Code::Internal
            ),
            _ => false,
        }
    }

    /// The server's URL, if the error names one.
    fn url(&self) -> &str {
        match self {
            RemoteEnvError::Url { url }
            | RemoteEnvError::Connect { url, .. }
            | RemoteEnvError::Rpc { url, .. }
            | RemoteEnvError::Malformed { url, .. }
            | RemoteEnvError::TooManyActions { url, .. } => url,
            RemoteEnvError::Runtime(_) => "",
        }
    }
}

impl From<RemoteEnvError> for EnvError {
    fn from(e: RemoteEnvError) -> Self {
        let mut message = e.to_string();
        let mut cause = std::error::Error::source(&e);
        while let Some(c) = cause {
            message.push_str(": ");
            message.push_str(&c.to_string());
            cause = c.source();
        }
        EnvError::Remote {
            target: e.url().to_string(),
            retryable: e.retryable(),
            message,
        }
    }
}

/// How a [`RemoteEnv`] talks to its server.
#[derive(Debug, Clone)]
pub struct RemoteEnvOptions {
    /// Mask bytes per agent the collector's policy expects (its heads'
    /// width); `None`: the server's actions. More slots than the server has
    /// actions are masked out; fewer is an error.
    pub mask_slots: Option<usize>,
    /// Longest wait for a connection.
    pub connect_timeout: Duration,
    /// Longest wait for one call (a simulator may step slowly).
    pub call_timeout: Duration,
}

impl Default for RemoteEnvOptions {
    fn default() -> Self {
        Self {
            mask_slots: None,
            connect_timeout: Duration::from_secs(5),
            call_timeout: Duration::from_secs(60),
        }
    }
}

/// A batch of envs stepped by a server of the env API.
pub struct RemoteEnv {
    url: String,
    /// `None` only while dropping.
    runtime: Option<tokio::runtime::Runtime>,
    client: EnvironmentClient<Channel>,
    spec: EnvSpec,
    session: u64,
    mask_slots: usize,
    buffers: StepBuffers,
    kpis: Vec<Vec<(String, f64)>>,
}

impl std::fmt::Debug for RemoteEnv {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RemoteEnv")
            .field("url", &self.url)
            .field("spec", &self.spec)
            .field("session", &self.session)
            .finish_non_exhaustive()
    }
}

impl RemoteEnv {
    /// Connects to the server at `url`, reads its spec and opens a session
    /// seeded `seed`. Blocks; call it off async contexts (e.g. in
    /// `spawn_blocking`).
    pub fn connect(url: &str, seed: u64, opts: &RemoteEnvOptions) -> Result<Self, RemoteEnvError> {
        let (runtime, mut client) = open_client(url, opts)?;
        let rpc = |call, status| RemoteEnvError::Rpc {
            url: url.to_string(),
            call,
            status: Box::new(status),
        };
        let malformed = |what, source| RemoteEnvError::Malformed {
            url: url.to_string(),
            what,
            source: Box::new(source),
        };
        let spec = read_spec(&runtime, &mut client, url)?;
        let mask_slots = opts.mask_slots.unwrap_or(spec.num_actions);
        if mask_slots < spec.num_actions {
            return Err(RemoteEnvError::TooManyActions {
                url: url.to_string(),
                actions: spec.num_actions,
                slots: mask_slots,
            });
        }
        let reset = runtime
            .block_on(client.reset(v1::ResetRequest { seed }))
            .map_err(|s| rpc("Reset", s))?
            .into_inner();
        check_reset_reply(&spec, &reset).map_err(|e| malformed("reset reply", e))?;
        tracing::info!(
            url,
            name = %spec.name,
            envs = spec.num_envs,
            agents = spec.agents,
            session = reset.session,
            seed,
            "remote env session opened"
        );
        let buffers = StepBuffers {
            obs: reset.obs,
            ..StepBuffers::new(spec.num_envs, spec.agents, spec.obs_len(), 0)
        };
        let mut env = Self {
            url: url.to_string(),
            runtime: Some(runtime),
            client,
            session: reset.session,
            mask_slots,
            buffers,
            kpis: Vec::new(),
            spec,
        };
        env.set_masks(reset.masks);
        Ok(env)
    }

    /// The spec of the server at `url`, read on a connection of its own
    /// (the actor joins the learner with the server's env count before it
    /// opens a session). Blocks; call it off async contexts.
    pub fn fetch_spec(url: &str, opts: &RemoteEnvOptions) -> Result<EnvSpec, RemoteEnvError> {
        let (runtime, mut client) = open_client(url, opts)?;
        let spec = read_spec(&runtime, &mut client, url);
        drop(client);
        runtime.shutdown_background();
        spec
    }

    /// The server's spec.
    pub fn spec(&self) -> &EnvSpec {
        &self.spec
    }

    /// The server's URL.
    pub fn url(&self) -> &str {
        &self.url
    }

    /// The session this env steps.
    pub fn session(&self) -> u64 {
        self.session
    }

    /// Takes the KPIs (by name) of the episodes finished since the last
    /// call, in the order [`BatchedEnv::drain_episodes`] gives their
    /// statistics.
    pub fn drain_kpis(&mut self) -> Vec<Vec<(String, f64)>> {
        std::mem::take(&mut self.kpis)
    }

    /// Steps the session: [`BatchedEnv::step`] with this crate's error.
    pub fn try_step(&mut self, actions: &[u8]) -> Result<(), RemoteEnvError> {
        let request = v1::StepRequest {
            session: self.session,
            actions: actions.to_vec(),
        };
        let runtime =
            self.runtime
                .as_ref()
                .ok_or(RemoteEnvError::Runtime(std::io::Error::other(
                    "the runtime is gone",
                )))?;
        let reply = runtime
            .block_on(self.client.step(request))
            .map_err(|status| RemoteEnvError::Rpc {
                url: self.url.clone(),
                call: "Step",
                status: Box::new(status),
            })?
            .into_inner();
        check_step_reply(&self.spec, &reply).map_err(|source| RemoteEnvError::Malformed {
            url: self.url.clone(),
            what: "step reply",
            source: Box::new(source),
        })?;
        let (per_env, d) = (self.spec.rows_per_env(), self.spec.obs_dim);
        let row_len = per_env * d;
        for (k, e) in ended(&reply.terminated, &reply.truncated).enumerate() {
            self.buffers.final_obs[e * row_len..(e + 1) * row_len]
                .copy_from_slice(&reply.final_obs[k * row_len..(k + 1) * row_len]);
        }
        for episode in &reply.episodes {
            // Checked above.
            if let Ok((stats, kpis)) = episode_from_message(episode) {
                self.buffers.episodes.push(stats);
                self.kpis.push(kpis);
            }
        }
        self.buffers.obs = reply.obs;
        self.buffers.rewards = reply.rewards;
        self.buffers.terminated = reply.terminated;
        self.buffers.truncated = reply.truncated;
        self.set_masks(reply.masks);
        Ok(())
    }

    /// Keeps `masks` (checked: `num_actions` per agent), widened to
    /// `mask_slots` per agent with the extra slots masked out.
    fn set_masks(&mut self, masks: Vec<u8>) {
        let a = self.spec.num_actions;
        let out = &mut self.buffers.masks;
        if self.mask_slots == a {
            *out = masks;
            return;
        }
        out.clear();
        out.reserve(self.spec.agent_slots() * self.mask_slots);
        for agent in masks.chunks_exact(a) {
            out.extend_from_slice(agent);
            out.extend(std::iter::repeat_n(0u8, self.mask_slots - a));
        }
    }
}

/// A runtime of the caller's own and a client connected on it.
fn open_client(
    url: &str,
    opts: &RemoteEnvOptions,
) -> Result<(tokio::runtime::Runtime, EnvironmentClient<Channel>), RemoteEnvError> {
    let bad_url = || RemoteEnvError::Url {
        url: url.to_string(),
    };
    let uri: tonic::codegen::http::Uri = url.parse().map_err(|_| bad_url())?;
    if !matches!(uri.scheme_str(), Some("http" | "https")) || uri.authority().is_none() {
        return Err(bad_url());
    }
    let endpoint = Channel::from_shared(url.to_string())
        .map_err(|_| bad_url())?
        .connect_timeout(opts.connect_timeout)
        .timeout(opts.call_timeout)
        .tcp_nodelay(true);
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(RemoteEnvError::Runtime)?;
    let channel = runtime
        .block_on(endpoint.connect())
        .map_err(|source| RemoteEnvError::Connect {
            url: url.to_string(),
            source,
        });
    let channel = match channel {
        Ok(c) => c,
        Err(e) => {
            runtime.shutdown_background();
            return Err(e);
        }
    };
    let client = EnvironmentClient::new(channel)
        .max_decoding_message_size(64 * 1024 * 1024)
        .max_encoding_message_size(64 * 1024 * 1024);
    Ok((runtime, client))
}

/// The server's spec, checked.
fn read_spec(
    runtime: &tokio::runtime::Runtime,
    client: &mut EnvironmentClient<Channel>,
    url: &str,
) -> Result<EnvSpec, RemoteEnvError> {
    let m = runtime
        .block_on(client.spec(v1::SpecRequest {}))
        .map_err(|status| RemoteEnvError::Rpc {
            url: url.to_string(),
            call: "Spec",
            status: Box::new(status),
        })?
        .into_inner();
    spec_from_message(&m).map_err(|source| RemoteEnvError::Malformed {
        url: url.to_string(),
        what: "spec",
        source: Box::new(source),
    })
}

impl Drop for RemoteEnv {
    fn drop(&mut self) {
        // Dropping a runtime blocks, which panics inside async contexts
        // (an actor drops its collector in an async task): let it wind
        // down in the background instead.
        if let Some(runtime) = self.runtime.take() {
            runtime.shutdown_background();
        }
    }
}

impl BatchedEnv for RemoteEnv {
    fn num_envs(&self) -> usize {
        self.spec.num_envs
    }
    fn agents(&self) -> usize {
        self.spec.agents
    }
    fn kind(&self) -> ObsKind {
        self.spec.kind
    }
    fn obs_dim(&self) -> usize {
        self.spec.obs_dim
    }
    /// Steps the session over the wire; a failure is
    /// [`EnvError::Remote`] (with `retryable` set when the server went
    /// away, restarted or dropped the session).
    fn step(&mut self, actions: &[u8]) -> Result<(), EnvError> {
        self.try_step(actions).map_err(EnvError::from)
    }
    batched_env_buffers!(buffers);
}
