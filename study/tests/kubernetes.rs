//! The Indexed Job manifest, parsed back by a small reader of the YAML
//! subset it uses (block mappings and sequences, JSON-quoted or plain
//! scalars); and the batch flow a cluster runs.

use buridan_study::k8s::IndexedJob;
use buridan_study::*;
use serde_json::{json, Value};

/// Parses block YAML (2-space indents, `key: value`, `key:`, `- item`).
fn parse_yaml(text: &str) -> Value {
    let mut lines: Vec<(usize, String)> = text
        .lines()
        .filter(|l| !l.trim().is_empty() && !l.trim_start().starts_with('#'))
        .map(|l| (l.len() - l.trim_start().len(), l.trim_start().to_string()))
        .collect();
    let mut i = 0;
    let v = block(&mut lines, &mut i, 0);
    assert_eq!(i, lines.len(), "unparsed line {:?}", lines.get(i));
    v
}

fn scalar(s: &str) -> Value {
    if s.starts_with('"') {
        serde_json::from_str(s).expect("a JSON-quoted string")
    } else if let Ok(n) = s.parse::<i64>() {
        json!(n)
    } else if s == "true" || s == "false" {
        json!(s == "true")
    } else {
        assert!(
            !s.contains(": ") && !s.starts_with(['{', '[', '&', '*', '!', '|', '>']),
            "unsafe plain scalar {s:?}"
        );
        json!(s)
    }
}

fn block(lines: &mut Vec<(usize, String)>, i: &mut usize, indent: usize) -> Value {
    if lines[*i].1.starts_with("- ") {
        let mut items = Vec::new();
        while *i < lines.len() && lines[*i].0 == indent && lines[*i].1.starts_with("- ") {
            let rest = lines[*i].1[2..].to_string();
            if !rest.starts_with('"') && (rest.contains(": ") || rest.ends_with(':')) {
                // A mapping item: its first key sits two columns in.
                lines[*i] = (indent + 2, rest);
                items.push(block(lines, i, indent + 2));
            } else {
                items.push(scalar(&rest));
                *i += 1;
            }
        }
        return Value::Array(items);
    }
    let mut map = serde_json::Map::new();
    while *i < lines.len() && lines[*i].0 == indent {
        let line = lines[*i].1.clone();
        let (key, rest) = line.split_once(':').expect("key: value");
        let rest = rest.trim();
        *i += 1;
        let value = if rest.is_empty() {
            let child = lines[*i].0;
            assert!(
                child > indent || lines[*i].1.starts_with("- "),
                "empty value for {key}"
            );
            block(lines, i, child)
        } else {
            scalar(rest)
        };
        assert!(
            map.insert(key.to_string(), value).is_none(),
            "duplicate key {key}"
        );
    }
    assert!(
        *i >= lines.len() || lines[*i].0 < indent,
        "bad indent at {:?}",
        lines.get(*i)
    );
    Value::Object(map)
}

#[test]
fn the_manifest_parses_back_to_an_indexed_job() {
    let mut job = IndexedJob::new(
        "tune-ppo-rm-2-1",
        "registry.example/buridan/learner:v1",
        vec![
            "tune".into(),
            "trial".into(),
            "/study".into(),
            "--index={index}".into(),
            "--note=a \"quoted\": value".into(),
        ],
        40,
    );
    job.parallelism = 10;
    job.namespace = Some("research".into());
    job.cpu = "2".into();
    let v = parse_yaml(&job.to_yaml().unwrap());
    assert_eq!(v["apiVersion"], "batch/v1");
    assert_eq!(v["kind"], "Job");
    assert_eq!(v["metadata"]["name"], "tune-ppo-rm-2-1");
    assert_eq!(v["metadata"]["namespace"], "research");
    let spec = &v["spec"];
    assert_eq!(spec["completionMode"], "Indexed");
    assert_eq!(
        (spec["completions"].as_i64(), spec["parallelism"].as_i64()),
        (Some(40), Some(10))
    );
    assert_eq!(spec["backoffLimitPerIndex"], 1);
    let pod = &spec["template"]["spec"];
    assert_eq!(pod["restartPolicy"], "Never");
    assert_eq!(
        spec["template"]["metadata"]["labels"],
        v["metadata"]["labels"]
    );
    let c = &pod["containers"][0];
    assert_eq!(c["image"], "registry.example/buridan/learner:v1");
    assert_eq!(
        c["args"],
        json!([
            "tune",
            "trial",
            "/study",
            "--index=$(JOB_COMPLETION_INDEX)",
            "--note=a \"quoted\": value"
        ])
    );
    assert_eq!(
        c["resources"]["requests"],
        json!({"cpu": "2", "memory": "2Gi"})
    );
    assert_eq!(c["resources"]["limits"], c["resources"]["requests"]);
    assert_eq!(
        c["volumeMounts"][0],
        json!({"name": "results", "mountPath": "/study"})
    );
    assert_eq!(
        pod["volumes"][0],
        json!({"name": "results", "persistentVolumeClaim": {"claimName": "buridan-study"}})
    );
}

#[test]
fn invalid_jobs_are_refused_with_the_field() {
    let ok = IndexedJob::new("t", "img", vec![], 1);
    let cases: Vec<(IndexedJob, &str)> = vec![
        (
            IndexedJob {
                name: "-t".into(),
                ..ok.clone()
            },
            "name",
        ),
        (
            IndexedJob {
                name: "a".repeat(64),
                ..ok.clone()
            },
            "name",
        ),
        (
            IndexedJob {
                image: " ".into(),
                ..ok.clone()
            },
            "image",
        ),
        (
            IndexedJob {
                completions: 0,
                ..ok.clone()
            },
            "completions",
        ),
        (
            IndexedJob {
                parallelism: 0,
                ..ok.clone()
            },
            "parallelism",
        ),
        (
            IndexedJob {
                mount_path: "study".into(),
                ..ok.clone()
            },
            "mount_path",
        ),
        (
            IndexedJob {
                volume_claim: "Claim".into(),
                ..ok.clone()
            },
            "volume_claim",
        ),
        (
            IndexedJob {
                namespace: Some("a_b".into()),
                ..ok.clone()
            },
            "namespace",
        ),
    ];
    for (job, field) in cases {
        assert_eq!(job.to_yaml().unwrap_err().field, field);
    }
}

/// Plan a batch, run each index as a pod would (from the spec on the
/// shared volume), collect, and report.
#[test]
fn a_batch_runs_by_index_and_is_collected() {
    struct Pod;
    impl TrialRunner for Pod {
        fn run(&self, spec: &TrialSpec, r: &mut dyn Reporter) -> Result<Measurement, TrialError> {
            assert!(spec.run_dir.join("trial.json").exists());
            let x = spec.overrides["x"].as_integer().unwrap() as f64;
            if x == 7.0 {
                return Err(TrialError::new("out of memory"));
            }
            let m = Measurement {
                step: spec.steps,
                train_success: Some(x / 10.0),
                ..Default::default()
            };
            r.report(&Measurement {
                step: spec.steps / 2,
                train_success: Some(x / 20.0),
                ..Default::default()
            });
            Ok(m)
        }
    }
    let cfg = StudyConfig::from_toml_str(
        "[study]\nname = \"batch\"\nsampler = \"grid\"\ngrid_points = 9\ntrials = 9\nsteps_per_trial = 100\n[space]\nx = { int = [1, 9] }",
    )
    .unwrap();
    let planner = tempfile::tempdir().unwrap();
    let mut study = Study::open(planner.path(), cfg.clone()).unwrap();
    let ids = study.plan(20).unwrap();
    assert_eq!(ids.len(), 9, "capped at the study's trials");
    let job = IndexedJob::new(
        "batch",
        "img",
        vec![
            "tune".into(),
            "trial".into(),
            "/study".into(),
            "--index={index}".into(),
        ],
        ids.len() as u32,
    );
    assert!(job.to_yaml().is_ok());
    // The volume is mounted elsewhere in the pods: copy it, as a shared volume would appear.
    let volume = tempfile::tempdir().unwrap();
    copy_dir(planner.path(), volume.path());
    for &i in &ids {
        buridan_study::batch::run_trial(volume.path(), i, &Pod).unwrap();
    }
    let mut study = Study::open(volume.path(), cfg).unwrap();
    assert_eq!(study.collect().unwrap(), 9);
    let p = study.progress();
    assert_eq!((p.completed, p.failed, p.planned), (8, 1, 0));
    let best = study.state().best().unwrap();
    assert_eq!(best.overrides["x"].as_integer(), Some(9));
    assert_eq!(best.reports.len(), 1);
    study.write_outputs().unwrap();
    assert!(volume.path().join("best.toml").exists());
    // Collecting again changes nothing.
    assert_eq!(study.collect().unwrap(), 0);
}

fn copy_dir(from: &std::path::Path, to: &std::path::Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let target = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &target);
        } else {
            std::fs::copy(e.path(), target).unwrap();
        }
    }
}
