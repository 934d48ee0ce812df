//! What stops a run from outside the process: Ctrl-C, SIGTERM, a closed stdin.
//!
//! Each sets a shared flag that the training loop reads after every update
//! (`Run::interrupt_on`); the run then checkpoints and returns
//! `TrainError::Interrupted`, so `--resume` continues where it stopped.
//! A supervisor (Kubernetes, systemd, a study's `kill`) sends SIGTERM and
//! waits: without this, the newest periodic checkpoint would be all that
//! is left of the run.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Exit status after a second Ctrl-C or SIGTERM (128 + SIGINT, as shells report).
pub const FORCED_EXIT: i32 = 130;

/// Sets `flag` on the first Ctrl-C or SIGTERM, so the run checkpoints after
/// its current update and stops; a second one exits at once with
/// [`FORCED_EXIT`] (an update that takes too long to wait for).
///
/// ```no_run
/// use std::sync::{atomic::AtomicBool, Arc};
/// let stop = Arc::new(AtomicBool::new(false));
/// buridan_cli::signals::watch_signals(stop.clone());
/// // ... hand `stop` to Run::interrupt_on ...
/// ```
pub fn watch_signals(flag: Arc<AtomicBool>) {
    std::thread::spawn(move || {
        let Ok(rt) = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
        else {
            tracing::warn!("no signal handler: Ctrl-C and SIGTERM stop without a checkpoint");
            return;
        };
        rt.block_on(async {
            buridan_serving::shutdown_signal().await;
            tracing::warn!(
                "stopping: checkpointing after the current update (again to stop at once)"
            );
            flag.store(true, Ordering::SeqCst);
            buridan_serving::shutdown_signal().await;
            tracing::warn!("stopped at once: no checkpoint of the current update");
            std::process::exit(FORCED_EXIT);
        });
    });
}

/// Sets `flag` when stdin reaches its end: a parent process that spawned
/// this one with a pipe stops it by closing the pipe (or by dying).
pub fn stop_when_stdin_closes(flag: Arc<AtomicBool>) {
    std::thread::spawn(move || {
        let _ = std::io::copy(&mut std::io::stdin().lock(), &mut std::io::sink());
        tracing::info!("stdin closed: stopping with a checkpoint");
        flag.store(true, Ordering::SeqCst);
    });
}
