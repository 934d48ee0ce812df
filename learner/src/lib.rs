//! Learner library.

pub mod algo;
pub mod train;
