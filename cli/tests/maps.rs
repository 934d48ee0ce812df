//! `learner maps` and generated maps wherever a map name is taken.

mod common;

use std::process::Command;

use buridan_env::generate::GeneratedMap;
use buridan_env::Map;

fn learner(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_learner"))
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn maps_lists_the_reference_models_and_the_generators() {
    let out = learner(&["maps"]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("rm-2.1 "), "{text}");
    for family in ["maze/HxW", "braid/HxW", "random/HxW", "warehouse/HxW"] {
        assert!(text.contains(family), "{family} missing:\n{text}");
    }
}

#[test]
fn maps_writes_a_generated_map_that_loads_back_as_the_same_grid() {
    let dir = std::env::temp_dir().join(format!("buridan-cli-maps-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("braid.map");
    let out = learner(&[
        "maps",
        "--generate",
        "braid/21x19/loops=0.25/seed=4",
        "--out",
        file.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let spec: GeneratedMap = "braid/21x19/loops=0.25/seed=4".parse().unwrap();
    assert_eq!(
        Map::from_file(&file).unwrap().grid.walls(),
        spec.grid().walls()
    );
    // Without --out, the text goes to standard output.
    let out = learner(&["maps", "--generate", "braid/21x19/loops=0.25/seed=4"]);
    assert_eq!(
        String::from_utf8(out.stdout).unwrap(),
        std::fs::read_to_string(&file).unwrap()
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_bad_spec_is_refused_naming_its_problem() {
    let out = learner(&["maps", "--generate", "braid/20x19/seed=0"]);
    assert!(!out.status.success());
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(err.contains("odd") && err.contains("20x19"), "{err}");
    let out = learner(&[
        "eval",
        "--map",
        "random/9x9/density=2/seed=0",
        "--controller",
        "pibt",
        "--out",
        std::env::temp_dir()
            .join("buridan-cli-maps-bad")
            .to_str()
            .unwrap(),
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(err.contains("density = '2'"), "{err}");
}

#[test]
fn eval_plans_on_generated_maps() {
    let dir = std::env::temp_dir().join(format!("buridan-cli-maps-eval-{}", std::process::id()));
    for (map, controller) in [
        ("maze/19x19/seed=0", "lacam"),
        ("warehouse/33x46/seed=0", "pibt"),
    ] {
        let args = common::eval_args(&[
            "--map",
            map,
            "--agents",
            "16",
            "--episodes",
            "3",
            "--controller",
            controller,
            "--rules",
            "pogema",
            "--out",
            dir.to_str().unwrap(),
        ]);
        let summaries = buridan_cli::eval::run(&args).unwrap();
        assert_eq!(summaries[0].map, map);
        assert_eq!(summaries[0].success_rate, 1.0, "{map} {controller}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
