//! The `learner` command line: each subcommand in its own module.

pub mod eval;
pub mod serve;
pub mod train;
