//! Learner library.

pub mod algo;
