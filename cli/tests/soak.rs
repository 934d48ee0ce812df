//! `learner bench soak` (the `soak` feature) for 30 seconds. Ignored by
//! default: it needs the `actor` binary beside `learner` (build it first),
//! runs three processes on two cores for over half a minute, and learns
//! rm-2.1 only in release builds in that time. Run it with
//!
//! ```sh
//! cargo build --release -p buridan-actor
//! cargo test --release -p buridan-cli --features soak --test soak -- --ignored
//! ```

use std::path::PathBuf;
use std::process::Command;

#[test]
#[ignore = "needs the actor binary and half a minute of three processes; run with --ignored"]
fn a_short_soak_passes_and_writes_its_report() {
    let learner = PathBuf::from(env!("CARGO_BIN_EXE_learner"));
    let actor = learner.with_file_name("actor");
    assert!(
        actor.is_file(),
        "build the actor first: cargo build -p buridan-actor (same profile)"
    );
    let out = tempfile::tempdir().unwrap();
    let config = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../learner/configs/impala-ctde-rm-2.1.toml"
    );
    let status = Command::new(&learner)
        .args(["bench", "soak", "--minutes", "0.5", "--kill-every", "10"])
        .args(["--target", "0", "--sample-every", "2", "--config", config])
        .arg("--actor-exe")
        .arg(&actor)
        .arg("--out")
        .arg(out.path())
        .status()
        .unwrap();
    assert!(status.success(), "{status}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.path().join("soak.json")).unwrap())
            .unwrap();
    assert_eq!(json["failures"], serde_json::json!([]), "{json}");
    assert_eq!(json["books"]["used_twice"], 0, "{json}");
    assert_eq!(json["books"]["consumed_in_part"], 0, "{json}");
    assert!(json["books"]["consumed"].as_u64().unwrap() > 0, "{json}");
    for file in ["soak.csv", "soak.png", "soak.md"] {
        assert!(out.path().join(file).is_file(), "{file}");
    }
}
