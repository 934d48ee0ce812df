//! Evaluation harness: filled by the baselines issue.
