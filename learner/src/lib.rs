//! The learner: training (PPO, IMPALA), evaluation and the `learner` command line.

pub mod algo;
pub mod cli;
pub mod policy_controller;
pub mod serve;
pub mod train;
