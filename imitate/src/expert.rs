//! The expert: a classical planner asked what every agent should do next.
//!
//! A state is the agents' cells and goals on one layout. The expert plans
//! from it with the first planner that solves it within the time limit and
//! returns the plan's first joint step as actions. Every later
//! configuration of that plan gets its step too (the rest of a valid plan is
//! a valid plan), so a rollout that stays on the expert's track costs one
//! planner call per episode, and a policy stuck in one configuration one
//! call in all.
//!
//! The policy's action mask forbids entering an occupied cell, even one
//! its holder leaves in the same step (the env's index order would let an
//! agent follow a lower-index one). So the expert never labels such a move:
//! a plan step in which an agent follows another is split into steps that
//! the policy can take ([`masked_steps`]) — first the agents whose target is
//! free move and the followers wait, then the followers enter the cells
//! just left. The labels are exactly the actions that take a rollout from
//! one configuration of the (split) plan to the next, so a policy that
//! follows them stays on the plan's track. (Replacing a follow move by
//! "stay" and keeping the plan's next configurations instead leaves the
//! track: the state after the wait is planned afresh, and the two plans'
//! labels can close a cycle the policy then imitates faithfully.)

use buridan_mapf::Problem;
use std::collections::HashMap;
use std::time::Duration;

use buridan_env::{Cell, GridEnv};
use buridan_mapf::replay::plan_actions;
use buridan_mapf::{planner_by_name, Limits, Planner};

use crate::config::{ImitationConfig, LabelStyle};

/// The expert's next joint step in one state: one action per agent, none
/// of them into a cell occupied at the start of the step, so a masked
/// policy can take it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Labels {
    /// Every agent's action (0 stay, 1 up, 2 right, 3 down, 4 left): the
    /// policy's targets.
    pub actions: Vec<u8>,
    /// The joint move the env executes when a rollout follows the expert:
    /// `actions` itself under [`LabelStyle::Split`], the plan's own step
    /// (follows included) under [`LabelStyle::Wait`].
    pub execute: Vec<u8>,
}

impl Labels {
    fn split(actions: Vec<u8>) -> Self {
        Self {
            execute: actions.clone(),
            actions,
        }
    }

    /// The plan's step from `from` with every move into a cell occupied
    /// at its start replaced by "stay" ([`LabelStyle::Wait`]).
    fn wait(plan: Vec<u8>, from: &[Cell], to: &[Cell]) -> Self {
        let actions = plan
            .iter()
            .zip(to)
            .map(|(&a, target)| {
                if a != 0 && from.contains(target) {
                    0
                } else {
                    a
                }
            })
            .collect();
        Self {
            actions,
            execute: plan,
        }
    }
}

/// Splits one plan step, from `from` to `to` (a conflict-free joint move),
/// into steps without following moves: each moves the agents whose target
/// is free at its start, and the others wait. Returns each step's start
/// configuration and actions, or `None` if agents would wait for each
/// other in a cycle (a rotation, which simultaneous-move plans may hold).
///
/// ```
/// use buridan_env::Cell;
/// use buridan_imitate::expert::masked_steps;
/// let c = |col| Cell { row: 0, col };
/// // Agent 0 leaves cell 1 to the right; agent 1 follows it from cell 0.
/// let steps = masked_steps(&[c(1), c(0)], &[c(2), c(1)], &[2, 2]).unwrap();
/// assert_eq!(steps, vec![
///     (vec![c(1), c(0)], vec![2, 0]), // the leader moves, the follower waits
///     (vec![c(2), c(0)], vec![0, 2]), // then the follower enters
/// ]);
/// // A step without following stays one step.
/// assert_eq!(masked_steps(&[c(0), c(5)], &[c(1), c(4)], &[2, 4]).unwrap().len(), 1);
/// ```
pub fn masked_steps(
    from: &[Cell],
    to: &[Cell],
    actions: &[u8],
) -> Option<Vec<(Vec<Cell>, Vec<u8>)>> {
    let mut at = from.to_vec();
    let mut pending: Vec<bool> = (0..from.len()).map(|i| from[i] != to[i]).collect();
    let mut steps = Vec::with_capacity(1);
    while pending.iter().any(|&p| p) {
        let go: Vec<bool> = (0..at.len())
            .map(|i| pending[i] && !at.contains(&to[i]))
            .collect();
        if !go.contains(&true) {
            return None;
        }
        let step_actions = (0..at.len())
            .map(|i| if go[i] { actions[i] } else { 0 })
            .collect();
        steps.push((at.clone(), step_actions));
        for i in (0..at.len()).filter(|&i| go[i]) {
            at[i] = to[i];
            pending[i] = false;
        }
    }
    Some(steps)
}

type StateKey = (String, Vec<Cell>, Vec<Cell>);

/// Planners with a time limit and a memory of every state they labelled.
pub struct Expert {
    planners: Vec<Box<dyn Planner>>,
    limits: Limits,
    known: HashMap<StateKey, Option<Labels>>,
    style: LabelStyle,
    /// Planner calls so far.
    pub calls: u64,
    /// Planner calls that found no plan within the limit.
    pub failures: u64,
}

/// Labels kept at most before the memory starts afresh.
const MAX_KNOWN: usize = 2_000_000;

impl Expert {
    /// The expert of `cfg` (checked by [`ImitationConfig::validate`]).
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_env::{EnvConfig, GridEnv, Map};
    /// let cfg = buridan_imitate::ImitationConfig::default();
    /// let mut expert = buridan_imitate::Expert::new(&cfg);
    /// let env = GridEnv::new(Arc::new(Map::load("rm-2.1").unwrap()), EnvConfig::default()).unwrap();
    /// let labels = expert.label(&env).unwrap();
    /// assert_eq!(labels.actions.len(), 4);
    /// assert_eq!(expert.calls, 1);
    /// expert.label(&env);
    /// assert_eq!(expert.calls, 1, "a known state costs no call");
    /// ```
    pub fn new(cfg: &ImitationConfig) -> Self {
        Self {
            planners: cfg
                .expert
                .iter()
                .filter_map(|p| planner_by_name(p))
                .collect(),
            limits: Limits {
                time: Duration::from_secs_f64(cfg.expert_time),
                memory_bytes: 512 << 20,
                ..Limits::default()
            },
            known: HashMap::new(),
            style: cfg.labels,
            calls: 0,
            failures: 0,
        }
    }

    /// The expert's next step for every agent of `env`'s current state,
    /// or `None` if no planner solved it in time.
    pub fn label(&mut self, env: &GridEnv) -> Option<&Labels> {
        let key: StateKey = (env.map().name.clone(), env.goals(), env.positions());
        if !self.known.contains_key(&key) {
            if self.known.len() >= MAX_KNOWN {
                self.known.clear();
            }
            self.solve(env, &key);
        }
        self.known.get(&key).and_then(Option::as_ref)
    }

    /// Plans from `key`'s state and remembers the step of every
    /// configuration along the plan (or that the state is unsolved).
    fn solve(&mut self, env: &GridEnv, key: &StateKey) {
        self.calls += 1;
        let (grid, goals, starts) = (&env.map().grid, &key.1, &key.2);
        let plan = self.planners.iter().find_map(|p| {
            p.solve(Problem::new(grid, starts, goals), &self.limits)
                .ok()
        });
        let Some(solution) = plan else {
            self.failures += 1;
            self.known.insert(key.clone(), None);
            return;
        };
        let plan = solution.plan;
        let Ok(steps) = plan_actions(&plan) else {
            // Not a plan of unit moves: no labels from it.
            self.failures += 1;
            self.known.insert(key.clone(), None);
            return;
        };
        if self.style == LabelStyle::Wait {
            for (t, actions) in steps.into_iter().enumerate() {
                let (from, to) = (plan.positions_at(t), plan.positions_at(t + 1));
                self.known
                    .entry((key.0.clone(), goals.clone(), from.clone()))
                    .or_insert_with(|| Some(Labels::wait(actions, &from, &to)));
            }
            // A state already on its goals: everyone stays.
            self.known
                .entry(key.clone())
                .or_insert_with(|| Some(Labels::split(vec![0; starts.len()])));
            return;
        }
        let at_goals = steps.is_empty();
        for (t, actions) in steps.into_iter().enumerate() {
            let (from, to) = (plan.positions_at(t), plan.positions_at(t + 1));
            let Some(split) = masked_steps(&from, &to, &actions) else {
                // A rotation the policy cannot take: the track ends here,
                // and its states are asked anew when a rollout reaches them.
                break;
            };
            for (config, actions) in split {
                self.known
                    .entry((key.0.clone(), goals.clone(), config))
                    .or_insert_with(|| Some(Labels::split(actions)));
            }
        }
        if at_goals {
            // Everyone is on their goal: everyone stays.
            let actions = vec![0; starts.len()];
            self.known.insert(key.clone(), Some(Labels::split(actions)));
        } else if !self.known.contains_key(key) {
            // The plan opens with a rotation: no label the policy can take.
            self.failures += 1;
            self.known.insert(key.clone(), None);
        }
    }
}
