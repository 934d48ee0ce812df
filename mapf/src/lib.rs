//! Classical MAPF baselines: filled by the baselines issue.
