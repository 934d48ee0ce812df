//! A misbehaving client for soak runs: it loops over what a careless or
//! hostile client sends a learner and checks the learner's answer to each.
//!
//! Each round it
//! - sends bytes that do not decode as the request message (gRPC framing
//!   intact) as `SubmitFragment` and as `Join` → expects `INVALID_ARGUMENT`;
//! - submits real fragments made implausible: a reward of 1e30, a NaN
//!   logit, a −∞ logit where the mask allows the action → expects
//!   `INVALID_ARGUMENT`;
//! - once the learner's policy is well past the fragment's, replays an old
//!   real fragment: the first submission must be refused as stale (an `OK`
//!   reply with `accepted = false`), the same sequence number again must get
//!   `ALREADY_EXISTS` (no fragment is used twice);
//! - opens a session and leaves it idle; every few rounds, if it knows the
//!   learner's `--max-sessions`, it joins until the cap answers
//!   `RESOURCE_EXHAUSTED`, and, if it knows `--session-idle-timeout`, checks
//!   that its idle sessions are gone (`NOT_FOUND`) after the timeout.
//!
//! [`MisbehaveTally`] counts what was sent and what came back. Anything the
//! learner took that it should have refused is counted in
//! [`MisbehaveTally::wrongly_accepted`]; an answer with another status in
//! [`MisbehaveTally::unexpected`]. Connection failures (a learner restarting)
//! are only counted: the client reconnects next round.
//!
//! ```no_run
//! use buridan_actor::misbehave::{Misbehaver, MisbehaveOptions};
//! let m = Misbehaver::spawn("http://127.0.0.1:50051", MisbehaveOptions::default()).unwrap();
//! std::thread::sleep(std::time::Duration::from_secs(30));
//! let tally = m.stop();
//! assert_eq!(tally.wrongly_accepted, 0, "{}", tally.last_problem);
//! ```

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use buridan_policy::Fragment;
use buridan_proto::convert::{fragment_to_message, weights_from_message, WireTag};
use buridan_proto::v1;
use buridan_proto::v1::learner_client::LearnerClient;
use prost::bytes::Buf;
use prost::bytes::BufMut;
use prost::Message;
use rand::{Rng, SeedableRng};
use tonic::codec::{Codec, DecodeBuf, Decoder, EncodeBuf, Encoder};
use tonic::transport::Channel;
use tonic::{Code, Status};

use crate::client::{build_collector, url_connector, ActorError, Connector};

/// How the misbehaving client behaves.
#[derive(Debug, Clone)]
pub struct MisbehaveOptions {
    /// Name it joins with (the learner's logs).
    pub name: String,
    /// The learner's `--max-sessions`, to probe the cap (`None`: no probe).
    pub max_sessions: Option<usize>,
    /// The learner's `--session-idle-timeout`, to check that idle sessions
    /// expire (`None`: no check).
    pub idle_timeout: Option<Duration>,
    /// Probe the cap and the expiry every this many rounds (0: never). While
    /// the cap is full, real actors that (re)join are refused and back off.
    pub probe_every: u64,
    /// Pause between rounds.
    pub pause: Duration,
    /// Seed of the random bytes and of which reward or logit is spoiled.
    pub seed: u64,
}

impl Default for MisbehaveOptions {
    fn default() -> Self {
        Self {
            name: "misbehaving".into(),
            max_sessions: None,
            idle_timeout: None,
            probe_every: 5,
            pause: Duration::from_secs(2),
            seed: 0,
        }
    }
}

/// What the misbehaving client sent and what came back.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct MisbehaveTally {
    /// Rounds completed.
    pub rounds: u64,
    /// Undecodable requests sent.
    pub undecodable_sent: u64,
    /// … answered `INVALID_ARGUMENT`.
    pub undecodable_refused: u64,
    /// Implausible fragments sent (reward 1e30, NaN or −∞ logits).
    pub implausible_sent: u64,
    /// … answered `INVALID_ARGUMENT`.
    pub implausible_refused: u64,
    /// Old fragments submitted once the learner was past them.
    pub stale_sent: u64,
    /// … refused as stale (`OK`, not accepted).
    pub stale_refused: u64,
    /// The same fragments with the same sequence number again.
    pub replays_sent: u64,
    /// … answered `ALREADY_EXISTS`.
    pub replays_refused: u64,
    /// Sessions opened and left idle.
    pub idle_sessions: u64,
    /// Joins answered `RESOURCE_EXHAUSTED` (the session cap).
    pub joins_refused_at_cap: u64,
    /// Idle sessions found gone (`NOT_FOUND`) after the idle timeout.
    pub idle_sessions_expired: u64,
    /// Things the learner took that it should have refused (an implausible
    /// or stale fragment accepted, a replay accepted, a join beyond the
    /// cap, an idle session alive after its timeout).
    pub wrongly_accepted: u64,
    /// Refusals with another status than expected.
    pub unexpected: u64,
    /// Calls that failed on the connection (learner unreachable, reset).
    pub transport_errors: u64,
    /// The last wrongly accepted or unexpected answer, for the report.
    pub last_problem: String,
}

impl MisbehaveTally {
    /// Misbehaving requests sent (each expecting a refusal).
    pub fn sent(&self) -> u64 {
        self.undecodable_sent + self.implausible_sent + self.stale_sent + self.replays_sent
    }

    /// Refusals received as expected.
    pub fn refused(&self) -> u64 {
        self.undecodable_refused
            + self.implausible_refused
            + self.stale_refused
            + self.replays_refused
            + self.joins_refused_at_cap
            + self.idle_sessions_expired
    }
}

/// A misbehaving client running on its own thread until stopped.
pub struct Misbehaver {
    stop: Arc<AtomicBool>,
    tally: Arc<Mutex<MisbehaveTally>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Misbehaver {
    /// Starts the client against the learner at `url` (`http://host:port`).
    pub fn spawn(url: &str, opts: MisbehaveOptions) -> Result<Misbehaver, ActorError> {
        let connect = url_connector(url, None)?;
        let stop = Arc::new(AtomicBool::new(false));
        let tally = Arc::new(Mutex::new(MisbehaveTally::default()));
        let (s, t) = (stop.clone(), tally.clone());
        let thread = std::thread::Builder::new()
            .name("misbehave".into())
            .spawn(move || {
                let runtime = tokio::runtime::Builder::new_current_thread()
                    .enable_all()
                    .build()
                    .expect("a tokio runtime for the misbehaving client");
                runtime.block_on(run(connect, opts, t, s));
            })
            .expect("a thread for the misbehaving client");
        Ok(Misbehaver {
            stop,
            tally,
            thread: Some(thread),
        })
    }

    /// The tally so far.
    pub fn tally(&self) -> MisbehaveTally {
        self.tally.lock().expect("tally lock").clone()
    }

    /// Stops the client (after its current call) and returns the tally.
    pub fn stop(mut self) -> MisbehaveTally {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        self.tally()
    }
}

impl Drop for Misbehaver {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
    }
}

/// Runs rounds of misbehaviour until `stop` is set, counting into `tally`.
pub async fn run(
    connect: Connector,
    opts: MisbehaveOptions,
    tally: Arc<Mutex<MisbehaveTally>>,
    stop: Arc<AtomicBool>,
) {
    let mut client = Client {
        opts,
        tally,
        stop,
        rng: rand::rngs::StdRng::seed_from_u64(0),
        old: None,
        seq: 0,
        idle: Vec::new(),
    };
    client.rng = rand::rngs::StdRng::seed_from_u64(client.opts.seed);
    let mut round = 0u64;
    while !client.stopped() {
        round += 1;
        let probe = client.opts.probe_every > 0 && round.is_multiple_of(client.opts.probe_every);
        match connect().await {
            Ok(channel) => match client.round(channel, probe).await {
                Ok(Flow::Go) => client.tally(|t| t.rounds += 1),
                Ok(Flow::Finished) => break,
                Err(status) => {
                    tracing::debug!(?status, "misbehaving client: connection failed");
                    client.tally(|t| t.transport_errors += 1);
                }
            },
            Err(e) => {
                tracing::debug!("misbehaving client: {e}");
                client.tally(|t| t.transport_errors += 1);
            }
        }
        client.sleep(client.opts.pause).await;
    }
}

/// Whether to go on after a round.
enum Flow {
    Go,
    Finished,
}

/// An idle session left open by an earlier round.
struct IdleSession {
    run_id: String,
    session: u64,
    opened: tokio::time::Instant,
}

struct Client {
    opts: MisbehaveOptions,
    tally: Arc<Mutex<MisbehaveTally>>,
    stop: Arc<AtomicBool>,
    rng: rand::rngs::StdRng,
    /// A real fragment from the first round and the learner run it came
    /// from, replayed once the learner is past its policy version.
    old: Option<(String, Fragment)>,
    seq: u64,
    idle: Vec<IdleSession>,
}

/// A status that says the connection (not the request) failed.
fn transport(status: &Status) -> bool {
    matches!(
        status.code(),
        Code::Unavailable | Code::Unknown | Code::Cancelled | Code::DeadlineExceeded
    )
}

impl Client {
    fn stopped(&self) -> bool {
        self.stop.load(Ordering::SeqCst)
    }

    fn tally(&self, f: impl FnOnce(&mut MisbehaveTally)) {
        f(&mut self.tally.lock().expect("tally lock"));
    }

    fn problem(&self, wrongly_accepted: bool, what: String) {
        tracing::warn!("misbehaving client: {what}");
        self.tally(|t| {
            if wrongly_accepted {
                t.wrongly_accepted += 1;
            } else {
                t.unexpected += 1;
            }
            t.last_problem = what;
        });
    }

    /// Sleeps `d`, waking early when stopped.
    async fn sleep(&self, d: Duration) {
        let end = tokio::time::Instant::now() + d;
        while !self.stopped() && tokio::time::Instant::now() < end {
            tokio::time::sleep(Duration::from_millis(50).min(d)).await;
        }
    }

    fn next_seq(&mut self) -> u64 {
        self.seq += 1;
        self.seq
    }

    /// One round over a fresh channel; `Err` if the connection failed.
    async fn round(&mut self, channel: Channel, probe: bool) -> Result<Flow, Status> {
        let mut client = LearnerClient::new(channel.clone())
            .max_decoding_message_size(64 * 1024 * 1024)
            .max_encoding_message_size(64 * 1024 * 1024);
        self.undecodable(&channel).await?;
        let joined = match self.join(&mut client).await? {
            Some(j) if j.run_finished => return Ok(Flow::Finished),
            Some(j) => j,
            None => return Ok(Flow::Go),
        };
        // Watch, so that this session never expires during the round; a
        // task follows the learner's version.
        let version = Arc::new(AtomicU64::new(0));
        let mut stream = match client
            .watch_parameters(v1::WatchRequest {
                run_id: joined.run_id.clone(),
                session: joined.session,
            })
            .await
        {
            Ok(s) => s.into_inner(),
            Err(s) if transport(&s) => return Err(s),
            Err(s) => {
                self.problem(false, format!("watching its own session: {s:?}"));
                return Ok(Flow::Go);
            }
        };
        let Some(first) = stream.message().await? else {
            return Ok(Flow::Go);
        };
        if first.finished {
            return Ok(Flow::Finished);
        }
        version.store(first.version, Ordering::SeqCst);
        let follow = {
            let version = version.clone();
            tokio::spawn(async move {
                while let Ok(Some(p)) = stream.message().await {
                    version.store(p.version, Ordering::SeqCst);
                }
            })
        };
        let _abort = AbortOnDrop(follow);
        let fragment = match self.collect(&joined, first) {
            Ok(f) => f,
            Err(e) => {
                self.problem(false, format!("cannot collect a template fragment: {e}"));
                return Ok(Flow::Go);
            }
        };
        if self.old.is_none() {
            self.old = Some((joined.run_id.clone(), fragment.clone()));
        }
        self.implausible(&mut client, &joined, &fragment).await?;
        self.replay(&mut client, &joined, version.load(Ordering::SeqCst))
            .await?;
        // One more session, left idle.
        if let Some(idle) = self.join(&mut client).await? {
            if !idle.run_finished {
                self.tally(|t| t.idle_sessions += 1);
                self.idle.push(IdleSession {
                    run_id: idle.run_id,
                    session: idle.session,
                    opened: tokio::time::Instant::now(),
                });
            }
        }
        if probe {
            self.probe_cap(&mut client).await?;
            self.check_expired(&mut client).await?;
        }
        Ok(Flow::Go)
    }

    /// Joins; `None` if the session cap refused the join (counted).
    async fn join(
        &mut self,
        client: &mut LearnerClient<Channel>,
    ) -> Result<Option<v1::JoinReply>, Status> {
        let reply = client
            .join(v1::JoinRequest {
                api_version: v1::ApiVersion::V2 as u32,
                actor_name: self.opts.name.clone(),
                envs: 0,
            })
            .await;
        match reply {
            Ok(r) => Ok(Some(r.into_inner())),
            Err(s) if s.code() == Code::ResourceExhausted => {
                self.tally(|t| t.joins_refused_at_cap += 1);
                Ok(None)
            }
            Err(s) if transport(&s) => Err(s),
            Err(s) => {
                self.problem(false, format!("join: {s:?}"));
                Ok(None)
            }
        }
    }

    /// A real fragment under the learner's first weights.
    fn collect(
        &self,
        joined: &v1::JoinReply,
        weights: v1::Parameters,
    ) -> Result<Fragment, Box<dyn std::error::Error>> {
        let mut collector = build_collector(joined)?;
        collector.load(&weights_from_message(weights)?)?;
        Ok(collector.collect()?)
    }

    /// Random bytes as a `SubmitFragment` and as a `Join` request.
    async fn undecodable(&mut self, channel: &Channel) -> Result<(), Status> {
        let mut grpc = tonic::client::Grpc::new(channel.clone());
        for method in ["SubmitFragment", "Join"] {
            let bytes = undecodable_bytes(&mut self.rng, 64);
            grpc.ready()
                .await
                .map_err(|e| Status::unavailable(e.to_string()))?;
            let path = format!("/buridan.v1.Learner/{method}")
                .parse()
                .expect("a gRPC path");
            self.tally(|t| t.undecodable_sent += 1);
            match grpc.unary(tonic::Request::new(bytes), path, RawCodec).await {
                Ok(_) => self.problem(true, format!("{method}: random bytes were answered OK")),
                Err(s) if s.code() == Code::InvalidArgument => {
                    self.tally(|t| t.undecodable_refused += 1)
                }
                Err(s) if transport(&s) => return Err(s),
                Err(s) => self.problem(false, format!("{method} of random bytes: {s:?}")),
            }
        }
        Ok(())
    }

    /// `fragment` spoiled three ways, each submitted once.
    async fn implausible(
        &mut self,
        client: &mut LearnerClient<Channel>,
        joined: &v1::JoinReply,
        fragment: &Fragment,
    ) -> Result<(), Status> {
        let spoils = [Spoil::HugeReward, Spoil::NanLogit, Spoil::NegInfLogit];
        for spoil in spoils {
            let Some(bad) = spoil.apply(fragment, &mut self.rng) else {
                continue;
            };
            let tag = WireTag {
                run_id: joined.run_id.clone(),
                session: joined.session,
                seq: self.next_seq(),
            };
            self.tally(|t| t.implausible_sent += 1);
            match client.submit_fragment(fragment_to_message(bad, &tag)).await {
                Ok(r) if r.get_ref().run_finished => {}
                Ok(r) => self.problem(
                    r.get_ref().accepted,
                    format!("a fragment with {spoil:?} was answered {:?}", r.get_ref()),
                ),
                Err(s) if s.code() == Code::InvalidArgument => {
                    self.tally(|t| t.implausible_refused += 1)
                }
                Err(s) if transport(&s) => return Err(s),
                Err(s) => self.problem(false, format!("a fragment with {spoil:?}: {s:?}")),
            }
        }
        Ok(())
    }

    /// The first round's fragment, resubmitted twice under one sequence
    /// number once the learner is past its version.
    async fn replay(
        &mut self,
        client: &mut LearnerClient<Channel>,
        joined: &v1::JoinReply,
        learner_version: u64,
    ) -> Result<(), Status> {
        let Some((run_id, old)) = &self.old else {
            return Ok(());
        };
        let lag = match &joined.run {
            Some(run) if !run.on_policy => run.max_policy_lag,
            _ => 0,
        };
        // A restarted learner (new run id) may be back at an earlier version.
        if *run_id != joined.run_id || learner_version <= old.policy_version + lag + 1 {
            return Ok(());
        }
        let mut old = old.clone();
        old.actor = joined.actor_id;
        let tag = WireTag {
            run_id: joined.run_id.clone(),
            session: joined.session,
            seq: self.next_seq(),
        };
        self.tally(|t| t.stale_sent += 1);
        match client
            .submit_fragment(fragment_to_message(old.clone(), &tag))
            .await
        {
            Ok(r) if r.get_ref().run_finished => return Ok(()),
            Ok(r) if !r.get_ref().accepted => self.tally(|t| t.stale_refused += 1),
            Ok(r) => self.problem(
                true,
                format!(
                    "a fragment of version {} was accepted at learner version {learner_version}: {:?}",
                    old.policy_version,
                    r.get_ref()
                ),
            ),
            Err(s) if transport(&s) => return Err(s),
            Err(s) => {
                self.problem(false, format!("an old fragment: {s:?}"));
                return Ok(());
            }
        }
        self.tally(|t| t.replays_sent += 1);
        match client.submit_fragment(fragment_to_message(old, &tag)).await {
            Err(s) if s.code() == Code::AlreadyExists => self.tally(|t| t.replays_refused += 1),
            Err(s) if transport(&s) => return Err(s),
            Err(s) => self.problem(false, format!("a replayed fragment: {s:?}")),
            Ok(r) if r.get_ref().run_finished => {}
            Ok(r) => self.problem(
                r.get_ref().accepted,
                format!("a replayed sequence number was answered {:?}", r.get_ref()),
            ),
        }
        Ok(())
    }

    /// Joins until the cap refuses; more than `max_sessions` joins taken is
    /// a cap not enforced.
    async fn probe_cap(&mut self, client: &mut LearnerClient<Channel>) -> Result<(), Status> {
        let Some(cap) = self.opts.max_sessions else {
            return Ok(());
        };
        for _ in 0..=cap {
            // `None`: refused at the cap (or another problem), counted.
            let Some(j) = self.join(client).await? else {
                return Ok(());
            };
            if j.run_finished {
                return Ok(());
            }
            self.tally(|t| t.idle_sessions += 1);
            self.idle.push(IdleSession {
                run_id: j.run_id,
                session: j.session,
                opened: tokio::time::Instant::now(),
            });
        }
        self.problem(
            true,
            format!(
                "{} joins in a row were taken with --max-sessions {cap}",
                cap + 1
            ),
        );
        Ok(())
    }

    /// Waits out the idle timeout of the oldest idle sessions, then checks
    /// every idle session past it is gone.
    async fn check_expired(&mut self, client: &mut LearnerClient<Channel>) -> Result<(), Status> {
        let Some(timeout) = self.opts.idle_timeout else {
            self.idle.clear();
            return Ok(());
        };
        // The learner sweeps every timeout/4 (at most 5 s): allow that and
        // a margin.
        let grace = timeout + (timeout / 4).min(Duration::from_secs(5)) + Duration::from_secs(1);
        self.sleep(grace).await;
        if self.stopped() {
            return Ok(());
        }
        let now = tokio::time::Instant::now();
        let (due, young): (Vec<_>, Vec<_>) = std::mem::take(&mut self.idle)
            .into_iter()
            .partition(|s| now.duration_since(s.opened) >= grace);
        self.idle = young;
        for s in due {
            let reply = client
                .watch_parameters(v1::WatchRequest {
                    run_id: s.run_id.clone(),
                    session: s.session,
                })
                .await;
            match reply {
                Err(st) if st.code() == Code::NotFound => {
                    self.tally(|t| t.idle_sessions_expired += 1)
                }
                Err(st) if transport(&st) => return Err(st),
                Err(st) => self.problem(false, format!("watching an idle session: {st:?}")),
                Ok(_) => self.problem(
                    true,
                    format!(
                        "session {} was still open {:.1} s after its last call (idle timeout {:.1} s)",
                        s.session,
                        now.duration_since(s.opened).as_secs_f64(),
                        timeout.as_secs_f64()
                    ),
                ),
            }
        }
        Ok(())
    }
}

/// Aborts a task when dropped.
struct AbortOnDrop(tokio::task::JoinHandle<()>);

impl Drop for AbortOnDrop {
    fn drop(&mut self) {
        self.0.abort();
    }
}

/// How a real fragment is made implausible.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Spoil {
    /// One reward set to 1e30 (finite, far outside any env's range).
    HugeReward,
    /// One logit of an allowed action set to NaN.
    NanLogit,
    /// One logit of an allowed action set to −∞.
    NegInfLogit,
}

impl Spoil {
    /// A copy of `f` spoiled at a random place; `None` if `f` has no place
    /// for it (no rewards, no allowed action).
    ///
    /// ```
    /// use buridan_actor::misbehave::Spoil;
    /// use buridan_policy::Fragment;
    /// use rand::SeedableRng;
    /// let mut f = Fragment::with_capacity(0, 0, 1, 1, 1, 1, 1, 2);
    /// f.rewards = vec![0.0];
    /// f.masks = vec![1, 0];
    /// f.behaviour_logits = vec![0.1, 0.2];
    /// let mut rng = rand::rngs::StdRng::seed_from_u64(0);
    /// assert_eq!(Spoil::HugeReward.apply(&f, &mut rng).unwrap().rewards, [1e30]);
    /// let g = Spoil::NegInfLogit.apply(&f, &mut rng).unwrap();
    /// assert_eq!(g.behaviour_logits, [f32::NEG_INFINITY, 0.2]); // the allowed one
    /// ```
    pub fn apply(self, f: &Fragment, rng: &mut impl Rng) -> Option<Fragment> {
        let mut bad = f.clone();
        match self {
            Spoil::HugeReward => {
                if bad.rewards.is_empty() {
                    return None;
                }
                let k = rng.random_range(0..bad.rewards.len());
                bad.rewards[k] = 1e30;
            }
            Spoil::NanLogit | Spoil::NegInfLogit => {
                let allowed: Vec<usize> = (0..bad.masks.len().min(bad.behaviour_logits.len()))
                    .filter(|&i| bad.masks[i] != 0)
                    .collect();
                if allowed.is_empty() {
                    return None;
                }
                let k = allowed[rng.random_range(0..allowed.len())];
                bad.behaviour_logits[k] = if self == Spoil::NanLogit {
                    f32::NAN
                } else {
                    f32::NEG_INFINITY
                };
            }
        }
        Some(bad)
    }
}

/// `len` random bytes that decode neither as a `Fragment` nor as a
/// `JoinRequest` nor as a `WatchRequest`.
///
/// ```
/// use prost::Message;
/// use rand::SeedableRng;
/// let mut rng = rand::rngs::StdRng::seed_from_u64(1);
/// let b = buridan_actor::misbehave::undecodable_bytes(&mut rng, 64);
/// assert_eq!(b.len(), 64);
/// assert!(buridan_proto::v1::Fragment::decode(&b[..]).is_err());
/// ```
pub fn undecodable_bytes(rng: &mut impl Rng, len: usize) -> Vec<u8> {
    loop {
        let bytes: Vec<u8> = (0..len.max(8)).map(|_| rng.random()).collect();
        let undecodable = v1::Fragment::decode(&bytes[..]).is_err()
            && v1::JoinRequest::decode(&bytes[..]).is_err()
            && v1::WatchRequest::decode(&bytes[..]).is_err();
        if undecodable {
            return bytes;
        }
    }
}

/// Sends a `Vec<u8>` as the whole body of a request (gRPC framing intact,
/// so only the protobuf decode can fail), and hands back a reply's bytes
/// undecoded.
///
/// ```no_run
/// # async fn f(channel: tonic::transport::Channel) -> Result<(), tonic::Status> {
/// use buridan_actor::misbehave::RawCodec;
/// let mut grpc = tonic::client::Grpc::new(channel);
/// grpc.ready().await.map_err(|e| tonic::Status::unavailable(e.to_string()))?;
/// let path = "/buridan.v1.Learner/SubmitFragment".parse().expect("a gRPC path");
/// let refused = grpc.unary(tonic::Request::new(vec![0xff; 8]), path, RawCodec).await;
/// assert_eq!(refused.unwrap_err().code(), tonic::Code::InvalidArgument);
/// # Ok(())
/// # }
/// ```
#[derive(Debug, Default, Clone, Copy)]
pub struct RawCodec;

/// [`RawCodec`]'s encoder: the bytes as they are.
pub struct RawEncoder;
/// [`RawCodec`]'s decoder: the body's bytes as they are.
pub struct RawDecoder;

impl Encoder for RawEncoder {
    type Item = Vec<u8>;
    type Error = Status;
    fn encode(&mut self, item: Vec<u8>, dst: &mut EncodeBuf<'_>) -> Result<(), Status> {
        dst.put_slice(&item);
        Ok(())
    }
}

impl Decoder for RawDecoder {
    type Item = Vec<u8>;
    type Error = Status;
    fn decode(&mut self, src: &mut DecodeBuf<'_>) -> Result<Option<Vec<u8>>, Status> {
        let bytes = src.copy_to_bytes(src.remaining());
        Ok(Some(bytes.to_vec()))
    }
}

impl Codec for RawCodec {
    type Encode = Vec<u8>;
    type Decode = Vec<u8>;
    type Encoder = RawEncoder;
    type Decoder = RawDecoder;
    fn encoder(&mut self) -> RawEncoder {
        RawEncoder
    }
    fn decoder(&mut self) -> RawDecoder {
        RawDecoder
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tallies_add_up() {
        let t = MisbehaveTally {
            undecodable_sent: 2,
            undecodable_refused: 2,
            implausible_sent: 3,
            implausible_refused: 3,
            stale_sent: 1,
            stale_refused: 1,
            replays_sent: 1,
            replays_refused: 1,
            joins_refused_at_cap: 1,
            idle_sessions_expired: 4,
            ..MisbehaveTally::default()
        };
        assert_eq!((t.sent(), t.refused()), (7, 12));
    }

    #[test]
    fn random_bytes_never_decode() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        for _ in 0..200 {
            let b = undecodable_bytes(&mut rng, 16);
            assert!(v1::Fragment::decode(&b[..]).is_err());
            assert!(v1::JoinRequest::decode(&b[..]).is_err());
        }
    }
}
