//! Schedulers on synthetic learning curves, reports interleaved as parallel
//! trials would send them.

use buridan_study::scheduler::pbt::{exploit_and_explore, Member, PbtConfig};
use buridan_study::scheduler::{Asha, MedianStopping, Scheduler};
use buridan_study::{Decision, SearchSpace};
use rand::SeedableRng;

/// Trial i's curve: success rises to a plateau q_i; q is a shuffled ramp.
const PLATEAUS: [f64; 9] = [0.5, 0.9, 0.1, 0.7, 0.3, 0.8, 0.2, 0.6, 0.4];

fn curve(q: f64, step: u64) -> f64 {
    q * (1.0 - (-(step as f64) / 2000.0).exp())
}

/// Runs all trials round-robin, one report per 100 steps, up to 10,000
/// steps; returns the step each trial stopped at.
fn simulate(s: &mut dyn Scheduler) -> Vec<u64> {
    let mut stopped_at = vec![None; PLATEAUS.len()];
    for step in (100..=10_000).step_by(100) {
        for (i, &q) in PLATEAUS.iter().enumerate() {
            if stopped_at[i].is_some() {
                continue;
            }
            if s.report(i as u64, step, curve(q, step)) == Decision::Stop {
                stopped_at[i] = Some(step);
            }
        }
    }
    stopped_at
        .into_iter()
        .map(|s| s.unwrap_or(10_000))
        .collect()
}

#[test]
fn asha_stops_bad_trials_and_keeps_the_best() {
    let mut asha = Asha::new(500, 3, 10_000);
    let stopped = simulate(&mut asha);
    // Rung 500: trials arrive in index order; each is judged against those
    // recorded before it (top third goes on). The best (0.9) always survives.
    assert_eq!(stopped[1], 10_000, "{stopped:?}");
    let survivors = stopped.iter().filter(|&&s| s == 10_000).count();
    assert!(survivors <= 3, "{stopped:?}");
    // The three worst plateaus (0.1, 0.2, 0.3) are cut at the first rung.
    for i in [2, 4, 6] {
        assert_eq!(stopped[i], 500, "{stopped:?}");
    }
    let used: u64 = stopped.iter().sum();
    assert!(used < 9 * 10_000 / 2, "{used}");
}

#[test]
fn asha_with_a_single_rung_judges_once() {
    let mut asha = Asha::new(500, 3, 1000);
    assert_eq!(asha.milestones(), [500]);
    assert_eq!(asha.report(0, 500, 1.0), Decision::Promote { rung: 0 });
    assert_eq!(asha.report(1, 500, 0.0), Decision::Stop);
    assert_eq!(asha.report(0, 900, 0.0), Decision::Continue);
    // NaN counts as the worst value, never as a panic.
    assert_eq!(asha.report(2, 500, f64::NAN), Decision::Stop);
}

#[test]
fn the_median_rule_stops_trials_below_the_others() {
    let mut median = MedianStopping::new(1000, 3);
    let stopped = simulate(&mut median);
    assert_eq!(stopped[1], 10_000, "{stopped:?}");
    // Below-median plateaus are stopped soon after the grace period.
    for i in [2, 6] {
        assert!(stopped[i] <= 1100, "{stopped:?}");
    }
    let survivors = stopped.iter().filter(|&&s| s == 10_000).count();
    assert!((2..=6).contains(&survivors), "{stopped:?}");
}

#[test]
fn the_median_rule_waits_for_enough_trials() {
    let mut median = MedianStopping::new(0, 3);
    assert_eq!(median.report(0, 10, 0.9), Decision::Continue);
    assert_eq!(median.report(1, 10, 0.8), Decision::Continue);
    assert_eq!(median.report(2, 10, 0.0), Decision::Continue); // only 2 others
    assert_eq!(median.report(3, 10, 0.0), Decision::Stop); // median of 0.9, 0.8, 0 is 0.8
}

#[test]
fn pbt_moves_the_bottom_quarter_onto_the_top_quarter() {
    let space = SearchSpace::from_toml_str(
        r#"
        lr = { log_uniform = [1e-4, 1e-2] }
        epochs = { int = [1, 20] }
        hidden = { choice = [[32, 32], [64, 64], [256, 256]] }
        "#,
    )
    .unwrap();
    let population: Vec<Member> = (0..8u64)
        .map(|i| Member {
            trial: i,
            score: [0.1, 0.9, 0.5, 0.3, 0.8, 0.2, 0.6, 0.4][i as usize],
            overrides: [
                ("lr".to_string(), toml::Value::Float(1e-3)),
                ("epochs".to_string(), toml::Value::Integer(10)),
                (
                    "hidden".to_string(),
                    toml::Value::Array(vec![64.into(), 64.into()]),
                ),
            ]
            .into(),
        })
        .collect();
    let config = PbtConfig {
        resample_probability: 0.0,
        ..PbtConfig::default()
    };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let moves = exploit_and_explore(&population, &space, &config, &mut rng);
    // Bottom quarter: trials 0 (0.1) and 5 (0.2); top quarter: 1 (0.9) and 4 (0.8).
    let mut bottom: Vec<u64> = moves.iter().map(|m| m.trial).collect();
    bottom.sort();
    assert_eq!(bottom, [0, 5]);
    for m in &moves {
        assert!([1, 4].contains(&m.source), "{m:?}");
        let lr = m.overrides["lr"].as_float().unwrap();
        assert!(
            (lr - 8e-4).abs() < 1e-12 || (lr - 1.2e-3).abs() < 1e-12,
            "{lr}"
        );
        let epochs = m.overrides["epochs"].as_integer().unwrap();
        assert!(epochs == 8 || epochs == 12, "{epochs}");
        let hidden = m.overrides["hidden"].as_array().unwrap()[0]
            .as_integer()
            .unwrap();
        assert!(hidden == 32 || hidden == 256, "{hidden}");
    }
    // Too small a population: nothing to exploit.
    assert!(exploit_and_explore(&population[..1], &space, &config, &mut rng).is_empty());
}
