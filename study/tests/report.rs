//! Aggregation across seeds into a report table, in all three renderings.

use buridan_study::report::{Cell, Table};
use buridan_study::stats::Bootstrap;

#[test]
fn seeds_aggregate_into_a_table_with_intervals() {
    // Success rates of 10 seeds per (layout, algorithm).
    let rows = [
        (
            "rm-2.1 ppo",
            [0.96, 0.95, 0.97, 0.94, 0.96, 0.98, 0.95, 0.96, 0.97, 0.12],
        ),
        ("rm-2.1 impala", [0.90; 10]),
    ];
    let boot = Bootstrap::default();
    let groups = boot.aggregate_groups(
        rows.iter()
            .flat_map(|(k, v)| v.iter().map(move |x| (k.to_string(), *x))),
    );
    let ppo = &groups["rm-2.1 ppo"];
    assert_eq!(ppo.count, 10);
    // One failed seed drags the mean; the IQM (middle 6 of 10) ignores it.
    assert!((ppo.mean - 0.876).abs() < 1e-12);
    assert!(
        (ppo.iqm - (0.95 + 0.96 * 3.0 + 0.95 + 0.97) / 6.0).abs() < 1e-12,
        "{}",
        ppo.iqm
    );
    assert!(ppo.mean_ci.contains(ppo.mean) && ppo.mean_ci.low < 0.8);
    assert!(ppo.iqm_ci.high - ppo.iqm_ci.low < ppo.mean_ci.high - ppo.mean_ci.low);
    let impala = &groups["rm-2.1 impala"];
    assert!((impala.mean_ci.low - 0.9).abs() < 1e-12 && (impala.mean_ci.high - 0.9).abs() < 1e-12);

    let mut t = Table::new(["cell", "success %", "IQM %", "runs"]);
    for (k, a) in &groups {
        t.push(vec![
            Cell::text(k),
            Cell::mean(a, 100.0, 1),
            Cell::iqm(a, 100.0, 1),
            Cell::Number {
                value: a.count as f64,
                decimals: 0,
            },
        ])
        .unwrap();
    }
    let md = t.to_markdown();
    assert!(md.starts_with("| cell | success % | IQM % | runs |\n|---|---|---|---|\n"));
    assert!(
        md.contains("| rm-2.1 impala | 90.0 [90.0, 90.0] | 90.0 [90.0, 90.0] | 10 |"),
        "{md}"
    );
    let csv = t.to_csv();
    assert!(
        csv.starts_with(
            "cell,success %,success %_low,success %_high,IQM %,IQM %_low,IQM %_high,runs
"
        ),
        "{csv}"
    );
    assert!(
        csv.contains(
            "
rm-2.1 impala,90,90,90,90,90,90,10
"
        ),
        "{csv}"
    );
    assert_eq!(csv.lines().count(), 3);
    let json: serde_json::Value = serde_json::from_str(&t.to_json()).unwrap();
    assert_eq!(json["rows"][0][1]["kind"], "estimate");
    assert_eq!(json["rows"][0][0]["text"], "rm-2.1 impala");
    let dir = tempfile::tempdir().unwrap();
    t.write_all(dir.path(), "comparison").unwrap();
    for ext in ["md", "csv", "json"] {
        assert!(dir.path().join(format!("comparison.{ext}")).exists());
    }
}
