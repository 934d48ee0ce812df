//! Learner library.
