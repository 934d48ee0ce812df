//! The actor processes and their supervisor (random SIGKILL, restart), and
//! the kills' schedule.

use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use indicatif::ProgressBar;

use crate::child::{kill_and_reap, log_file};
use crate::dice::Dice;
use crate::{SoakArgs, SoakError, TARGET};

/// An actor slot: its process, or when it is due to restart.
pub(crate) struct Slot {
    pub(crate) child: Option<Child>,
    pub(crate) restart_at: Option<Instant>,
}

/// How to start an actor.
pub(crate) struct ActorCommand {
    pub(crate) exe: PathBuf,
    /// The learner's URL.
    pub(crate) url: String,
    /// Where the actors' logs go.
    pub(crate) out: PathBuf,
}

impl ActorCommand {
    /// Starts actor `k`, appending to its log.
    pub(crate) fn spawn(&self, k: usize) -> Result<Child, SoakError> {
        let (stdout, stderr) = log_file(&self.out, &format!("actor-{k}.log"))?;
        Command::new(&self.exe)
            .arg("--connect")
            .arg(&self.url)
            .arg("--name")
            .arg(format!("soak-actor-{k}"))
            .stdin(Stdio::null())
            .stdout(stdout)
            .stderr(stderr)
            .spawn()
            .map_err(SoakError::io(format!("starting {}", self.exe.display())))
    }
}

/// The actor processes, one per slot, each restarted when it goes; the
/// tally of kills, restarts and exits.
pub(crate) struct Actors {
    pub(crate) command: ActorCommand,
    pub(crate) slots: Vec<Slot>,
    pub(crate) kills: u64,
    pub(crate) restarts: u64,
    pub(crate) exits: u64,
}

impl Actors {
    /// Starts `n` actors.
    pub(crate) fn start(command: ActorCommand, n: usize) -> Result<Self, SoakError> {
        let slots = (0..n)
            .map(|k| {
                Ok(Slot {
                    child: Some(command.spawn(k)?),
                    restart_at: None,
                })
            })
            .collect::<Result<_, SoakError>>()?;
        Ok(Self {
            command,
            slots,
            kills: 0,
            restarts: 0,
            exits: 0,
        })
    }

    /// The slots with an actor running now.
    pub(crate) fn running(&self) -> impl Iterator<Item = usize> + '_ {
        self.slots
            .iter()
            .enumerate()
            .filter(|(_, slot)| slot.child.is_some())
            .map(|(k, _)| k)
    }

    /// Notices actors that exited on their own (restarted a second later)
    /// and restarts those that are due.
    pub(crate) fn supervise(&mut self, now: Instant, bar: &ProgressBar) -> Result<(), SoakError> {
        for (k, slot) in self.slots.iter_mut().enumerate() {
            if let Some(child) = &mut slot.child {
                let exited = child
                    .try_wait()
                    .map_err(SoakError::io(format!("watching actor {k}")))?;
                if let Some(status) = exited {
                    self.exits += 1;
                    bar.suspend(|| tracing::warn!(target: TARGET, actor = k, %status, "soak: actor exited on its own; restarting"));
                    slot.child = None;
                    slot.restart_at = Some(now + Duration::from_secs(1));
                }
            }
            if slot.restart_at.is_some_and(|t| now >= t) {
                slot.child = Some(self.command.spawn(k)?);
                slot.restart_at = None;
                self.restarts += 1;
                let restarts = self.restarts;
                bar.suspend(
                    || tracing::info!(target: TARGET, actor = k, restarts, "soak: actor restarted"),
                );
            }
        }
        Ok(())
    }

    /// SIGKILLs a running actor picked by `dice` and restarts it within
    /// `restart_within` seconds (uniform from a tenth of it).
    pub(crate) fn kill_one(
        &mut self,
        dice: &mut Dice,
        restart_within: f64,
        now: Instant,
        bar: &ProgressBar,
    ) {
        let running: Vec<usize> = self.running().collect();
        if running.is_empty() {
            return;
        }
        let k = running[(dice.next() % running.len() as u64) as usize];
        if let Some(mut child) = self.slots[k].child.take() {
            kill_and_reap(&mut child);
        }
        self.kills += 1;
        let wait = restart_within * (0.1 + 0.9 * dice.unit());
        self.slots[k].restart_at = Some(now + Duration::from_secs_f64(wait));
        let kills = self.kills;
        bar.suspend(|| tracing::info!(target: TARGET, actor = k, kills, restart_in_s = format!("{wait:.1}"), "soak: actor killed (SIGKILL)"));
    }

    /// Kills them all, for good.
    pub(crate) fn stop(&mut self) {
        for slot in &mut self.slots {
            if let Some(mut child) = slot.child.take() {
                kill_and_reap(&mut child);
            }
        }
    }
}

/// When the next actor is killed: exponential gaps with mean
/// `--kill-every`, drawn from dice seeded by `--seed`.
pub(crate) struct KillSchedule {
    pub(crate) dice: Dice,
    pub(crate) next: Instant,
    pub(crate) mean_s: f64,
    pub(crate) restart_within: f64,
}

impl KillSchedule {
    pub(crate) fn new(args: &SoakArgs) -> Self {
        let mut dice = Dice(args.seed ^ 0x50A4);
        let next = Instant::now() + Duration::from_secs_f64(dice.exp(args.kill_every));
        Self {
            dice,
            next,
            mean_s: args.kill_every,
            restart_within: args.restart_within,
        }
    }

    /// Kills an actor if one is due by `now`.
    pub(crate) fn strike(&mut self, now: Instant, actors: &mut Actors, bar: &ProgressBar) {
        if now < self.next {
            return;
        }
        actors.kill_one(&mut self.dice, self.restart_within, now, bar);
        self.next = now + Duration::from_secs_f64(self.dice.exp(self.mean_s));
    }
}
