//! `learner eval --scen PATH --rules pogema`: instance sets end to end, in
//! process.

mod common;

use std::path::{Path, PathBuf};

use buridan_cli::eval::{self, EvalArgs};
use buridan_env::Rules;

fn args(scen: Vec<PathBuf>, controller: &str, agents: Option<&str>, out: PathBuf) -> EvalArgs {
    let mut flags: Vec<String> = ["--rules", "pogema", "--controller", controller]
        .into_iter()
        .chain(["--time-limit", "10", "--memory-limit", "256"])
        .map(String::from)
        .collect();
    for s in scen {
        flags.extend(["--scen".to_string(), s.display().to_string()]);
    }
    if let Some(n) = agents {
        flags.extend(["--agents".to_string(), n.to_string()]);
    }
    flags.extend(["--out".to_string(), out.display().to_string()]);
    common::eval_args(&flags)
}

/// A directory with the POGEMA warehouse and two of its instances.
fn instance_dir(root: &Path) -> PathBuf {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../mapf/tests/data/pogema");
    let dir = root.join("instances");
    std::fs::create_dir_all(&dir).unwrap();
    for file in [
        "warehouse.map",
        "warehouse-32-1.scen",
        "warehouse-32-0.scen",
    ] {
        std::fs::copy(data.join(file), dir.join(file)).unwrap();
    }
    dir
}

#[test]
fn scen_directory_is_one_episode_per_file_under_pogema_rules() {
    let root = tempfile::tempdir().unwrap();
    let dir = instance_dir(root.path());
    let out = root.path().join("eval");
    let summaries = eval::run(&args(vec![dir], "lacam", Some("16"), out.clone())).unwrap();
    let s = &summaries[0];
    assert_eq!(
        (s.rules, s.t_max, s.agents, s.instances),
        (Rules::Pogema, 128, 16, 2)
    );
    assert_eq!(s.success_rate, 1.0);
    assert!(
        s.soc_ratio_median.unwrap() >= 1.0 && s.isr_mean == 1.0,
        "{s:?}"
    );
    assert!(s.controller.starts_with("lacam"), "{}", s.controller);
    let mut csv = csv::Reader::from_path(out.join("episodes.csv")).unwrap();
    let headers = csv.headers().unwrap().clone();
    let col = |name: &str| headers.iter().position(|h| h == name).unwrap();
    let rows: Vec<csv::StringRecord> = csv.records().map(Result::unwrap).collect();
    let names: Vec<&str> = rows.iter().map(|r| &r[col("instance")]).collect();
    assert_eq!(names, ["warehouse-32-0.scen", "warehouse-32-1.scen"]);
    for r in &rows {
        assert_eq!(&r[col("success")], "true");
        let (soc, lb): (u64, u64) = (
            r[col("soc")].parse().unwrap(),
            r[col("soc_lower_bound")].parse().unwrap(),
        );
        assert!(soc >= lb, "{r:?}");
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(json["rules"], "pogema");
    assert_eq!(json["t_max"], 128);
    assert_eq!(json["isr_mean"], 1.0);
    // --max-steps overrides the rule set's T_max; every line without --agents.
    let mut short = args(
        vec![root.path().join("instances/warehouse-32-0.scen")],
        "lacam",
        None,
        root.path().join("short"),
    );
    short.t_max = Some(5);
    let s = &eval::run(&short).unwrap()[0];
    assert_eq!((s.agents, s.t_max, s.success_rate), (32, 5, 0.0));
    assert!(s.isr_mean < 1.0 && s.makespan_mean == 5.0, "{s:?}");
}

#[test]
fn bad_scen_input_and_unsupported_planners_are_reported() {
    let root = tempfile::tempdir().unwrap();
    let dir = instance_dir(root.path());
    let out = root.path().join("eval");
    let err = eval::run(&args(vec![dir.clone()], "od-astar", Some("4"), out.clone())).unwrap_err();
    assert!(
        format!("{err:#}").contains("cannot plan under pogema rules"),
        "{err:#}"
    );
    let err = eval::run(&args(vec![dir.clone()], "lacam", Some("33"), out.clone())).unwrap_err();
    assert!(
        format!("{err:#}")
            .contains("warehouse-32-0.scen: 33 agents requested, but the file has 32 agent lines"),
        "{err:#}"
    );
    let bad = dir.join("warehouse-32-2.scen");
    std::fs::write(&bad, "version 1\n0\twarehouse.map\t46\t33\t0\t0\n").unwrap();
    let err = eval::run(&args(vec![bad], "lacam", None, out.clone())).unwrap_err();
    assert!(
        format!("{err:#}").contains("warehouse-32-2.scen:2: expected 9 fields"),
        "{err:#}"
    );
    let err = eval::run(&args(vec![dir.join("nope.scen")], "lacam", None, out)).unwrap_err();
    assert!(format!("{err:#}").contains("nope.scen"), "{err:#}");
}
