//! What a plant evaluation reports: one record per episode, the summary
//! over them, the files written and the line printed.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use buridan_plant::{Kpis, Plant};
use serde::Serialize;

use super::PlantEvalSpec;
use crate::output::{io, OutputError};
use crate::plant_figures::{write_timeline, write_track_usage, Timeline, TrackUsage};

/// One evaluated plant episode: a row of `episodes.csv`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlantEpisodeRecord {
    /// Episode index.
    pub episode: u64,
    /// Steps taken (T_max: plant episodes only truncate).
    pub steps: u32,
    /// Finished products delivered to the sink.
    pub deliveries: u32,
    /// Deliveries per simulated hour.
    pub throughput_per_hour: f64,
    /// Collisions (drives into an oncoming AGV).
    pub collisions: u32,
    /// Moves cut short by another AGV (collisions included).
    pub blocked_moves: u32,
    /// Deadlocks: cycles of mutually waiting AGVs that lasted long enough.
    pub deadlocks: u32,
    /// Steps with a deadlock in progress.
    pub deadlock_steps: u32,
    /// Unit utilisation averaged over the units.
    pub utilisation: f64,
    /// Each unit's utilisation (A, B), space-separated.
    #[serde(serialize_with = "space_separated")]
    pub unit_utilisation: Vec<f64>,
    /// Mean seconds from a product's creation to its delivery (empty
    /// without deliveries).
    pub lead_time: Option<f64>,
    /// Episode reward summed over AGVs.
    pub reward: f32,
    /// Episode reward per AGV (the sum over AGVs divided by their number).
    pub reward_per_agent: f64,
    /// Time spent in the controller, milliseconds.
    pub compute_ms: f64,
}

fn space_separated<S: serde::Serializer>(values: &[f64], s: S) -> Result<S::Ok, S::Error> {
    let text = values
        .iter()
        .map(|v| format!("{v:.4}"))
        .collect::<Vec<_>>()
        .join(" ");
    s.serialize_str(&text)
}

impl PlantEpisodeRecord {
    /// The row of an episode with `agents` AGVs that ended with `kpis`.
    pub fn new(kpis: &Kpis, agents: usize, compute_ms: f64) -> Self {
        let units = &kpis.unit_utilisation;
        Self {
            episode: kpis.episode,
            steps: kpis.steps,
            deliveries: kpis.deliveries,
            throughput_per_hour: kpis.throughput_per_hour,
            collisions: kpis.collisions,
            blocked_moves: kpis.blocked_moves,
            deadlocks: kpis.deadlock_events,
            deadlock_steps: kpis.deadlock_steps,
            utilisation: if units.is_empty() {
                0.0
            } else {
                units.iter().sum::<f64>() / units.len() as f64
            },
            unit_utilisation: units.clone(),
            lead_time: kpis.mean_lead_time,
            reward: kpis.reward,
            reward_per_agent: f64::from(kpis.reward) / agents.max(1) as f64,
            compute_ms,
        }
    }
}

/// Aggregate of a plant evaluation: the JSON summary. Every `_mean` is
/// over episodes; its `_std` is the sample standard deviation (0 for one
/// episode).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlantEvalSummary {
    /// Controller name.
    pub controller: String,
    /// `plant:ID`.
    pub plant: String,
    /// What a trained policy was trained on (`plant:ID`), else empty.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub trained_on: Option<String>,
    /// AGVs per episode.
    pub agents: usize,
    /// Episodes evaluated.
    pub episodes: usize,
    /// Seed of the episode generator.
    pub seed: u64,
    /// Steps per episode.
    pub t_max: u32,
    /// Simulated seconds per episode.
    pub episode_seconds: f64,
    /// Deliveries per episode.
    pub deliveries_mean: f64,
    /// Their standard deviation.
    pub deliveries_std: f64,
    /// Deliveries per simulated hour.
    pub throughput_per_hour_mean: f64,
    /// Their standard deviation.
    pub throughput_per_hour_std: f64,
    /// Collisions per episode.
    pub collisions_mean: f64,
    /// Their standard deviation.
    pub collisions_std: f64,
    /// Deadlocks per episode.
    pub deadlocks_mean: f64,
    /// Their standard deviation.
    pub deadlocks_std: f64,
    /// Steps with a deadlock in progress per episode.
    pub deadlock_steps_mean: f64,
    /// Moves cut short per episode.
    pub blocked_moves_mean: f64,
    /// Episode reward per AGV (sum over the episode), averaged.
    pub reward_per_agent_mean: f64,
    /// Its standard deviation.
    pub reward_per_agent_std: f64,
    /// Unit utilisation (mean over units), averaged.
    pub utilisation_mean: f64,
    /// Its standard deviation.
    pub utilisation_std: f64,
    /// Each unit's utilisation (A, B), averaged over episodes.
    pub unit_utilisation_mean: Vec<f64>,
    /// Mean lead time in seconds over the episodes with deliveries (none
    /// if no episode delivered).
    pub lead_time_mean: Option<f64>,
    /// Its standard deviation over those episodes.
    pub lead_time_std: Option<f64>,
    /// Episodes that delivered at least once.
    pub episodes_with_deliveries: usize,
    /// Controller time per episode, milliseconds.
    pub compute_ms_mean: f64,
    /// Wall time of the whole evaluation, seconds.
    pub wall_seconds: f64,
}

/// Everything a plant evaluation produced.
#[derive(Debug, Clone)]
pub struct PlantEvalReport {
    /// The plant evaluated on.
    pub plant: Arc<Plant>,
    /// One record per episode, in episode order.
    pub records: Vec<PlantEpisodeRecord>,
    /// The aggregate.
    pub summary: PlantEvalSummary,
    /// What each AGV did in the first episode.
    pub timeline: Timeline,
    /// Segment use over all episodes.
    pub track: TrackUsage,
}

/// Mean and sample standard deviation (0 for fewer than two values; NaN
/// mean for none).
///
/// ```
/// let (m, s) = buridan_eval::plant::mean_std(&[1.0, 2.0, 3.0]);
/// assert_eq!((m, s), (2.0, 1.0));
/// assert_eq!(buridan_eval::plant::mean_std(&[4.0]), (4.0, 0.0));
/// ```
pub fn mean_std(values: &[f64]) -> (f64, f64) {
    let n = values.len();
    if n == 0 {
        return (f64::NAN, f64::NAN);
    }
    let mean = values.iter().sum::<f64>() / n as f64;
    if n < 2 {
        return (mean, 0.0);
    }
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    (mean, var.sqrt())
}

/// The summary of `records`.
pub(super) fn summarize(
    controller: &str,
    plant: &Plant,
    trained_on: Option<String>,
    spec: &PlantEvalSpec,
    records: &[PlantEpisodeRecord],
    wall_seconds: f64,
) -> PlantEvalSummary {
    let col = |f: fn(&PlantEpisodeRecord) -> f64| -> Vec<f64> { records.iter().map(f).collect() };
    let (deliveries_mean, deliveries_std) = mean_std(&col(|r| f64::from(r.deliveries)));
    let (throughput_per_hour_mean, throughput_per_hour_std) =
        mean_std(&col(|r| r.throughput_per_hour));
    let (collisions_mean, collisions_std) = mean_std(&col(|r| f64::from(r.collisions)));
    let (deadlocks_mean, deadlocks_std) = mean_std(&col(|r| f64::from(r.deadlocks)));
    let (reward_per_agent_mean, reward_per_agent_std) = mean_std(&col(|r| r.reward_per_agent));
    let (utilisation_mean, utilisation_std) = mean_std(&col(|r| r.utilisation));
    let lead: Vec<f64> = records.iter().filter_map(|r| r.lead_time).collect();
    let (lead_mean, lead_std) = mean_std(&lead);
    let units = records.first().map_or(0, |r| r.unit_utilisation.len());
    let unit_utilisation_mean = (0..units)
        .map(|u| {
            mean_std(
                &records
                    .iter()
                    .map(|r| r.unit_utilisation.get(u).copied().unwrap_or(0.0))
                    .collect::<Vec<_>>(),
            )
            .0
        })
        .collect();
    PlantEvalSummary {
        controller: controller.to_string(),
        plant: format!("plant:{}", plant.id),
        trained_on,
        agents: spec.agents,
        episodes: records.len(),
        seed: spec.seed,
        t_max: plant.episode.t_max,
        episode_seconds: f64::from(plant.episode.t_max) * plant.episode.step,
        deliveries_mean,
        deliveries_std,
        throughput_per_hour_mean,
        throughput_per_hour_std,
        collisions_mean,
        collisions_std,
        deadlocks_mean,
        deadlocks_std,
        deadlock_steps_mean: mean_std(&col(|r| f64::from(r.deadlock_steps))).0,
        blocked_moves_mean: mean_std(&col(|r| f64::from(r.blocked_moves))).0,
        reward_per_agent_mean,
        reward_per_agent_std,
        utilisation_mean,
        utilisation_std,
        unit_utilisation_mean,
        lead_time_mean: (!lead.is_empty()).then_some(lead_mean),
        lead_time_std: (!lead.is_empty()).then_some(lead_std),
        episodes_with_deliveries: lead.len(),
        compute_ms_mean: mean_std(&col(|r| r.compute_ms)).0,
        wall_seconds,
    }
}

/// Writes `episodes.csv` (one row per episode), `summary.json`, the first
/// episode's timeline and the track's use ([`crate::plant_figures`]: CSV
/// and PNG) of a plant evaluation into `dir` (created if missing) and
/// returns their paths.
pub fn write_plant_report(
    dir: &Path,
    report: &PlantEvalReport,
) -> Result<Vec<PathBuf>, OutputError> {
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let csv_path = dir.join("episodes.csv");
    let csv_error = |source| OutputError::Csv {
        path: csv_path.clone(),
        source,
    };
    let mut w = csv::Writer::from_path(&csv_path).map_err(csv_error)?;
    for r in &report.records {
        w.serialize(r).map_err(csv_error)?;
    }
    w.flush().map_err(io(&csv_path))?;
    let json_path = dir.join("summary.json");
    let json = serde_json::to_string_pretty(&report.summary).expect("summary serialises");
    std::fs::write(&json_path, json + "\n").map_err(io(&json_path))?;
    let s = &report.summary;
    let title = format!("{} on {}, {} AGVs", s.controller, s.plant, s.agents);
    let mut files = vec![csv_path, json_path];
    files.extend(write_timeline(
        dir,
        &format!("{title}, episode {}", report.timeline.episode),
        &report.timeline,
    )?);
    files.extend(write_track_usage(
        dir,
        &format!("{title}, {} episodes", s.episodes),
        &report.plant,
        &report.track,
    )?);
    Ok(files)
}

/// The line `learner eval --plant` prints: the KPIs with their standard
/// deviations.
pub fn summary_line(s: &PlantEvalSummary) -> String {
    let lead = s
        .lead_time_mean
        .map_or_else(|| "-".into(), |t| format!("{t:.0} s"));
    format!(
        "{} on {} with {} AGVs ({} episodes of {} steps, seed {}): deliveries {:.2} ± {:.2} ({:.1}/h), collisions {:.2} ± {:.2}, deadlocks {:.2} ± {:.2}, reward per AGV {:.2} ± {:.2}, utilisation {:.2}, lead time {lead}",
        s.controller,
        s.plant,
        s.agents,
        s.episodes,
        s.t_max,
        s.seed,
        s.deliveries_mean,
        s.deliveries_std,
        s.throughput_per_hour_mean,
        s.collisions_mean,
        s.collisions_std,
        s.deadlocks_mean,
        s.deadlocks_std,
        s.reward_per_agent_mean,
        s.reward_per_agent_std,
        s.utilisation_mean,
    )
}
