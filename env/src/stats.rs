//! Per-episode statistics.

/// What one finished episode amounted to.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct EpisodeStats {
    /// Episode index (its starts and goals follow from map, agents, seed and this).
    pub episode: u64,
    /// Episode reward summed over agents, as RLlib reports it.
    pub reward: f32,
    /// Steps taken.
    pub length: u32,
    /// All agents on their goals before truncation (never in lifelong mode).
    pub success: bool,
    /// Agents standing on their goals at the end.
    pub agents_at_goal: u32,
    /// Move requests that failed (wall, edge or occupied cell).
    pub blocked_moves: u32,
    /// Goals reached: first arrivals, or every arrival in lifelong mode.
    pub goals_reached: u32,
    /// Steps with at least one deadlocked agent (see [`crate::monitor`]).
    pub deadlock_steps: u32,
    /// Steps with at least one livelocked agent.
    pub livelock_steps: u32,
    /// Times an agent became deadlocked.
    pub deadlock_events: u32,
    /// Which layout of a multi-layout env the episode played (its index in
    /// the [`crate::LayoutMixture`]'s list); 0 for a single-map env.
    #[serde(default)]
    pub layout: u32,
    /// 0 for a fresh episode; k for its k-th replay after a failure
    /// ([`crate::replay::FailureReplay`]).
    #[serde(default)]
    pub replay: u32,
}

impl EpisodeStats {
    /// Goals reached per step: the lifelong throughput.
    ///
    /// ```
    /// let s = buridan_env::EpisodeStats { goals_reached: 30, length: 100, ..Default::default() };
    /// assert_eq!(s.throughput(), 0.3);
    /// ```
    pub fn throughput(&self) -> f64 {
        if self.length == 0 {
            0.0
        } else {
            f64::from(self.goals_reached) / f64::from(self.length)
        }
    }
}
