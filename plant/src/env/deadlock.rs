//! Deadlock detection: who waits for whom, and cycles of waiting AGVs that
//! have lasted `episode.deadlock_after` steps.

use super::{Agv, PlantEnv, FORWARD};

/// What the detector saw at the end of one step.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(super) struct Deadlocks {
    /// Cycles that reached the age `deadlock_after` in this step.
    pub(super) new: u32,
    /// Some cycle is at least `deadlock_after` steps old.
    pub(super) any: bool,
}

/// Counts the cycles of `waits` (who each AGV waits for) whose every
/// member has waited `after` steps, each cycle once, at its lowest index.
pub(super) fn find_deadlocks(waits: &[Option<usize>], agvs: &[Agv], after: u32) -> Deadlocks {
    let n = waits.len();
    let mut found = Deadlocks::default();
    for start in 0..n {
        // Follow the waits from `start`; it is on a cycle iff it comes
        // back within n hops.
        let mut cycle = vec![start];
        let mut at = start;
        let mut closed = false;
        for _ in 0..n {
            match waits[at] {
                Some(next) if next == start => {
                    closed = true;
                    break;
                }
                Some(next) => {
                    cycle.push(next);
                    at = next;
                }
                None => break,
            }
        }
        if !closed || cycle.iter().any(|&c| c < start) {
            continue;
        }
        let age = cycle
            .iter()
            .map(|&c| agvs[c].waiting_steps)
            .min()
            .unwrap_or(0);
        if age >= after {
            found.any = true;
            if age == after {
                found.new += 1;
            }
        }
    }
    found
}

impl PlantEnv {
    /// Who each AGV waits for: the AGV touching it on its route ahead.
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_plant::{Plant, PlantConfig, PlantEnv};
    /// let plant = Arc::new(Plant::load("dissertation").unwrap());
    /// let env = PlantEnv::new(plant, PlantConfig { agents: 2, ..Default::default() }).unwrap();
    /// assert_eq!(env.waits_for(), vec![None, None]); // starts are apart
    /// ```
    pub fn waits_for(&self) -> Vec<Option<usize>> {
        (0..self.agents())
            .map(|i| {
                if self.goal_node(i).is_none() || self.at_goal(i) || self.is_handling(i) {
                    return None;
                }
                let (pieces, _) = self.track.plan(&self.agvs[i], FORWARD, 1e-3);
                let (driven, blocker) = self.track.drivable(&self.agvs, i, &pieces);
                blocker.filter(|_| driven < 5e-4)
            })
            .collect()
    }

    /// Updates waiting counters, then counts deadlocks: cycles of waiting
    /// AGVs whose every member has waited `deadlock_after` steps.
    pub(super) fn detect_deadlocks(&mut self) {
        let waits = self.waits_for();
        for (agv, w) in self.agvs.iter_mut().zip(&waits) {
            agv.waiting_steps = if w.is_some() {
                agv.waiting_steps + 1
            } else {
                0
            };
        }
        let found = find_deadlocks(&waits, &self.agvs, self.track.plant.episode.deadlock_after);
        self.kpis.deadlock_events += found.new;
        if found.any {
            self.kpis.deadlock_steps += 1;
        }
    }
}
