//! The soak from start to report: the learner, the actors and the
//! misbehaving client started, the kills and samples for `--minutes`, the
//! stop, the books, and the report in `--out`.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use buridan_actor::misbehave::{MisbehaveOptions, Misbehaver};
use buridan_study::figures::clock;
use indicatif::{ProgressBar, ProgressStyle};

use crate::actors::{ActorCommand, Actors, KillSchedule};
use crate::learner::Learner;
use crate::markdown::markdown;
use crate::sample::{Sample, Samples};
use crate::summary::{summarize, SoakSummary, Stopped};
use crate::{Host, SoakArgs, SoakError};

/// Creates `out`, unless an earlier soak is there (its CSV and run would be
/// appended to).
fn create_out_dir(out: &Path) -> Result<(), SoakError> {
    if out.join("soak.csv").exists() || out.join("run").exists() {
        return Err(SoakError::OutTaken(out.to_path_buf()));
    }
    std::fs::create_dir_all(out).map_err(SoakError::io(format!("creating {}", out.display())))
}

/// The `actor` executable: `--actor-exe`, or `actor` beside `learner_exe`.
fn find_actor_exe(args: &SoakArgs, learner_exe: &Path) -> Result<PathBuf, SoakError> {
    let actor_exe = args
        .actor_exe
        .clone()
        .unwrap_or_else(|| learner_exe.with_file_name("actor"));
    if !actor_exe.is_file() {
        return Err(SoakError::NoActor(actor_exe));
    }
    Ok(actor_exe)
}

/// The soak's progress bar, `total` long.
fn progress_bar(total: Duration, host: &Host) -> ProgressBar {
    let bar = ProgressBar::new(total.as_secs());
    bar.set_style(
        ProgressStyle::with_template("{prefix} [{bar:25}] {elapsed}/{len}s {msg}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar.set_prefix("soak");
    (host.watch)(&bar);
    bar
}

/// The misbehaving client, unless `--no-misbehave`.
fn start_misbehaver(
    args: &SoakArgs,
    url: &str,
    max_sessions: usize,
) -> Result<Option<Misbehaver>, SoakError> {
    if args.no_misbehave {
        return Ok(None);
    }
    let options = MisbehaveOptions {
        name: "soak-misbehaving".into(),
        max_sessions: Some(max_sessions),
        idle_timeout: Some(Duration::from_secs_f64(args.session_idle_timeout)),
        seed: args.seed,
        ..MisbehaveOptions::default()
    };
    Ok(Some(Misbehaver::spawn(url, options)?))
}

/// The soak proper, for `total`: actors killed and restarted, a sample
/// every `--sample-every` s. Why it ended early if the learner died.
fn soak_for(
    args: &SoakArgs,
    total: Duration,
    learner: &mut Learner,
    actors: &mut Actors,
    misbehaver: Option<&Misbehaver>,
    samples: &mut Samples,
    bar: &ProgressBar,
) -> Result<Option<String>, SoakError> {
    let end = Instant::now() + total;
    let mut kill_schedule = KillSchedule::new(args);
    let mut next_sample = Instant::now();
    while Instant::now() < end {
        std::thread::sleep(Duration::from_millis(100));
        if let Some(status) = learner.exit_status()? {
            return Ok(Some(format!(
                "the learner died after {} with {status}",
                clock(learner.seconds())
            )));
        }
        let now = Instant::now();
        bar.set_position(learner.started.elapsed().as_secs().min(total.as_secs()));
        actors.supervise(now, bar)?;
        kill_schedule.strike(now, actors, bar);
        if now >= next_sample {
            next_sample = now + Duration::from_secs_f64(args.sample_every);
            let s = samples.take(learner, actors, bar)?;
            bar.set_message(message(s, args.actors, misbehaver));
        }
    }
    Ok(None)
}

/// Stops the misbehaving client and the actors; unless the learner died
/// (`learner_died`), lets it drain, records a last sample, stops it with
/// SIGTERM and finds its checkpoint.
fn stop_soak(
    learner: &mut Learner,
    actors: &mut Actors,
    misbehaver: Option<Misbehaver>,
    samples: &mut Samples,
    bar: &ProgressBar,
    learner_died: Option<String>,
) -> Result<Stopped, SoakError> {
    let tally = misbehaver.map(Misbehaver::stop);
    actors.stop();
    bar.finish_and_clear();
    let mut checkpoint = None;
    let mut failures = Vec::new();
    match learner_died {
        Some(why) => failures.push(why),
        None => {
            learner.wait_until_still(&mut samples.last_scrape);
            let s = learner.sample(&samples.last_scrape, 0, actors.kills);
            samples.record(s)?;
            learner.terminate(&mut failures)?;
            checkpoint = learner.checkpoint();
            if checkpoint.is_none() {
                failures
                    .push("the learner wrote no checkpoint on SIGTERM (see learner.log)".into());
            }
        }
    }
    Ok(Stopped {
        seconds: learner.seconds(),
        tally,
        checkpoint,
        failures,
    })
}

/// Writes `soak.json`, `soak.png` and `soak.md` to `out`, and prints the
/// Markdown.
fn report(summary: &SoakSummary, samples: &[Sample], out: &Path) -> Result<(), SoakError> {
    let json = serde_json::to_string_pretty(summary)?;
    std::fs::write(out.join("soak.json"), json).map_err(SoakError::io("writing soak.json"))?;
    if let Err(e) = crate::png::draw(&out.join("soak.png"), samples, summary.target) {
        tracing::warn!("soak.png not drawn: {e}");
    }
    let md = markdown(summary);
    std::fs::write(out.join("soak.md"), &md).map_err(SoakError::io("writing soak.md"))?;
    println!("{md}");
    Ok(())
}

/// Runs a soak of `host`'s learner (`learner bench soak`); the summary if
/// every check passed, else [`SoakError::Failed`] with each failure.
pub fn run(args: &SoakArgs, host: &Host) -> Result<SoakSummary, SoakError> {
    args.validate()?;
    let out = &args.out;
    create_out_dir(out)?;
    let run_dir = out.join("run");
    let cfg = args.learner_config(&run_dir)?;
    let exe = &host.learner_exe;
    let actor_exe = find_actor_exe(args, exe)?;
    let max_sessions = args.max_sessions.unwrap_or(args.actors + 8);

    let mut learner = Learner::start(args, exe, &run_dir, max_sessions)?;
    learner.wait_until_serving()?;
    let actor_command = ActorCommand {
        exe: actor_exe,
        url: learner.url.clone(),
        out: out.clone(),
    };
    let mut actors = Actors::start(actor_command, args.actors)?;
    let misbehaver = start_misbehaver(args, &learner.url, max_sessions)?;

    let total = Duration::from_secs_f64(args.minutes * 60.0);
    let bar = progress_bar(total, host);
    let mut samples = Samples::create(out)?;
    let learner_died = soak_for(
        args,
        total,
        &mut learner,
        &mut actors,
        misbehaver.as_ref(),
        &mut samples,
        &bar,
    )?;
    let stopped = stop_soak(
        &mut learner,
        &mut actors,
        misbehaver,
        &mut samples,
        &bar,
        learner_died,
    )?;

    let summary = summarize(args, &cfg, &samples, &actors, stopped);
    report(&summary, &samples.rows, out)?;
    if !summary.failures.is_empty() {
        return Err(SoakError::Failed {
            failures: summary.failures,
            out: out.clone(),
        });
    }
    Ok(summary)
}

/// The progress bar's message for sample `s`.
fn message(s: &Sample, actors: usize, m: Option<&Misbehaver>) -> String {
    let mut text = format!(
        "rss {:.0} MiB, success {}, env steps {}, fragments accepted {} refused {} consumed {}, actors {}/{actors}, kills {}",
        s.rss_kib as f64 / 1024.0,
        s.success.map_or("–".into(), |v| format!("{:.1}%", 100.0 * v)),
        buridan_study::figures::tick(s.env_steps as f64),
        s.accepted,
        s.refused,
        s.consumed,
        s.actors_running,
        s.kills
    );
    if let Some(m) = m {
        let t = m.tally();
        text.push_str(&format!(
            ", misbehaving sent {} refused {} wrongly accepted {}",
            t.sent(),
            t.refused(),
            t.wrongly_accepted
        ));
    }
    text
}
