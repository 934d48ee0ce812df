//! The learner: the algorithms (PPO, IMPALA), the training loop over an
//! exchange with actors (in-process threads or gRPC), and the gRPC server.
//! The `learner` command line lives in `buridan-cli`.

pub mod algo;
pub mod serve;
pub mod train;
