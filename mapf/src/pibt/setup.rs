//! What the PIBT-based solvers share around the generator: the instance
//! as cell indices with its distance tables, PIBT's priorities, and one step
//! of online PIBT.

use crate::graph::{distance_table, Topology};
use crate::limits::{check_instance, goals_reachable, SolveError};
use crate::plan::Plan;
use crate::Problem;

use super::generator::{Generator, Preference};

/// The shared setup of PIBT-based solvers: topology, distance tables,
/// starts and goals as cell indices.
pub(crate) struct Setup {
    pub topo: Topology,
    pub dist: Vec<Vec<u32>>,
    pub starts: Vec<u32>,
    pub goals: Vec<u32>,
}

impl Setup {
    /// Checks the instance (typed errors, unreachable goals → `NoSolution`).
    pub fn new(problem: Problem<'_>) -> Result<Self, SolveError> {
        let (grid, starts, goals) = (problem.grid, problem.starts, problem.goals);
        check_instance(grid, starts, goals)?;
        if !goals_reachable(grid, starts, goals) {
            return Err(SolveError::NoSolution);
        }
        let topo = Topology::new(grid);
        let dist = goals.iter().map(|&g| distance_table(grid, g)).collect();
        Ok(Self {
            starts: starts.iter().map(|&s| topo.index(s)).collect(),
            goals: goals.iter().map(|&g| topo.index(g)).collect(),
            topo,
            dist,
        })
    }

    /// PIBT's initial priorities: a fraction below 1 growing with the
    /// distance to the goal (farther agents first).
    pub fn initial_priorities(&self) -> Vec<f64> {
        let cells = self.topo.cells() as f64 + 1.0;
        (0..self.starts.len())
            .map(|i| f64::from(self.dist[i][self.starts[i] as usize]) / cells)
            .collect()
    }

    /// PIBT's priority update after reaching `config` (see
    /// [`advance_priorities`]).
    pub fn update_priorities(&self, priorities: &mut [f64], config: &[u32]) {
        advance_priorities(priorities, config, &self.goals);
    }

    /// Agents by decreasing priority (see [`priority_order`]).
    pub fn order(priorities: &[f64]) -> Vec<u32> {
        priority_order(priorities, &[])
    }

    /// The plan visiting `configs` in order, trimmed.
    pub fn plan(&self, configs: &[Vec<u32>]) -> Plan {
        self.topo
            .plan(self.starts.len(), configs.iter().map(Vec::as_slice))
    }
}

/// PIBT's priority update after reaching `config`: +1 for agents not on
/// their `goals`, back to the fractional part (the fixed tie-breaker) on the
/// goal. Agents kept waiting thus overtake those that have arrived.
pub(crate) fn advance_priorities(priorities: &mut [f64], config: &[u32], goals: &[u32]) {
    for ((p, &at), &goal) in priorities.iter_mut().zip(config).zip(goals) {
        if at == goal {
            *p = p.fract();
        } else {
            *p += 1.0;
        }
    }
}

/// Agents by decreasing priority (ties: lower index first); the agents
/// marked in `urgent` (all of them or none given) go before all others,
/// among themselves by priority.
pub(crate) fn priority_order(priorities: &[f64], urgent: &[bool]) -> Vec<u32> {
    let is_urgent = |a: u32| urgent.get(a as usize).copied().unwrap_or(false);
    let mut order: Vec<u32> = (0..priorities.len() as u32).collect();
    order.sort_by(|&a, &b| {
        is_urgent(b)
            .cmp(&is_urgent(a))
            .then(priorities[b as usize].total_cmp(&priorities[a as usize]))
    });
    order
}

/// One step of online PIBT, shared by lifelong PIBT and the collision
/// shield: the next configuration `gen` (a fresh [`Generator`], with the
/// swap operation if the caller wants it) finds after `cur` with agents in
/// `priorities` order (the `urgent` ones first, [`priority_order`]), then
/// the priorities advanced towards `goals`.
/// Without constraints every agent can at least stay, so the generator
/// cannot fail; should it ever, everybody stays (a legal step), rather than
/// handing the env an illegal one.
pub(crate) fn online_step<P: Preference>(
    mut gen: Generator<'_>,
    pref: &P,
    cur: &[u32],
    goals: &[u32],
    priorities: &mut [f64],
    urgent: &[bool],
) -> Vec<u32> {
    let order = priority_order(priorities, urgent);
    let mut next = Vec::with_capacity(cur.len());
    let ok = gen.generate(pref, cur, &order, &[], &mut next);
    debug_assert!(ok, "without constraints every agent can at least stay");
    if !ok {
        next = cur.to_vec();
    }
    advance_priorities(priorities, &next, goals);
    next
}
