//! Search-space and study-file errors name the key and the problem.

use buridan_study::config::ConfigError;
use buridan_study::space::{Domain, Problem};
use buridan_study::{SearchSpace, StudyConfig};

fn problem(text: &str) -> (String, Problem) {
    let e = SearchSpace::from_toml_str(text).unwrap_err();
    (e.key, e.problem)
}

#[test]
fn each_mistake_has_its_own_error() {
    let cases: Vec<(&str, &str, Problem)> = vec![
        ("\"ppo.lr\" = 0.001", "ppo.lr", Problem::NotADomain),
        (
            "\"ppo.lr\" = { choice = [] }",
            "ppo.lr",
            Problem::EmptyChoice,
        ),
        (
            "ppo.lr = { uniform = [1, 1] }",
            "ppo.lr",
            Problem::EmptyRange {
                low: 1.0,
                high: 1.0,
            },
        ),
        (
            "ppo.lr = { log_uniform = [0, 1] }",
            "ppo.lr",
            Problem::NonPositiveLog,
        ),
        (
            "ppo.lr = { uniform = [0] }",
            "ppo.lr",
            Problem::BadBounds("numbers"),
        ),
        (
            "ppo.lr = { uniform = [\"a\", 1] }",
            "ppo.lr",
            Problem::BadBounds("numbers"),
        ),
        (
            "ppo.lr = { uniform = [0, inf] }",
            "ppo.lr",
            Problem::NotFinite,
        ),
        (
            "ppo.epochs = { int = [5.5, 14] }",
            "ppo.epochs",
            Problem::BadBounds("integers"),
        ),
        (
            "ppo.epochs = { int = [14, 5] }",
            "ppo.epochs",
            Problem::EmptyRange {
                low: 14.0,
                high: 5.0,
            },
        ),
        (
            "ppo.epochs = { int = [5, 14], step = 0 }",
            "ppo.epochs",
            Problem::BadStep,
        ),
        (
            "ppo.epochs = { int = [5, 14], stp = 2 }",
            "ppo.epochs",
            Problem::UnknownField("stp".into()),
        ),
        (
            "x = { uniform = [0, 1], choice = [1] }",
            "x",
            Problem::ManyDomains("choice, uniform".into()),
        ),
        ("[ppo]", "ppo", Problem::NotADomain),
        ("", "", Problem::Empty),
    ];
    for (text, key, expected) in cases {
        assert_eq!(problem(text), (key.to_string(), expected), "{text}");
    }
    let (key, p) = problem("x = { uniform = [0, 1] ");
    assert_eq!(key, "");
    assert!(matches!(p, Problem::Toml(_)));
}

#[test]
fn dotted_and_quoted_keys_mean_the_same() {
    let a = SearchSpace::from_toml_str("ppo.lr = { choice = [1e-4, 1e-3] }").unwrap();
    let b = SearchSpace::from_toml_str("\"ppo.lr\" = { choice = [1e-4, 1e-3] }").unwrap();
    let c = SearchSpace::from_toml_str("[ppo]\nlr = { choice = [1e-4, 1e-3] }").unwrap();
    assert_eq!(a, b);
    assert_eq!(a, c);
    assert_eq!(
        a.params()[0].domain,
        Domain::Choice(vec![1e-4.into(), 1e-3.into()])
    );
}

/// SPEC §4's PPO search space parses.
#[test]
fn the_dissertation_space_parses() {
    let s = SearchSpace::from_toml_str(
        r#"
        "ppo.epochs" = { int = [5, 14] }
        "ppo.clip" = { choice = [0.05, 0.1, 0.2, 0.3] }
        "ppo.lr" = { choice = [1e-4, 3e-4, 5e-4, 1e-3] }
        "ppo.entropy_coeff" = { choice = [0.0, 0.001, 0.01] }
        hidden = { choice = [[32, 32], [64, 64], [256, 256]] }
        "#,
    )
    .unwrap();
    assert_eq!(s.params().len(), 5);
    assert_eq!(
        buridan_study::sampler::GridSampler::new(10).size(&s),
        10 * 4 * 4 * 3 * 3
    );
}

#[test]
fn study_file_errors_name_the_field() {
    let base = "[study]\nname = \"x\"\ntrials = 2\nsteps_per_trial = 10\n";
    let space = "[space]\nx = { int = [1, 2] }\n";
    let err = |extra: &str, space: &str| {
        StudyConfig::from_toml_str(&format!("{base}{extra}{space}")).unwrap_err()
    };
    assert!(matches!(
        err("parallel = 0\n", space),
        ConfigError::Invalid {
            field: "parallel",
            ..
        }
    ));
    assert!(matches!(
        err("wall_time = \"4d\"\n", space),
        ConfigError::Invalid {
            field: "wall_time",
            ..
        }
    ));
    assert!(matches!(
        err("sampler = \"bayes\"\n", space),
        ConfigError::Study(_)
    ));
    assert!(matches!(err("trails = 3\n", space), ConfigError::Study(_)));
    assert!(matches!(
        err("", "[space]\nx = { int = [2, 1] }\n"),
        ConfigError::Space(_)
    ));
    assert!(matches!(err("", ""), ConfigError::Space(_)));
    assert!(matches!(
        err("[study.scheduler]\nkind = \"hyperband\"\n", space),
        ConfigError::Study(_)
    ));
    let ok = StudyConfig::from_toml_str(&format!(
        "{base}wall_time = \"30m\"\n[study.scheduler]\nkind = \"median\"\ngrace_steps = 5\n{space}"
    ))
    .unwrap();
    assert_eq!(ok.wall_time, Some(std::time::Duration::from_secs(1800)));
}
