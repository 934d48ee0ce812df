//! `learner train|serve --dashboard ADDR`: the live dashboard
//! (`buridan-dashboard`) fed by the run. A [`Progress`] wrapper passes every
//! metrics row and exchange status to the board, and evaluates each new
//! checkpoint in the background (a few seeded episodes through the
//! evaluation harness), showing the result and the replay of one episode
//! (the first failed one, else the first).

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use buridan_dashboard::{Board, Running, Status};
use buridan_env::{Map, Rules, Starts};
use buridan_eval::replay::{record_episode, Warmup};
use buridan_eval::{evaluate, EvalSpec};
use buridan_learner::train::{ExchangeStatus, MetricsRow, Progress, Summary, TrainConfig};
use buridan_mapf::Limits;
use buridan_policy::ActMode;
use buridan_render::{gif_bytes, GifOptions};
use serde_json::json;

/// The dashboard's options of `learner train` and `learner serve`.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct DashboardArgs {
    /// Serve the live dashboard on this address (e.g. 127.0.0.1:8080; port
    /// 0 picks a free one, printed at the start).
    #[arg(long, value_name = "ADDR")]
    pub dashboard: Option<SocketAddr>,
    /// Episodes of the evaluation of each new checkpoint shown on the
    /// dashboard (seed 42, the run's first layout; 0: none).
    #[arg(long, default_value_t = 20, value_name = "N")]
    pub dashboard_eval: usize,
    /// Keep serving the dashboard this many seconds after the run ends.
    #[arg(long, default_value_t = 0.0, value_name = "SECS")]
    pub dashboard_linger: f64,
}

/// A dashboard being served, with the board the run writes to.
pub struct Live {
    board: Board,
    running: Running,
    linger: f64,
}

impl Live {
    /// Starts the dashboard if `args` asks for one, and says where it is.
    pub fn start(args: &DashboardArgs) -> Result<Option<Live>> {
        let Some(addr) = args.dashboard else {
            return Ok(None);
        };
        if !(args.dashboard_linger >= 0.0 && args.dashboard_linger.is_finite()) {
            anyhow::bail!("--dashboard-linger must be a number of seconds, 0 or more");
        }
        let board = Board::default();
        let running = buridan_dashboard::serve(addr, board.clone())
            .with_context(|| format!("--dashboard {addr}"))?;
        let url = format!("http://{}", running.addr());
        tracing::info!(%url, "dashboard");
        eprintln!("dashboard at {url}");
        Ok(Some(Live {
            board,
            running,
            linger: args.dashboard_linger,
        }))
    }

    /// The address served.
    pub fn addr(&self) -> SocketAddr {
        self.running.addr()
    }

    /// Keeps serving for the linger time (or until `stop` is set: a
    /// signal), then stops.
    pub fn finish(self, stop: Option<&AtomicBool>) {
        if self.linger > 0.0 {
            eprintln!(
                "dashboard at http://{} for {} s more",
                self.running.addr(),
                self.linger
            );
            let end = Instant::now() + Duration::from_secs_f64(self.linger);
            while Instant::now() < end && !stop.is_some_and(|s| s.load(Ordering::SeqCst)) {
                std::thread::sleep(
                    Duration::from_millis(100).min(end.saturating_duration_since(Instant::now())),
                );
            }
        }
    }
}

/// Checkpoints waiting for evaluation (the newest only) and whether the
/// run is over.
#[derive(Default)]
struct Queue {
    next: Option<PathBuf>,
    closed: bool,
}

/// A [`Progress`] that shows the run on a dashboard as well as on `inner`.
pub struct DashboardProgress<'a> {
    inner: &'a mut dyn Progress,
    board: Board,
    episodes: usize,
    queue: Arc<(Mutex<Queue>, Condvar)>,
    evaluator: Option<JoinHandle<()>>,
}

impl<'a> DashboardProgress<'a> {
    /// Shows the run on `live`'s board; evaluates checkpoints on
    /// `episodes` episodes (0: none).
    pub fn new(inner: &'a mut dyn Progress, live: &Live, episodes: usize) -> Self {
        Self {
            inner,
            board: live.board.clone(),
            episodes,
            queue: Arc::default(),
            evaluator: None,
        }
    }

    /// Closes the queue and waits for the evaluator: after the checkpoint
    /// still queued if `drain`, else after the evaluation under way (a
    /// stopped or failed run does not wait for one more).
    fn close(&mut self, drain: bool) {
        {
            let (lock, cv) = &*self.queue;
            let mut q = lock.lock().unwrap_or_else(|e| e.into_inner());
            q.closed = true;
            if !drain {
                q.next = None;
            }
            cv.notify_all();
        }
        if let Some(t) = self.evaluator.take() {
            let _ = t.join();
        }
    }
}

impl Drop for DashboardProgress<'_> {
    fn drop(&mut self) {
        self.close(false);
    }
}

impl Progress for DashboardProgress<'_> {
    fn on_start(&mut self, cfg: &TrainConfig, total_steps: u64, env_steps: u64) {
        self.inner.on_start(cfg, total_steps, env_steps);
        self.board.set_run(json!({
            "algo": cfg.algorithm.algo().to_string(),
            "mode": format!("{:?}", cfg.mode).to_lowercase(),
            "map": cfg.map_label(),
            "agents": cfg.agents,
            "seed": cfg.run.seed,
            "steps": total_steps,
        }));
        if cfg.task.is_plant() && self.episodes > 0 {
            // The evaluation plays grid episodes and draws grid replays.
            tracing::info!(
                plant = %cfg.map_label(),
                "the dashboard shows training only: its checkpoint evaluation plays grid layouts"
            );
        }
        if self.episodes > 0 && self.evaluator.is_none() && !cfg.task.is_plant() {
            // The first layout of a mixture.
            let job = EvalJob {
                map: cfg.layouts()[0].name.clone(),
                agents: cfg.agents,
                starts: cfg.starts,
                t_max: cfg.t_max,
                episodes: self.episodes,
            };
            let (queue, board) = (self.queue.clone(), self.board.clone());
            self.evaluator = Some(std::thread::spawn(move || job.serve(&queue, &board)));
        }
    }

    fn on_update(&mut self, row: &MetricsRow) {
        self.inner.on_update(row);
        self.board
            .push_row(serde_json::to_value(row).expect("a metrics row serialises"));
    }

    fn on_exchange(&mut self, status: &ExchangeStatus) {
        self.inner.on_exchange(status);
        self.board.set_status(Status {
            connected_actors: status.connected_actors,
            queue_depth: status.queue_depth,
            fragments: status.fragments.iter().cloned().collect(),
        });
    }

    fn on_stopped(&mut self, reason: buridan_learner::train::StopReason) {
        self.inner.on_stopped(reason);
    }

    fn on_checkpoint(&mut self, dir: &Path) {
        self.inner.on_checkpoint(dir);
        let (lock, cv) = &*self.queue;
        lock.lock().unwrap_or_else(|e| e.into_inner()).next = Some(dir.to_path_buf());
        cv.notify_all();
    }

    fn on_finish(&mut self, summary: &Summary) {
        // The final checkpoint's evaluation is shown before the run says it is done.
        self.close(true);
        self.inner.on_finish(summary);
    }
}

/// What the background evaluation plays.
struct EvalJob {
    map: String,
    agents: usize,
    starts: Starts,
    t_max: u32,
    episodes: usize,
}

impl EvalJob {
    /// Evaluates the newest queued checkpoint until the queue closes (and
    /// is empty).
    fn serve(&self, queue: &(Mutex<Queue>, Condvar), board: &Board) {
        let (lock, cv) = queue;
        loop {
            let dir = {
                let mut q = lock.lock().unwrap_or_else(|e| e.into_inner());
                while q.next.is_none() && !q.closed {
                    q = cv.wait(q).unwrap_or_else(|e| e.into_inner());
                }
                match q.next.take() {
                    Some(dir) => dir,
                    None => return,
                }
            };
            if let Err(e) = self.evaluate(&dir, board) {
                tracing::warn!(checkpoint = %dir.display(), error = format!("{e:#}"), "dashboard evaluation");
            }
        }
    }

    fn evaluate(&self, dir: &Path, board: &Board) -> Result<()> {
        const SEED: u64 = 42;
        let map = Arc::new(Map::load(&self.map)?);
        let make = buridan_eval::by_name::controller_factory(
            &format!("checkpoint:{}", dir.display()),
            self.agents,
            SEED,
            Limits::default(),
            ActMode::Greedy,
            Rules::Thesis,
        )?;
        let spec = EvalSpec {
            agents: self.agents,
            episodes: self.episodes,
            seed: SEED,
            starts: self.starts,
            t_max: self.t_max,
            jobs: 1,
            // The env's thesis rules: this caller does not choose a rule set yet.
            ..EvalSpec::default()
        };
        let report = evaluate(&map, &spec, &*make, &|_| {})?;
        let mut eval = serde_json::to_value(&report.summary)?;
        let name = dir.file_name().map_or_else(
            || dir.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        );
        eval["checkpoint"] = json!(name);
        board.set_eval(eval);
        let shown = report
            .records
            .iter()
            .find(|r| !r.success && r.gave_up.is_none())
            .unwrap_or(&report.records[0]);
        let trace = record_episode(&map, &spec, &*make, shown.episode, Warmup::Fresh)?;
        let gif = gif_bytes(&trace, &GifOptions::default())?;
        let r = &trace.record;
        board.set_replay(
            gif,
            format!(
                "{name}: episode {} of seed {SEED} on {}, {} agents — {} at t = {}{}",
                shown.episode,
                map.name,
                self.agents,
                if r.success { "solved" } else { "failed" },
                r.timesteps,
                match r.deadlocked_agents {
                    0 => String::new(),
                    1 => ", 1 agent deadlocked".into(),
                    n => format!(", {n} agents deadlocked"),
                }
            ),
        );
        Ok(())
    }
}
