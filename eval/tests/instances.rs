//! Instance sets from `.scen` files: loading, typed errors on bad input,
//! and an evaluation under pogema rules with POGEMA's metrics.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use buridan_env::{MapError, Rules};
use buridan_eval::instances::{load_instance_set, ScenError};
use buridan_eval::planner::PlannerController;
use buridan_eval::{evaluate_instances, Controller, EvalSpec};
use buridan_mapf::{planner_for_rules, Limits};

/// A 3×5 map with a wall in the middle of the middle row.
const MAP: &str = "type octile\nheight 3\nwidth 5\nmap\n.....\n..@..\n.....\n";

fn line(sx: usize, sy: usize, gx: usize, gy: usize) -> String {
    format!("0\tsmall.map\t5\t3\t{sx}\t{sy}\t{gx}\t{gy}\t0\n")
}

/// A fresh directory with `small.map` and the given `.scen` files.
fn dir_with(name: &str, files: &[(&str, String)]) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("buridan-instances-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("small.map"), MAP).unwrap();
    for (file, text) in files {
        std::fs::write(dir.join(file), text).unwrap();
    }
    dir
}

fn scen(lines: &[String]) -> String {
    format!("version 1\n{}", lines.concat())
}

#[test]
fn a_directory_is_its_scen_files_in_natural_order_on_the_map_they_name() {
    let two = scen(&[line(0, 0, 4, 0), line(0, 2, 4, 2)]);
    let dir = dir_with(
        "order",
        &[
            ("s-10.scen", two.clone()),
            ("s-2.scen", two.clone()),
            ("notes.txt", "x".into()),
        ],
    );
    let set = load_instance_set(std::slice::from_ref(&dir), None, None).unwrap();
    let names: Vec<&str> = set.instances.iter().map(|i| i.name.as_str()).collect();
    assert_eq!(names, ["s-2.scen", "s-10.scen"]);
    assert_eq!((set.map.name.as_str(), set.agents()), ("small", 2));
    // The first N lines; files and directories mix.
    let set = load_instance_set(
        &[dir.join("s-10.scen"), dir.clone()],
        Some("rm-3.1"),
        Some(1),
    );
    // rm-3.1 is not 5×3: the env's loader names the file and line.
    let err = set.unwrap_err().to_string();
    assert!(
        err.contains("s-10.scen:2: scenario is for a 5x3 map"),
        "{err}"
    );
    let set = load_instance_set(&[dir.join("s-10.scen"), dir.clone()], None, Some(1)).unwrap();
    assert_eq!(set.instances.len(), 3);
    assert_eq!(set.agents(), 1);
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn bad_instance_files_give_typed_errors_naming_file_and_line() {
    let ok = line(0, 0, 4, 0);
    let dir = dir_with(
        "bad",
        &[
            (
                "fields.scen",
                format!("version 1\n{ok}0\tsmall.map\t5\t3\t1\t1\t1\n"),
            ),
            ("wall.scen", scen(&[ok.clone(), line(2, 1, 0, 2)])),
            ("shared.scen", scen(&[ok.clone(), line(1, 2, 4, 0)])),
            (
                "other-map.scen",
                "version 1\n0\tbig.map\t5\t3\t0\t0\t4\t0\t0\n".into(),
            ),
            ("empty.scen", "version 1\n".into()),
        ],
    );
    let load = |file: &str, agents: Option<usize>| {
        load_instance_set(&[dir.join(file)], None, agents).unwrap_err()
    };
    let err = load("fields.scen", None);
    assert!(
        matches!(&err, ScenError::Map(MapError::Parse { line: 3, file, .. }) if file.ends_with("fields.scen")),
        "{err}"
    );
    assert!(err.to_string().contains("expected 9 fields"), "{err}");
    let err = load("wall.scen", None);
    assert!(
        matches!(&err, ScenError::Map(MapError::Parse { line: 3, .. })),
        "{err}"
    );
    assert!(
        err.to_string().contains("start x=2 y=1 is on a wall"),
        "{err}"
    );
    let err = load("shared.scen", None);
    assert!(
        matches!(
            &err,
            ScenError::SharedCell {
                line: 3,
                agent: 1,
                which: "goal",
                other: 0,
                other_line: 2,
                ..
            }
        ),
        "{err}"
    );
    let err = load("wall.scen", Some(1));
    assert!(
        err.to_string().contains("wall.scen"),
        "taking the first line only still parses the file: {err}"
    );
    let err = load_instance_set(
        &[dir.join("fields.scen")],
        Some(dir.join("small.map").to_str().unwrap()),
        Some(5),
    );
    assert!(err.is_err());
    let two = dir_with(
        "two",
        &[("a.scen", scen(&[line(0, 0, 4, 0), line(0, 2, 4, 2)]))],
    );
    let err = load_instance_set(&[two.join("a.scen")], None, Some(3)).unwrap_err();
    assert!(
        matches!(&err, ScenError::TooFewLines { requested: 3, lines: 2, file } if file.ends_with("a.scen")),
        "{err}"
    );
    let err = load("other-map.scen", None);
    assert!(
        matches!(&err, ScenError::Map(MapError::Io { path, .. }) if path.ends_with("big.map")),
        "{err}"
    );
    let err = load("empty.scen", None);
    assert!(
        matches!(&err, ScenError::NoAgents { file } if file.ends_with("empty.scen")),
        "{err}"
    );
    let err = load("missing.scen", None);
    assert!(
        matches!(&err, ScenError::Io { path, .. } if path.ends_with("missing.scen")),
        "{err}"
    );
    let empty_dir = dir.join("nothing");
    std::fs::create_dir_all(&empty_dir).unwrap();
    let err = load_instance_set(std::slice::from_ref(&empty_dir), None, None).unwrap_err();
    assert!(matches!(err, ScenError::EmptyDirectory { .. }), "{err}");
    let mixed = dir_with(
        "mixed",
        &[
            ("a.scen", scen(&[line(0, 0, 4, 0)])),
            ("b.scen", scen(&[line(0, 0, 4, 0), line(0, 2, 4, 2)])),
        ],
    );
    let err = load_instance_set(std::slice::from_ref(&mixed), None, None).unwrap_err();
    assert!(
        matches!(
            err,
            ScenError::MixedAgentCounts {
                lines: 2,
                first_lines: 1,
                ..
            }
        ),
        "{err}"
    );
    for d in [dir, two, mixed] {
        let _ = std::fs::remove_dir_all(d);
    }
}

/// The POGEMA warehouse's first two seeds with 8 agents under pogema rules:
/// LaCAM solves both; SoC, makespan and ISR follow POGEMA's definitions.
#[test]
fn lacam_on_pogema_instances_reports_pogema_metrics() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../mapf/tests/data/pogema");
    let files = [
        data.join("warehouse-32-0.scen"),
        data.join("warehouse-32-1.scen"),
    ];
    let set = load_instance_set(&files, None, Some(8)).unwrap();
    assert_eq!(set.map.name, "warehouse");
    let spec = EvalSpec {
        agents: 8,
        rules: Rules::Pogema,
        t_max: Rules::Pogema.default_t_max(),
        ..EvalSpec::default()
    };
    let planner: Arc<dyn buridan_mapf::Planner> =
        planner_for_rules("lacam", Rules::Pogema).unwrap().into();
    let make = move || -> Box<dyn Controller> {
        Box::new(PlannerController::new(planner.clone(), Limits::default()))
    };
    let report = evaluate_instances(&set.map, &spec, &set.instances, &make, &|_| {}).unwrap();
    let s = &report.summary;
    assert_eq!(
        (s.rules, s.t_max, s.instances, s.success_rate),
        (Rules::Pogema, 128, 2, 1.0)
    );
    for (r, inst) in report.records.iter().zip(&set.instances) {
        assert_eq!(r.instance.as_deref(), Some(inst.name.as_str()));
        assert!(r.success && r.isr == 1.0, "{r:?}");
        let lb = r.soc_lower_bound.unwrap();
        assert!(r.soc >= lb && lb > 0, "{r:?}");
        assert_eq!(r.makespan, r.timesteps, "{r:?}");
        assert_eq!(Some(r.makespan), r.plan_makespan, "{r:?}");
    }
    assert!(s.soc_ratio_median.unwrap() >= 1.0);
    assert_eq!(s.isr_mean, 1.0);
}
