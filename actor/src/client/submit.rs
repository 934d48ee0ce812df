//! Fragment submission: the observation encoding agreed with the learner,
//! one submission in flight beside the collection (off-policy), and the
//! booking of each reply.

use buridan_proto::convert::{fragment_to_message_encoded, WireTag};
use buridan_proto::v1;
use buridan_proto::v1::ObsEncoding;
use tonic::Status;

use super::{retryable, ActorError, ActorReport, Client, SessionEnd};

type SubmitResult = Result<tonic::Response<v1::SubmitReply>, Status>;

/// The observation encoding to send with: the one wanted if the run spec
/// lists it, else the cheaper packing it lists (codes, then LZ4), else raw
/// (every learner reads raw). Wanting raw always gets raw.
///
/// ```
/// use buridan_actor::client::obs_encoding_for;
/// use buridan_proto::v1::{ObsEncoding, RunSpec};
/// let none = RunSpec::default();
/// assert_eq!(obs_encoding_for(&none, ObsEncoding::Codes), ObsEncoding::Raw);
/// let lz4_only = RunSpec { obs_encodings: vec![ObsEncoding::Lz4 as i32], ..Default::default() };
/// assert_eq!(obs_encoding_for(&lz4_only, ObsEncoding::Codes), ObsEncoding::Lz4);
/// let both = RunSpec {
///     obs_encodings: vec![ObsEncoding::Codes as i32, ObsEncoding::Lz4 as i32],
///     ..Default::default()
/// };
/// assert_eq!(obs_encoding_for(&both, ObsEncoding::Lz4), ObsEncoding::Lz4);
/// assert_eq!(obs_encoding_for(&both, ObsEncoding::Codes), ObsEncoding::Codes);
/// assert_eq!(obs_encoding_for(&both, ObsEncoding::Raw), ObsEncoding::Raw);
/// ```
pub fn obs_encoding_for(run: &v1::RunSpec, wanted: ObsEncoding) -> ObsEncoding {
    if wanted == ObsEncoding::Raw {
        return ObsEncoding::Raw;
    }
    let listed = |e: ObsEncoding| run.obs_encodings.contains(&(e as i32));
    [wanted, ObsEncoding::Codes, ObsEncoding::Lz4]
        .into_iter()
        .find(|&e| listed(e))
        .unwrap_or(ObsEncoding::Raw)
}

/// Sends fragments, numbered per session. Off-policy runs keep one
/// submission in flight while the next fragment is collected (as the
/// in-process queue lets actors do), and encode it in that task too, beside
/// the collection; on-policy runs submit synchronously, since the reply may
/// say "wait".
pub(super) struct Submitter {
    client: Client,
    tag: WireTag,
    pipelined: bool,
    encoding: ObsEncoding,
    in_flight: Option<(u64, tokio::task::JoinHandle<SubmitResult>)>,
}

impl Submitter {
    /// A submitter for the session of `join`, whose checked run spec is
    /// `run`.
    pub(super) fn new(
        client: Client,
        join: &v1::JoinReply,
        run: &v1::RunSpec,
        wanted: ObsEncoding,
    ) -> Self {
        let encoding = obs_encoding_for(run, wanted);
        tracing::debug!(?encoding, "observation encoding");
        Self {
            client,
            tag: WireTag {
                run_id: join.run_id.clone(),
                session: join.session,
                seq: 0,
            },
            pipelined: !run.on_policy,
            encoding,
            in_flight: None,
        }
    }

    /// Submits `fragment` (after booking the previous one's reply, if
    /// pipelined); `Some(end)` if the session is over.
    pub(super) async fn submit(
        &mut self,
        fragment: buridan_policy::Fragment,
        report: &mut ActorReport,
        wait_after: &mut Option<u64>,
    ) -> Result<Option<SessionEnd>, ActorError> {
        let version = fragment.policy_version;
        self.tag.seq += 1;
        if let Some((v, previous)) = self.in_flight.take() {
            let result = previous.await.map_err(|_| ActorError::Panicked("submit"))?;
            if let Some(end) = on_reply(result, v, report, wait_after)? {
                return Ok(Some(end));
            }
        }
        let (tag, encoding) = (self.tag.clone(), self.encoding);
        if self.pipelined {
            let mut c = self.client.clone();
            let submit = tokio::spawn(async move {
                let message = fragment_to_message_encoded(fragment, &tag, encoding);
                c.submit_fragment(message).await
            });
            self.in_flight = Some((version, submit));
            Ok(None)
        } else {
            let message = fragment_to_message_encoded(fragment, &tag, encoding);
            let result = self.client.submit_fragment(message).await;
            on_reply(result, version, report, wait_after)
        }
    }
}

/// Books a submission's outcome; `Some(end)` if the session is over.
fn on_reply(
    result: SubmitResult,
    version: u64,
    report: &mut ActorReport,
    wait_after: &mut Option<u64>,
) -> Result<Option<SessionEnd>, ActorError> {
    match result {
        Ok(reply) => {
            let reply = reply.into_inner();
            if reply.run_finished {
                return Ok(Some(SessionEnd::Finished));
            }
            if reply.accepted {
                report.accepted += 1;
            } else {
                report.refused += 1;
                tracing::debug!(reason = %reply.reason, "fragment refused");
            }
            if reply.wait_for_next_version {
                *wait_after = Some(reply.learner_version.max(version));
            }
            Ok(None)
        }
        Err(source) if retryable(&source) => {
            report.lost += 1;
            Ok(Some(SessionEnd::Lost(ActorError::Rpc {
                call: "submit",
                source,
            })))
        }
        Err(s) => Err(ActorError::FragmentRefused(s)),
    }
}
