//! Plant files: the bundled ones load, and each malformed case gives its
//! own error naming the file and the problem.

mod common;

use buridan_plant::{Plant, PlantError, PlantProblem};

fn parse(text: &str) -> Result<Plant, PlantError> {
    Plant::from_toml_str(text, "bad.toml")
}

fn base() -> String {
    common::corridor_text(1, 1, 1000, 10)
}

/// The semantic problem of `text`, panicking on any other outcome.
fn problem(text: &str) -> PlantProblem {
    match parse(text) {
        Err(PlantError::Invalid { file, problem }) => {
            assert_eq!(file, "bad.toml");
            problem
        }
        other => panic!("expected a semantic error, got {other:?}"),
    }
}

#[test]
fn bundled_plants_load_by_id_and_by_path() {
    let d = Plant::load("dissertation").unwrap();
    assert_eq!(
        (d.nodes.len(), d.segments.len(), d.starts.len()),
        (12, 11, 4)
    );
    assert_eq!(d.node_distance(d.node_index("w").unwrap(), d.sink), 65.0);
    let h = Plant::load("hall").unwrap();
    assert_eq!(h.starts.len(), 8);
    let dir = std::env::temp_dir().join(format!("buridan-plant-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("corridor.toml");
    std::fs::write(&path, base()).unwrap();
    let p = Plant::load(path.to_str().unwrap()).unwrap();
    assert_eq!(p.id, "corridor");
    // s1 20 m + sk 15 m.
    assert_eq!(
        p.node_distance(p.node_index("src_a").unwrap(), p.sink),
        35.0
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn unknown_id_lists_the_bundled_ones() {
    let err = Plant::load("warehouse-9").unwrap_err();
    assert!(matches!(&err, PlantError::UnknownPlant { name, .. } if name == "warehouse-9"));
    assert!(err.to_string().contains("dissertation, hall"), "{err}");
}

#[test]
fn unreadable_file_is_an_io_error() {
    let err = Plant::from_file(std::path::Path::new("/nonexistent/plant.toml")).unwrap_err();
    assert!(matches!(err, PlantError::Io { .. }));
    assert!(err
        .to_string()
        .starts_with("cannot read plant file /nonexistent/plant.toml"));
}

#[test]
fn toml_syntax_error_names_its_line() {
    let text = "id = \"x\"\nstarts = [\"s1\"\n[agv]\n";
    match parse(text) {
        Err(PlantError::Syntax { file, line, .. }) => {
            assert_eq!(file, "bad.toml");
            assert_eq!(line, Some(3));
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn unknown_key_is_a_syntax_error_at_its_line() {
    // Line 9 of the base text is `speed = 1.0` inside [agv].
    let text = base().replace("speed = 1.0", "sped = 1.0");
    let line = text.lines().position(|l| l.starts_with("sped")).unwrap() + 1;
    match parse(&text) {
        Err(PlantError::Syntax {
            line: got, message, ..
        }) => {
            assert_eq!(got, Some(line));
            assert!(message.contains("unknown field `sped`"), "{message}");
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn missing_key_is_a_syntax_error() {
    let text = base().replace(", interarrival = 1000000.0 }", " }");
    match parse(&text) {
        Err(PlantError::Syntax { message, .. }) => {
            assert!(
                message.contains("missing field `interarrival`"),
                "{message}"
            )
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn segment_with_unknown_node() {
    let text = base().replace("from = \"m\"\nto = \"src_b\"", "from = \"m\"\nto = \"n9\"");
    let p = problem(&text);
    assert_eq!(
        p,
        PlantProblem::UnknownNode {
            item: "segment s2".into(),
            node: "n9".into()
        }
    );
    let err = parse(&text).unwrap_err();
    assert_eq!(
        err.to_string(),
        "bad.toml: segment s2 references unknown node n9"
    );
}

#[test]
fn station_with_unknown_node() {
    let text = base().replace("node = \"sink\"", "node = \"drain\"");
    assert_eq!(
        problem(&text),
        PlantProblem::UnknownNode {
            item: "sink".into(),
            node: "drain".into()
        }
    );
}

#[test]
fn duplicate_ids() {
    let text = base().replace("id = \"d\"", "id = \"m\"");
    assert_eq!(
        problem(&text),
        PlantProblem::DuplicateId {
            kind: "node",
            id: "m".into()
        }
    );
    let text = base().replace("id = \"sd\"", "id = \"sk\"");
    assert_eq!(
        problem(&text),
        PlantProblem::DuplicateId {
            kind: "segment",
            id: "sk".into()
        }
    );
}

#[test]
fn self_loop_and_parallel_segments() {
    let text = base().replace("from = \"m\"\nto = \"d\"", "from = \"d\"\nto = \"d\"");
    assert_eq!(
        problem(&text),
        PlantProblem::SelfLoop {
            segment: "sd".into(),
            node: "d".into()
        }
    );
    let text = base().replace("from = \"m\"\nto = \"d\"", "from = \"src_b\"\nto = \"m\"");
    assert!(matches!(
        problem(&text),
        PlantProblem::ParallelSegments { first, second, .. } if first == "s2" && second == "sd"
    ));
}

#[test]
fn lengths_must_be_positive_and_not_shorter_than_the_straight_line() {
    let text = base().replace("length = 8.0", "length = 0.0");
    assert_eq!(
        problem(&text),
        PlantProblem::NotPositive {
            item: "segment sd".into(),
            field: "length",
            value: 0.0
        }
    );
    // m (20,0) to d (25,-5) is 7.071 m apart.
    let text = base().replace("length = 8.0", "length = 7.0");
    assert!(matches!(
        problem(&text),
        PlantProblem::ShorterThanStraight { segment, length, distance }
            if segment == "sd" && length == 7.0 && (distance - 50f64.sqrt()).abs() < 1e-12
    ));
}

#[test]
fn parameters_must_be_positive() {
    let text = base().replace("speed = 1.0", "speed = -2.0");
    assert_eq!(
        problem(&text),
        PlantProblem::NotPositive {
            item: "agv".into(),
            field: "speed",
            value: -2.0
        }
    );
    let text = base().replacen("process_time = 10.0", "process_time = 0.0", 1);
    assert_eq!(
        problem(&text),
        PlantProblem::NotPositive {
            item: "unit of product A".into(),
            field: "process_time",
            value: 0.0
        }
    );
}

#[test]
fn disconnected_node() {
    let text = base().replace(
        "[[segments]]\nid = \"sd\"\nfrom = \"m\"\nto = \"d\"\nlength = 8.0\n",
        "",
    );
    assert_eq!(
        problem(&text),
        PlantProblem::Disconnected {
            node: "d".into(),
            reference: "src_a".into()
        }
    );
}

#[test]
fn products_must_be_a_and_b() {
    let text = base().replace("id = \"B\"", "id = \"C\"");
    assert_eq!(
        problem(&text),
        PlantProblem::Products { got: "A, C".into() }
    );
}

#[test]
fn stations_must_not_share_nodes() {
    let text = base().replace("node = \"sink\"", "node = \"unit_b\"");
    assert_eq!(
        problem(&text),
        PlantProblem::SharedStation {
            first: "unit of product B".into(),
            second: "sink".into(),
            node: "unit_b".into()
        }
    );
}

#[test]
fn start_problems() {
    let text = base().replace("starts = [\"s2\", \"s1\"]", "starts = []");
    assert_eq!(problem(&text), PlantProblem::NoStarts);
    let text = base().replace("starts = [\"s2\", \"s1\"]", "starts = [\"s2\", \"s7\"]");
    assert_eq!(
        problem(&text),
        PlantProblem::UnknownSegment {
            index: 1,
            segment: "s7".into()
        }
    );
    let text = base().replace("starts = [\"s2\", \"s1\"]", "starts = [\"s2\", \"s2\"]");
    assert_eq!(
        problem(&text),
        PlantProblem::SharedStart {
            first: 0,
            second: 1,
            segment: "s2".into()
        }
    );
    let text = base()
        .replace("starts = [\"s2\", \"s1\"]", "starts = [\"sd\"]")
        .replace("length = 1.0", "length = 5.0");
    assert_eq!(
        problem(&text),
        PlantProblem::StartTooShort {
            index: 0,
            segment: "sd".into(),
            length: 8.0,
            needed: 10.0
        }
    );
}

#[test]
fn numbers_out_of_range() {
    let text = base().replacen("x = 20.0", "x = nan", 1);
    assert_eq!(
        problem(&text).to_string(),
        "node m: x must be a finite number, got NaN"
    );
    let text = base().replacen("capacity = 4,", "capacity = 4000000,", 1);
    assert_eq!(
        problem(&text),
        PlantProblem::OutOfRange {
            item: "source of product A".into(),
            field: "capacity",
            value: 4_000_000.0,
            range: "at most 10000"
        }
    );
}
