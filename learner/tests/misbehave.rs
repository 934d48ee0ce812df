//! The misbehaving client of `learner bench soak`
//! ([`buridan_actor::misbehave`]) against a real `learner serve` on
//! loopback TCP, with one well-behaved actor training beside it: every
//! kind of misbehaviour is sent and refused with the expected status, and
//! nothing it sends is taken.

use std::time::{Duration, Instant};

use buridan_actor::client::{run as run_actor, url_connector, ActorOptions};
use buridan_actor::misbehave::{MisbehaveOptions, Misbehaver};
use buridan_learner::serve::SessionLimits;
use buridan_learner::train::{Algorithm, ImpalaConfig, RunConfig, Task, TrainConfig};

mod support;
use support::Learner;

#[test]
fn every_misbehaviour_is_refused_with_the_expected_status() {
    // IMPALA, one 40-step fragment per update: the learner soon runs past
    // the misbehaving client's first fragment (lag 8), so it replays it.
    let cfg = TrainConfig {
        task: Task::Grid("rm-1.1".into()),
        agents: 2,
        starts: buridan_env::Starts::Fixed,
        algorithm: Algorithm::Impala(ImpalaConfig {
            train_batch: 40,
            ..ImpalaConfig::default()
        }),
        run: RunConfig {
            steps: 10_000_000,
            envs_per_actor: 2,
            fragment_len: 20,
            ..RunConfig::default()
        },
        ..TrainConfig::default()
    };
    let limits = SessionLimits {
        idle_timeout: Duration::from_millis(400),
        max_sessions: 6,
    };
    let learner = Learner::serve(cfg, limits);
    let url = learner.url();

    // A well-behaved actor, so that the policy version moves on (left
    // running: it retries until the test process ends).
    let connector = url_connector(&url, None).unwrap();
    std::thread::spawn(move || {
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        let _ = rt.block_on(run_actor(
            connector,
            ActorOptions {
                name: "good".into(),
                ..ActorOptions::default()
            },
        ));
    });

    let m = Misbehaver::spawn(
        &url,
        MisbehaveOptions {
            max_sessions: Some(limits.max_sessions),
            idle_timeout: Some(limits.idle_timeout),
            probe_every: 2,
            pause: Duration::from_millis(100),
            ..MisbehaveOptions::default()
        },
    )
    .unwrap();
    let deadline = Instant::now() + Duration::from_secs(120);
    loop {
        let t = m.tally();
        let done = t.rounds >= 4 && t.replays_sent >= 1 && t.idle_sessions_expired >= 1;
        if done || Instant::now() > deadline {
            break;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    let t = m.stop();
    drop(learner);

    assert_eq!(
        (t.wrongly_accepted, t.unexpected),
        (0, 0),
        "{t:?}: {}",
        t.last_problem
    );
    assert!(t.rounds >= 4, "{t:?}");
    assert!(
        t.undecodable_sent > 0 && t.undecodable_refused == t.undecodable_sent,
        "{t:?}"
    );
    assert!(
        t.implausible_sent > 0 && t.implausible_refused == t.implausible_sent,
        "{t:?}"
    );
    assert!(t.stale_sent > 0 && t.stale_refused == t.stale_sent, "{t:?}");
    assert!(
        t.replays_sent > 0 && t.replays_refused == t.replays_sent,
        "{t:?}"
    );
    assert!(t.joins_refused_at_cap > 0, "the cap was probed: {t:?}");
    assert!(t.idle_sessions_expired > 0, "idle sessions expired: {t:?}");
}
