//! Population-based training's record in `study.json`: the rounds done,
//! each member's hyperparameters and result per round, where its next round
//! starts, and the lineage — who copied whom after which round, continuing
//! with which values. From it: `pbt.csv` and the best member's
//! hyperparameter schedule (`pbt-schedule.csv`).

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::overrides::Overrides;
use crate::state::{trial_dir, StudyState};

/// PBT's part of a study state.
///
/// ```
/// let p = buridan_study::lineage::PbtState::new(4);
/// assert_eq!((p.rounds_done, p.members.len()), (0, 4));
/// ```
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct PbtState {
    /// Rounds the whole population has finished, exploit-and-explore included.
    pub rounds_done: u32,
    /// One per member, index = trial id.
    pub members: Vec<PbtMember>,
    /// Every exploit, in order.
    pub lineage: Vec<Exploitation>,
}

/// One member's progress through the rounds.
///
/// ```
/// let m = buridan_study::lineage::PbtMember::default();
/// assert!(m.start_from.is_none());
/// ```
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct PbtMember {
    /// Rounds it has finished.
    pub rounds: u32,
    /// Rounds it has started: `rounds + 1` while a round runs or after it
    /// was cut, so the round resumes from its own checkpoint.
    pub started: u32,
    /// Its hyperparameters in each round it started (index = round).
    pub schedule: Vec<Overrides>,
    /// Env steps at the end of each finished round.
    pub steps: Vec<u64>,
    /// Objective key at the end of each finished round (`None`: no episode yet).
    pub scores: Vec<Option<f64>>,
    /// The run directory (relative to the study) its next round starts
    /// from: its own last round's, or that of the member it exploited.
    pub start_from: Option<PathBuf>,
}

/// One exploit: after round `round`, `trial` continued from `source`'s
/// checkpoint with `overrides`.
///
/// ```
/// let e = buridan_study::lineage::Exploitation {
///     round: 2, step: 30_000, trial: 3, source: 0,
///     trial_score: Some(0.1), source_score: Some(0.8), overrides: Default::default(),
/// };
/// assert_eq!(e.source, 0);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Exploitation {
    /// The round after which it happened (0-based).
    pub round: u32,
    /// Env steps of the copied checkpoint.
    pub step: u64,
    /// The member that copied.
    pub trial: u64,
    /// The member it copied.
    pub source: u64,
    /// The copier's score at the end of the round.
    pub trial_score: Option<f64>,
    /// The source's score at the end of the round.
    pub source_score: Option<f64>,
    /// The perturbed hyperparameters the copier continues with.
    pub overrides: Overrides,
}

/// One round of a schedule: from `start_step`, the weights that end up in
/// the final policy trained in `member`'s run with `overrides`.
///
/// ```
/// let s = buridan_study::lineage::ScheduleStep { round: 0, start_step: 0, member: 1, overrides: Default::default() };
/// assert_eq!(s.member, 1);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScheduleStep {
    /// The round.
    pub round: u32,
    /// Env steps of the checkpoint the round started from.
    pub start_step: u64,
    /// Whose run trained the weights in this round.
    pub member: u64,
    /// With which hyperparameters.
    pub overrides: Overrides,
}

/// The run directory of `trial`'s round `round`, relative to the study.
///
/// ```
/// let d = buridan_study::lineage::round_dir(3, 12);
/// assert_eq!(d.to_str(), Some("trials/0003/round-012"));
/// ```
pub fn round_dir(trial: u64, round: u32) -> PathBuf {
    trial_dir(trial).join(format!("round-{round:03}"))
}

impl PbtState {
    /// A state for `population` members, before the first round.
    ///
    /// ```
    /// assert!(buridan_study::lineage::PbtState::new(2).lineage.is_empty());
    /// ```
    pub fn new(population: usize) -> PbtState {
        PbtState {
            rounds_done: 0,
            members: vec![PbtMember::default(); population],
            lineage: Vec::new(),
        }
    }

    /// The hyperparameter schedule that produced `member`'s final weights:
    /// following its lineage back, for each round it finished, whose run
    /// trained the weights and with which values.
    ///
    /// ```
    /// use buridan_study::lineage::{Exploitation, PbtMember, PbtState};
    /// let lr = |x: f64| -> buridan_study::Overrides { [("lr".to_string(), toml::Value::Float(x))].into() };
    /// let member = |a: f64, b: f64| PbtMember {
    ///     rounds: 2, started: 2, schedule: vec![lr(a), lr(b)], steps: vec![10, 20],
    ///     scores: vec![Some(a), Some(b)], start_from: None,
    /// };
    /// let mut p = PbtState::new(0);
    /// p.members = vec![member(0.1, 0.1), member(0.9, 0.7)];
    /// // After round 0, member 0 copied member 1 and went on with lr 0.7.
    /// p.lineage.push(Exploitation { round: 0, step: 10, trial: 0, source: 1, trial_score: None, source_score: None, overrides: lr(0.7) });
    /// p.members[0].schedule[1] = lr(0.7);
    /// let s = p.schedule(0);
    /// assert_eq!((s[0].member, s[1].member), (1, 0));
    /// assert_eq!((s[0].overrides["lr"].as_float(), s[1].start_step), (Some(0.9), 10));
    /// ```
    pub fn schedule(&self, member: u64) -> Vec<ScheduleStep> {
        let Some(last) = self.members.get(member as usize) else {
            return Vec::new();
        };
        let rounds = last.rounds;
        let mut holders = vec![member; rounds as usize];
        let mut m = member;
        for r in (0..rounds).rev() {
            holders[r as usize] = m;
            if r > 0 {
                if let Some(e) = self
                    .lineage
                    .iter()
                    .find(|e| e.round == r - 1 && e.trial == m)
                {
                    m = e.source;
                }
            }
        }
        holders
            .iter()
            .enumerate()
            .map(|(r, &h)| {
                let start_step = match r {
                    0 => 0,
                    _ => self.members[holders[r - 1] as usize].steps[r - 1],
                };
                ScheduleStep {
                    round: r as u32,
                    start_step,
                    member: h,
                    overrides: self.members[h as usize].schedule[r].clone(),
                }
            })
            .collect()
    }
}

fn keys(state: &StudyState) -> Vec<&str> {
    state
        .config
        .space
        .params()
        .iter()
        .map(|p| p.key.as_str())
        .collect()
}

fn finish(w: csv::Writer<Vec<u8>>) -> String {
    w.into_inner()
        .ok()
        .and_then(|b| String::from_utf8(b).ok())
        .unwrap_or_default()
}

fn opt(x: Option<f64>) -> String {
    x.map(|v| v.to_string()).unwrap_or_default()
}

fn values(keys: &[&str], overrides: &Overrides) -> Vec<String> {
    keys.iter()
        .map(|k| overrides.get(*k).map(|v| v.to_string()).unwrap_or_default())
        .collect()
}

/// The lineage as CSV (`pbt.csv`): one row per exploit — round, step, who
/// copied whom, both scores, and the copier's new values; `None` for a
/// study without PBT.
///
/// ```
/// # let cfg = buridan_study::StudyConfig::from_toml_str("[study]\nname = \"x\"\nsteps_per_trial = 10\nparallel = 2\n[study.scheduler]\nkind = \"pbt\"\ninterval_steps = 5\n[space]\nlr = { uniform = [0, 1] }").unwrap();
/// let mut state = buridan_study::state::StudyState::new(&cfg);
/// assert!(buridan_study::lineage::lineage_csv(&state).is_none());
/// state.pbt = Some(buridan_study::lineage::PbtState::new(2));
/// assert_eq!(buridan_study::lineage::lineage_csv(&state).unwrap(), "round,step,trial,source,trial_score,source_score,lr\n");
/// ```
pub fn lineage_csv(state: &StudyState) -> Option<String> {
    let pbt = state.pbt.as_ref()?;
    let keys = keys(state);
    let mut w = csv::Writer::from_writer(Vec::new());
    let mut header = vec![
        "round",
        "step",
        "trial",
        "source",
        "trial_score",
        "source_score",
    ];
    header.extend(&keys);
    let _ = w.write_record(&header);
    for e in &pbt.lineage {
        let mut row = vec![
            e.round.to_string(),
            e.step.to_string(),
            e.trial.to_string(),
            e.source.to_string(),
            opt(e.trial_score),
            opt(e.source_score),
        ];
        row.extend(values(&keys, &e.overrides));
        let _ = w.write_record(&row);
    }
    Some(finish(w))
}

/// The best member's hyperparameter schedule as CSV (`pbt-schedule.csv`):
/// one row per round — round, start step, whose run, values; `None`
/// without PBT or before a member has finished.
///
/// ```
/// # let cfg = buridan_study::StudyConfig::from_toml_str("[study]\nname = \"x\"\nsteps_per_trial = 10\nparallel = 2\n[study.scheduler]\nkind = \"pbt\"\ninterval_steps = 5\n[space]\nlr = { uniform = [0, 1] }").unwrap();
/// let state = buridan_study::state::StudyState::new(&cfg);
/// assert!(buridan_study::lineage::schedule_csv(&state).is_none());
/// ```
pub fn schedule_csv(state: &StudyState) -> Option<String> {
    let pbt = state.pbt.as_ref()?;
    let best = state.best()?;
    let keys = keys(state);
    let mut w = csv::Writer::from_writer(Vec::new());
    let mut header = vec!["round", "start_step", "member"];
    header.extend(&keys);
    let _ = w.write_record(&header);
    for s in pbt.schedule(best.id) {
        let mut row = vec![
            s.round.to_string(),
            s.start_step.to_string(),
            s.member.to_string(),
        ];
        row.extend(values(&keys, &s.overrides));
        let _ = w.write_record(&row);
    }
    Some(finish(w))
}
