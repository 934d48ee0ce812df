//! One evaluation harness for every controller — MA-A*, CBS, random and
//! trained policies — on identical episodes drawn from the env's seeded
//! generator, with the dissertation's statistics and charts.
//!
//! - [`controller`]: the [`Controller`] trait and [`RandomController`].
//! - [`planner`]: planners of `buridan-mapf` as controllers.
//! - [`lifelong`]: PIBT one step at a time (`lifelong-pibt`), no plan.
//! - [`policy`]: a trained policy (a checkpoint) as a controller.
//! - [`plant`]: evaluation on the AGV plant (`buridan-plant`): baselines
//!   and plant-trained policies over seeded episodes, KPIs per episode.
//! - [`shield`]: a trained policy executed through the PIBT collision
//!   shield (deterministic, conflict-free joint moves).
//! - [`runner`]: [`evaluate`] runs episodes and aggregates them;
//!   [`evaluate_instances`] does so on an instance set.
//! - [`instances`]: instance sets, MovingAI `.scen` files as episodes.
//! - [`benchmark`]: measured rows beside published ones on an instance
//!   set (POGEMA's warehouse): the table and its charts.
//! - [`fleet`]: closed-loop fleet sessions: any controller answers each
//!   report of positions and goals; planners replan.
//! - [`goal_sequences`]: goal files (`lifelong-goals v1`): starts and goal
//!   sequences of a lifelong instance.
//! - [`throughput`]: lifelong throughput of a controller on one goal file.
//! - [`lifelong_bench`]: POGEMA's lifelong warehouse benchmark over a folder
//!   of goal files, pooled per agent count beside published figures.
//! - [`stats`]: quantiles and box-plot statistics.
//! - [`output`]: CSV, JSON and PNG files of a report; the agent-count sweep.
//! - [`plot`]: heatmaps, box plots and line charts as PNG.
//! - [`replay`]: one episode recorded step by step, for drawing.
//! - [`serde_as_text!`]: serde through a type's text (`buridan_env::text_serde`).

pub mod benchmark;
pub mod by_name;
pub mod controller;
pub mod fleet;
pub mod goal_sequences;
pub mod instances;
pub mod lifelong;
pub mod lifelong_bench;
pub mod output;
pub mod planner;
pub mod plant;
pub mod plant_figures;
pub mod plot;
pub mod policy;
pub mod replay;
pub mod rescue;
pub mod runner;
pub mod shield;
pub mod stats;
pub use buridan_env::serde_as_text;
pub mod throughput;

pub use controller::{Controller, GiveUp, PlanNotes, RandomController};
pub use runner::{
    evaluate, evaluate_instances, run_episode, EpisodeRecord, EvalReport, EvalSpec, EvalSummary,
};
