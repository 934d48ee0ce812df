//! The actor process: filled by the distributed issue. Until then actors run in-process in the learner.
