//! Fuzz targets of the study files: TOML text →
//! `StudyConfig::from_toml_str` (which parses the `[space]` table too), and
//! durations → `parse_duration`. Nothing panics or allocates what a number
//! asks for; an accepted study has its documented ranges, and every
//! parameter of its space samples, grids and maps values to coordinates
//! within its bounds. Seeds are the shipped study files
//! (`learner/studies`, `docs/results/*/study.toml`). `BURIDAN_FUZZ_CASES`
//! sets the cases per target (default 256); `scripts/fuzz.sh` runs every
//! target with a million.

#[path = "../../env/tests/fuzz_support/mod.rs"]
mod fuzz_support;

use buridan_study::config::{parse_duration, ConfigError};
use buridan_study::sampler::{trial_rng, SamplerKind};
use buridan_study::StudyConfig;
use fuzz_support::{mutated_text, random_text, run};
use proptest::prelude::*;

const TOML_WORDS: &[&str] = &[
    "\n[space]\n",
    "\n[study]\n",
    "\n[study.scheduler]\n",
    "\nx = { int = [1, 9223372036854775807], step = 3 }\n",
    "\ny = { int = [-9223372036854775808, 9223372036854775807] }\n",
    "\nz = { uniform = [-1e308, 1e308] }\n",
    "\nw = { log_uniform = [1e-300, 1e300] }\n",
    "\nc = { choice = [1, \"a\", [2, 3], { t = 1 }] }\n",
    "\nd.e = { choice = [] }\n",
    "\nwall_time = \"4ß\"\n",
    "\nwall_time = \"1.5h\"\n",
    "\nwall_time = 0\n",
    "\nsampler = \"grid\"\n",
    "\nsampler = \"tpe\"\n",
    "\ngrid_points = 18446744073709551615\n",
    "\ngrid_points = 4611686018427387904\n",
    "\nkind = \"pbt\"\n",
    "\nkind = \"asha\"\n",
    "\nparallel = 2\n",
    "\ntrials = 3\n",
    "int",
    "uniform",
    "log_uniform",
    "choice",
    "step",
    " = ",
    "\"",
    "[",
    "]",
    "{",
    "}",
    ",",
    "#",
    "\n",
    "ß",
    "h",
];

/// The shipped study files.
fn seeds() -> Vec<String> {
    fuzz_support::shipped_tomls("study.toml", "[study]")
        .into_iter()
        .map(|(_, text)| text)
        .collect()
}

/// Parses `text`; true if accepted (then checked).
fn check_study(text: &str) -> Result<bool, TestCaseError> {
    let cfg = match StudyConfig::from_toml_str(text) {
        Ok(cfg) => cfg,
        Err(e) => {
            prop_assert!(!e.to_string().is_empty());
            if let ConfigError::Invalid { field, .. } = e {
                prop_assert!(!field.is_empty());
            }
            return Ok(false);
        }
    };
    prop_assert!(cfg.parallel >= 1 && cfg.trials >= 1);
    prop_assert!(cfg.steps_per_trial >= 1 && cfg.grid_points >= 1);
    if let Some(w) = cfg.wall_time {
        prop_assert!(!w.is_zero());
    }
    let params = cfg.space.params();
    prop_assert!(!params.is_empty());
    for p in params {
        let d = &p.domain;
        let (lo, hi) = d.internal_bounds();
        prop_assert!(lo <= hi, "{}: bounds {lo} {hi}", p.key);
        for i in 0..4 {
            let v = d.sample(&mut trial_rng(cfg.seed, i));
            let x = d.coordinate(&v);
            prop_assert!(x.is_some(), "{}: sampled {v} is outside its domain", p.key);
            let x = x.unwrap();
            prop_assert!(x >= lo && x <= hi, "{}: coordinate {x} of {v}", p.key);
        }
        for x in [lo, hi, (lo + hi) / 2.0, f64::NAN] {
            let v = d.value_at(x);
            prop_assert!(d.coordinate(&v).is_some(), "{}: value_at({x}) = {v}", p.key);
        }
    }
    // The samplers the study would build suggest values of the domains.
    for kind in [SamplerKind::Grid, SamplerKind::Random] {
        let sampler = kind.build(cfg.seed, cfg.grid_points);
        for index in 0..3 {
            if let Some(o) = sampler.suggest(&cfg.space, index, &[]) {
                for p in params {
                    let v = &o[&p.key];
                    prop_assert!(p.domain.coordinate(v).is_some(), "{}: {v}", p.key);
                }
            }
        }
    }
    Ok(true)
}

/// Study file text (a shipped study mutated, or random) →
/// `StudyConfig::from_toml_str`.
#[test]
fn fuzz_study_config() {
    let text = prop_oneof![
        8 => mutated_text(seeds(), TOML_WORDS),
        1 => random_text(),
    ];
    run("study_config", text, |text| check_study(&text));
}

/// Durations (`wall_time`): strings near `1.5h` and integers →
/// `parse_duration`: no panic; an accepted duration is positive and finite.
#[test]
fn fuzz_duration() {
    let value = prop_oneof![
        4 => mutated_text(
            vec!["1.5h".into(), "90m".into(), "3600s".into(), " 2 h".into()],
            &["ß", "é", "h", "m", "s", "-", ".", "e", "€"],
        )
        .prop_map(toml::Value::String),
        1 => random_text().prop_map(toml::Value::String),
        1 => any::<i64>().prop_map(toml::Value::Integer),
        1 => any::<f64>().prop_map(toml::Value::Float),
    ];
    run("duration", value, |v| match parse_duration(&v) {
        Err(e) => {
            prop_assert!(!e.is_empty());
            Ok(false)
        }
        Ok(d) => {
            prop_assert!(!d.is_zero() && d.as_secs_f64() < 1e12);
            Ok(true)
        }
    });
}

/// The seeds are accepted study files.
#[test]
fn fuzz_seeds_are_accepted() {
    let seeds = seeds();
    assert!(seeds.len() >= 10, "{} study files", seeds.len());
    for text in seeds {
        assert!(check_study(&text).unwrap(), "{text}");
    }
}

/// Found by `fuzz_duration`: a duration ending in a character of several
/// bytes (`4ß`) panicked (the unit was cut at the last byte).
#[test]
fn fuzz_regression_multibyte_duration_unit() {
    let e = parse_duration(&toml::Value::String("4ß".into())).unwrap_err();
    assert_eq!(e, "`4ß`: expected a number and s, m or h");
    let e = StudyConfig::from_toml_str(
        "[study]\nname = \"x\"\ntrials = 1\nsteps_per_trial = 1\nwall_time = \"ß\"\n[space]\nx = { int = [1, 2] }",
    )
    .unwrap_err();
    assert!(e.to_string().contains("wall_time"), "{e}");
    // Found next: a positive duration too small to be any time at all.
    let e = parse_duration(&toml::Value::String("1e-320h".into())).unwrap_err();
    assert_eq!(e, "must be positive");
}

/// Found by `fuzz_study_config`: an `int` range wider than 2^53 gave
/// values outside the range (the float coordinate rounded past `high`);
/// `[i64::MIN, i64::MAX]` overflowed.
#[test]
fn fuzz_regression_int_range_wider_than_floats_is_refused() {
    for range in [
        "[5, 130475633212263278]",
        "[-9223372036854775808, 9223372036854775807]",
    ] {
        let text = format!("x = {{ int = {range} }}");
        let e = buridan_study::SearchSpace::from_toml_str(&text).unwrap_err();
        assert!(e.to_string().contains("wider than 2^53"), "{e}");
    }
    let ok =
        buridan_study::SearchSpace::from_toml_str("x = { int = [0, 9007199254740992] }").unwrap();
    assert_eq!(
        ok.params()[0].domain.value_at(f64::MAX),
        toml::Value::Integer(1 << 53)
    );
}
