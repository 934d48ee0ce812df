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
//! its holder leaves in the same step (the env's index order would allow
//! following a lower-index agent). Such a plan step is labelled "stay" for
//! the policy ([`Labels::policy`]): the agent waits one step and enters the
//! cell on the next, which is what a masked policy can do.

use std::collections::HashMap;
use std::time::Duration;

use buridan_env::{Cell, GridEnv};
use buridan_mapf::replay::plan_actions;
use buridan_mapf::{planner_by_name, Limits, Planner};

use crate::config::ImitationConfig;

/// The expert's next joint step in one state.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Labels {
    /// The plan's actions (what the env executes to follow the plan).
    pub plan: Vec<u8>,
    /// The same with moves into a cell occupied at the start of the step
    /// replaced by "stay": the targets for a policy whose mask forbids them.
    pub policy: Vec<u8>,
}

impl Labels {
    fn new(plan: Vec<u8>, from: &[Cell], to: &[Cell]) -> Self {
        let policy = plan
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
        Labels { plan, policy }
    }
}

type StateKey = (String, Vec<Cell>, Vec<Cell>);

/// Planners with a time limit and a memory of every state they labelled.
pub struct Expert {
    planners: Vec<Box<dyn Planner>>,
    limits: Limits,
    known: HashMap<StateKey, Option<Labels>>,
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
    /// assert_eq!(labels.plan.len(), 4);
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
        let plan = self
            .planners
            .iter()
            .find_map(|p| p.solve(grid, starts, goals, &self.limits).ok());
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
        for (t, actions) in steps.into_iter().enumerate() {
            let (from, to) = (plan.positions_at(t), plan.positions_at(t + 1));
            self.known
                .entry((key.0.clone(), goals.clone(), from.clone()))
                .or_insert_with(|| Some(Labels::new(actions, &from, &to)));
        }
        // A state already on its goals: everyone stays.
        self.known
            .entry(key.clone())
            .or_insert_with(|| Some(Labels::new(vec![0; starts.len()], starts, starts)));
    }
}
