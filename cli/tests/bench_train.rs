//! `learner bench train`: variants of one run measured side by side.

mod common;

use buridan_cli::bench_train::{run, TrainBenchArgs};
use buridan_learner::train::TrainConfig;

fn bench_args(out: std::path::PathBuf, variants: &[&str], repeats: usize) -> TrainBenchArgs {
    TrainBenchArgs {
        train: common::train_args(out),
        variants: variants.iter().map(|v| v.to_string()).collect(),
        repeats,
    }
}

#[test]
fn variants_run_alternately_with_their_overrides_and_tables_compare_them() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bench");
    let args = bench_args(
        out.clone(),
        &[
            "one-thread:ppo.update_threads=1",
            "two-threads:ppo.update_threads=2;ppo.epochs=1",
        ],
        2,
    );
    let measured = run(&args).unwrap();
    let order: Vec<(&str, usize)> = measured
        .iter()
        .map(|m| (m.variant.as_str(), m.repeat))
        .collect();
    assert_eq!(
        order,
        [
            ("one-thread", 0),
            ("two-threads", 0),
            ("one-thread", 1),
            ("two-threads", 1)
        ]
    );
    for m in &measured {
        assert_eq!(m.env_steps, 3000);
        assert!(m.steps_per_s > 0.0 && m.wall_seconds > 0.0);
    }
    // Each run is `learner train` with the variant's overrides on top.
    let cfg = |variant: &str| {
        TrainConfig::from_toml_file(&out.join(variant).join("repeat-1").join("config.toml"))
            .unwrap()
    };
    let (one, two) = (cfg("one-thread"), cfg("two-threads"));
    let (one_ppo, two_ppo) = (one.algorithm.ppo().unwrap(), two.algorithm.ppo().unwrap());
    assert_eq!((one_ppo.update_threads, one_ppo.epochs), (1, 2));
    assert_eq!((two_ppo.update_threads, two_ppo.epochs), (2, 1));
    assert_eq!(
        (one.run.seed, two.run.seed, one.map_label()),
        (3, 3, "rm-1.1".into())
    );

    let rows: Vec<serde_json::Value> =
        serde_json::from_str(&std::fs::read_to_string(out.join("table.json")).unwrap()).unwrap();
    assert_eq!(rows.len(), 2);
    assert_eq!(rows[0]["ratio"].as_f64(), Some(1.0));
    let mean = |v: &str| {
        let xs: Vec<f64> = measured
            .iter()
            .filter(|m| m.variant == v)
            .map(|m| m.steps_per_s)
            .collect();
        xs.iter().sum::<f64>() / xs.len() as f64
    };
    let ratio = rows[1]["ratio"].as_f64().unwrap();
    assert!((ratio - mean("two-threads") / mean("one-thread")).abs() < 1e-9);
    let md = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert!(
        md.contains("| two-threads | `ppo.update_threads=2;ppo.epochs=1` | 2 |"),
        "{md}"
    );
    assert_eq!(
        std::fs::read_to_string(out.join("runs.csv"))
            .unwrap()
            .lines()
            .count(),
        5
    );

    // A second benchmark into the same directory is refused, not mixed in.
    let again = format!("{:#}", run(&args).unwrap_err());
    assert!(again.contains("already holds a benchmark"), "{again}");
}

#[test]
fn bad_variants_are_refused_before_anything_runs() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bench");
    for (variants, expected) in [
        (vec!["a", "a"], "named twice"),
        (vec!["a:ppo.epochs"], "is not KEY=VALUE"),
        (vec!["a/b"], "the name must be"),
    ] {
        let err = format!(
            "{:#}",
            run(&bench_args(out.clone(), &variants, 1)).unwrap_err()
        );
        assert!(err.contains(expected), "{variants:?}: {err}");
    }
    // An override the config does not know fails as `learner train` does.
    let err = format!(
        "{:#}",
        run(&bench_args(out.clone(), &["a:ppo.no_such_key=1"], 1)).unwrap_err()
    );
    assert!(err.contains("no_such_key"), "{err}");
    assert!(!out.join("runs.csv").exists());
}
