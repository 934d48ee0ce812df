//! Per-episode key performance indicators of a plant run.

use buridan_env::EpisodeStats;

/// What one plant episode achieved, beyond the reward: the KPIs the
/// dissertation did not report.
///
/// ```
/// let k = buridan_plant::Kpis { deliveries: 12, steps: 1000, ..Default::default() };
/// let stats = k.episode_stats();
/// assert_eq!((stats.goals_reached, stats.length), (12, 1000));
/// ```
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct Kpis {
    /// Episode index.
    pub episode: u64,
    /// Steps taken.
    pub steps: u32,
    /// Simulated seconds (steps × step length).
    pub seconds: f64,
    /// Finished products delivered to the sink.
    pub deliveries: u32,
    /// Deliveries per simulated hour.
    pub throughput_per_hour: f64,
    /// Collisions: steps in which an AGV drove into an oncoming AGV (each
    /// is one −1 reward; a head-on push by both counts twice).
    pub collisions: u32,
    /// Moves cut short by another AGV (collisions included).
    pub blocked_moves: u32,
    /// Deadlocks: cycles of mutually waiting AGVs that lasted
    /// `episode.deadlock_after` steps.
    pub deadlock_events: u32,
    /// Steps with at least one deadlock in progress.
    pub deadlock_steps: u32,
    /// Per unit (A, B): fraction of steps it was processing.
    pub unit_utilisation: Vec<f64>,
    /// Mean seconds from a product's creation at its source to its delivery
    /// at the sink, over the products delivered (`None` without deliveries).
    pub mean_lead_time: Option<f64>,
    /// Products picked up at sources.
    pub pickups: u32,
    /// Products placed in their units.
    pub placements: u32,
    /// Products the sources created (initial buffer contents included).
    pub products_created: u32,
    /// Episode reward summed over agents.
    pub reward: f32,
}

impl Kpis {
    /// The KPIs as (name, value) pairs, as the env API (`env.proto`) sends
    /// them with each finished episode: `seconds`, `deliveries`,
    /// `throughput_per_hour`, `collisions`, `blocked_moves`,
    /// `deadlock_events`, `deadlock_steps`, `utilisation_A`,
    /// `utilisation_B` (one per unit, by product), `pickups`, `placements`,
    /// `products_created`, and `mean_lead_time` if anything was delivered.
    ///
    /// ```
    /// let k = buridan_plant::Kpis { deliveries: 3, unit_utilisation: vec![0.5, 0.25], ..Default::default() };
    /// let named = k.named();
    /// assert!(named.contains(&("deliveries".to_string(), 3.0)));
    /// assert!(named.contains(&("utilisation_B".to_string(), 0.25)));
    /// assert!(!named.iter().any(|(name, _)| name == "mean_lead_time"));
    /// ```
    pub fn named(&self) -> Vec<(String, f64)> {
        let mut out: Vec<(String, f64)> = [
            ("seconds", self.seconds),
            ("deliveries", f64::from(self.deliveries)),
            ("throughput_per_hour", self.throughput_per_hour),
            ("collisions", f64::from(self.collisions)),
            ("blocked_moves", f64::from(self.blocked_moves)),
            ("deadlock_events", f64::from(self.deadlock_events)),
            ("deadlock_steps", f64::from(self.deadlock_steps)),
            ("pickups", f64::from(self.pickups)),
            ("placements", f64::from(self.placements)),
            ("products_created", f64::from(self.products_created)),
        ]
        .into_iter()
        .map(|(name, value)| (name.to_string(), value))
        .collect();
        for (unit, &u) in ["A", "B"].iter().zip(&self.unit_utilisation) {
            out.push((format!("utilisation_{unit}"), u));
        }
        if let Some(lead) = self.mean_lead_time {
            out.push(("mean_lead_time".into(), lead));
        }
        out
    }

    /// The env-wide [`EpisodeStats`] these KPIs map to: deliveries are the
    /// goals reached, blocked moves and deadlocks carry over; there is no
    /// success (episodes only end at `t_max`) and no livelock detector.
    pub fn episode_stats(&self) -> EpisodeStats {
        EpisodeStats {
            episode: self.episode,
            reward: self.reward,
            length: self.steps,
            success: false,
            agents_at_goal: 0,
            blocked_moves: self.blocked_moves,
            goals_reached: self.deliveries,
            deadlock_steps: self.deadlock_steps,
            livelock_steps: 0,
            deadlock_events: self.deadlock_events,
            layout: 0,
            replay: 0,
        }
    }
}
