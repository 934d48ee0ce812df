//! A run's figures as Prometheus metrics (no-ops unless an exporter is
//! installed).

use buridan_policy::Fragment;

use super::{Exchange, MetricsRow};

/// Counts the fragments an update consumed, and their env steps as the
/// buffers handed to the update hold them (`rewards` is `[T, B]`, `B` =
/// envs × rows per env), in `buridan_fragments_consumed_total` and
/// `buridan_fragment_steps_consumed_total` (`learner bench soak` checks
/// that every consumed fragment was whole: steps = fragments × fragment
/// length × envs).
pub(super) fn count_consumed(batch: &[Fragment]) {
    let steps: usize = batch
        .iter()
        .map(|f| f.rewards.len() / f.rows_per_env.max(1))
        .sum();
    ::metrics::counter!("buridan_fragments_consumed_total").increment(batch.len() as u64);
    ::metrics::counter!("buridan_fragment_steps_consumed_total").increment(steps as u64);
}

/// Publishes one update's figures as Prometheus metrics (no-ops unless an
/// exporter is installed).
pub(super) fn export_metrics(row: &MetricsRow, exchange: &dyn Exchange) {
    ::metrics::gauge!("buridan_policy_version").set(row.update as f64);
    ::metrics::gauge!("buridan_env_steps").set(row.env_steps as f64);
    ::metrics::gauge!("buridan_env_steps_per_second").set(row.steps_per_s);
    ::metrics::gauge!("buridan_queue_depth").set(exchange.queue_depth() as f64);
    ::metrics::gauge!("buridan_connected_actors").set(exchange.connected_actors() as f64);
    ::metrics::gauge!("buridan_episodes").set(row.episodes as f64);
    for (name, v) in [
        ("buridan_episode_return_mean", row.episode_return_mean),
        ("buridan_success_rate", row.success_rate),
        ("buridan_episode_length_mean", row.episode_len_mean),
    ] {
        if v.is_finite() {
            ::metrics::gauge!(name).set(v);
        }
    }
    for (term, v) in [
        ("total", row.total_loss),
        ("policy", row.policy_loss),
        ("value", row.vf_loss),
        ("entropy", row.entropy),
        ("kl", row.kl),
    ] {
        ::metrics::gauge!("buridan_loss", "term" => term).set(v);
    }
    ::metrics::gauge!("buridan_grad_norm").set(row.grad_norm);
    ::metrics::gauge!("buridan_learning_rate").set(row.lr);
    ::metrics::gauge!("buridan_entropy_coeff").set(row.entropy_coeff);
    ::metrics::histogram!("buridan_learn_seconds").record(row.learn_seconds);
}
