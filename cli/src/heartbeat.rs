//! Progress off a terminal: the progress bars hide themselves when stderr
//! is not a terminal (a log file, a pipe, a cluster's log collector), so a
//! watcher logs each bar's state through `tracing` every few seconds
//! instead: steps, rate, the bar's message (return, success) and the ETA.

use std::io::IsTerminal;
use std::time::Duration;

use buridan_study::figures::clock;
use indicatif::ProgressBar;

/// The `tracing` target of progress lines; `main` shows it at `info`.
pub const TARGET: &str = "progress";

/// Seconds between progress lines unless `BURIDAN_PROGRESS_SECS` says otherwise.
pub const DEFAULT_SECS: f64 = 5.0;

/// Points `bar` at a run of `len` steps of which `done` are done, so that
/// its rate and ETA count only the steps made from here: a run resumed
/// from a checkpoint would otherwise read its checkpoint's steps as done in
/// its first second ("561k/s, eta 5s" for a run at 2.5k steps/s).
///
/// ```
/// let bar = indicatif::ProgressBar::hidden();
/// buridan_cli::heartbeat::start_at(&bar, 4_000_000, 2_000_000);
/// std::thread::sleep(std::time::Duration::from_millis(20));
/// bar.set_position(2_000_100);
/// bar.tick();
/// assert!(bar.per_sec() < 1e5, "{}", bar.per_sec()); // 100 steps in ~20 ms
/// ```
pub fn start_at(bar: &ProgressBar, len: u64, done: u64) {
    bar.set_length(len);
    bar.set_position(done);
    // Record the position now (set_position is rate-limited), then
    // forget the jump.
    bar.tick();
    bar.reset_eta();
}

/// The time between two progress lines: `BURIDAN_PROGRESS_SECS` if it is a
/// positive number, else [`DEFAULT_SECS`].
pub fn interval() -> Duration {
    let secs = std::env::var("BURIDAN_PROGRESS_SECS")
        .ok()
        .and_then(|s| s.trim().parse::<f64>().ok())
        .filter(|s| *s > 0.0 && s.is_finite())
        .unwrap_or(DEFAULT_SECS);
    Duration::from_secs_f64(secs)
}

/// Logs `bar`'s state every [`interval`] while stderr is not a terminal,
/// until the bar finishes or is dropped (on a terminal the bar shows it).
pub fn watch(bar: &ProgressBar) {
    if std::io::stderr().is_terminal() {
        return;
    }
    let weak = bar.downgrade();
    let every = interval();
    std::thread::spawn(move || loop {
        std::thread::sleep(every);
        let Some(bar) = weak.upgrade() else { break };
        if bar.is_finished() {
            break;
        }
        tracing::info!(target: TARGET, "{}", line(&bar));
    });
}

/// One progress line: prefix, position of length (percent), rate, the
/// bar's message, elapsed time and ETA.
///
/// ```
/// let bar = indicatif::ProgressBar::hidden();
/// bar.set_length(200_000);
/// bar.set_position(50_000);
/// bar.set_prefix("impala ctde rm-2.1 n=4");
/// bar.set_message("success 12.5%");
/// let line = buridan_cli::heartbeat::line(&bar);
/// assert!(line.starts_with("impala ctde rm-2.1 n=4: 50k/200k (25%)"), "{line}");
/// assert!(line.contains("success 12.5%") && line.contains("eta"), "{line}");
/// ```
pub fn line(bar: &ProgressBar) -> String {
    let pos = bar.position();
    let len = bar.length().unwrap_or(0);
    let pct = if len > 0 {
        format!(" ({:.0}%)", 100.0 * pos as f64 / len as f64)
    } else {
        String::new()
    };
    let elapsed = bar.elapsed().as_secs_f64();
    // indicatif's estimate: over recent steps, so a resumed run's earlier
    // steps do not count.
    let (speed, eta) = speed_and_eta(pos, len, elapsed, bar.per_sec(), bar.eta().as_secs_f64());
    let prefix = bar.prefix();
    let message = bar.message();
    format!(
        "{}{}/{}{pct}, {speed}, {} elapsed, eta {eta}{}",
        if prefix.is_empty() {
            String::new()
        } else {
            format!("{}: ", prefix.trim())
        },
        buridan_study::figures::tick(pos as f64),
        buridan_study::figures::tick(len as f64),
        clock(elapsed),
        if message.is_empty() {
            String::new()
        } else {
            format!("; {}", message.trim())
        }
    )
}

/// The speed and ETA of a line: `pos` of `len` units after `elapsed`
/// seconds, at indicatif's recent `rate` (units/s) and `eta` (s).
///
/// Units of a second or more (env steps, episodes) use indicatif's
/// estimates over recent steps. Slow units (a study's jobs, minutes each)
/// use the average since the bar started: between two units the recent
/// rate decays towards zero and its ETA grows without bound.
///
/// ```
/// use buridan_cli::heartbeat::speed_and_eta;
/// assert_eq!(speed_and_eta(50_000, 200_000, 20.0, 25_000.0, 6.0), ("25k/s".into(), "6s".into()));
/// // One study job of two done after 30 s: the other takes about as long.
/// assert_eq!(speed_and_eta(1, 2, 30.0, 0.001, 500.0), ("30s each".into(), "30s".into()));
/// assert_eq!(speed_and_eta(0, 2, 30.0, 0.0, 0.0), ("0/s".into(), "-".into()));
/// ```
pub fn speed_and_eta(pos: u64, len: u64, elapsed: f64, rate: f64, eta: f64) -> (String, String) {
    let left = len.saturating_sub(pos);
    if rate >= 1.0 || pos == 0 {
        let eta = if pos > 0 && left > 0 && rate > 0.0 {
            clock(eta)
        } else {
            "-".into()
        };
        return (
            format!("{}/s", buridan_study::figures::tick(rate.round())),
            eta,
        );
    }
    let each = elapsed / pos as f64;
    let eta = if left > 0 {
        clock(each * left as f64)
    } else {
        "-".into()
    };
    (format!("{} each", clock(each)), eta)
}
