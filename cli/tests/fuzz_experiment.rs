//! Fuzz target of the experiment files: TOML text →
//! `Experiment::from_str` (`learner study`'s `[experiment]` and
//! `[[method]]` tables, resolved against the file's directory). Nothing
//! panics or allocates what a number asks for; an accepted experiment has
//! its documented ranges and a plan of the size its tables imply. Seeds are
//! the shipped experiment files (`learner/studies`,
//! `docs/results/*/experiment.toml`). `BURIDAN_FUZZ_CASES` sets the cases
//! (default 256); `scripts/fuzz.sh` runs every target with a million.

#[path = "../../env/tests/fuzz_support/mod.rs"]
mod fuzz_support;

use std::path::{Path, PathBuf};

use buridan_cli::experiment::Experiment;
use fuzz_support::{mutate, mutation, random_text, run};
use proptest::prelude::*;

const TOML_WORDS: &[&str] = &[
    "\n[experiment]\n",
    "\n[experiment.eval]\n",
    "\n[[method]]\nname = \"m\"\nconfig = \"x.toml\"\n",
    "\nseeds = 18446744073709551615\n",
    "\nseeds = 1000000000000\n",
    "\nseeds = []\n",
    "\nagents = \"1-1000000000000\"\n",
    "\nagents = \"4,8,,\"\n",
    "\nagents = [0]\n",
    "\nepisodes = 0\n",
    "\nparallel = 0\n",
    "\ntime_limit = nan\n",
    "\nrescue_time = inf\n",
    "\nrescue_planner = \"pibt+lacam\"\n",
    "\nplanners = [\"pibt\", \"random\", \"x\"]\n",
    "\nlayouts = [\"rm-2.2:1+rm-3.1:2\"]\n",
    "\nlayouts = [\"maps/comb.map\"]\n",
    "\nlayouts = []\n",
    "\nactions = [\"greedy\", \"lookahead:pibt\"]\n",
    "rm-2.1",
    "rm-1.1",
    " = ",
    "\"",
    "[",
    "]",
    "{",
    "}",
    ",",
    "#",
    "\n",
    "..",
    "/",
];

/// The shipped experiment files, each with its path (relative names in it
/// resolve against its directory).
fn seeds() -> Vec<(PathBuf, String)> {
    fuzz_support::shipped_tomls("experiment.toml", "[experiment]")
}

/// Parses `text` as the file `path`; true if accepted (then checked).
fn check_experiment(path: &Path, text: &str) -> Result<bool, TestCaseError> {
    let x = match Experiment::from_str(text, path) {
        Ok(x) => x,
        Err(e) => {
            prop_assert!(!e.problem.is_empty());
            return Ok(false);
        }
    };
    prop_assert!(!x.name.trim().is_empty());
    prop_assert!(!x.layouts.is_empty() && !x.eval_layouts().is_empty());
    prop_assert!(x.parallel >= 1 && x.eval.episodes >= 1);
    prop_assert!(x.eval.time_limit > 0.0 && x.eval.time_limit.is_finite());
    prop_assert!(x.eval.rescue_time > 0.0 && x.eval.rescue_time.is_finite());
    if let Some(a) = &x.eval.agents {
        prop_assert!(!a.is_empty() && !a.contains(&0));
    }
    prop_assert!(!x.methods.is_empty() || !x.planners.is_empty());
    // One training run per method, layout and seed.
    prop_assert!(x.train.len() <= x.methods.len() * x.layouts.len() * x.seeds.len());
    Ok(true)
}

/// Experiment file text (a shipped file mutated, or random) →
/// `Experiment::from_str`.
#[test]
fn fuzz_experiment() {
    let seeds = seeds();
    assert!(seeds.len() >= 10, "{} experiment files", seeds.len());
    let n = seeds.len();
    let input = prop_oneof![
        8 => (0..n, prop::collection::vec(mutation(TOML_WORDS), 0..8)).prop_map(
            move |(i, ms)| (i, String::from_utf8_lossy(&mutate(seeds[i].1.as_bytes(), &ms)).into_owned())
        ),
        1 => (0..n, random_text()),
    ];
    let paths: Vec<PathBuf> = self::seeds().into_iter().map(|(p, _)| p).collect();
    run("experiment", input, |(i, text)| {
        check_experiment(&paths[i], &text)
    });
}

/// The shipped studies are accepted experiment files (the copies kept in
/// `docs/results` may name configs that are not kept with them).
#[test]
fn fuzz_seeds_are_accepted() {
    for (path, text) in seeds() {
        let accepted = check_experiment(&path, &text).unwrap();
        assert!(
            accepted || path.starts_with(Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs")),
            "{}",
            path.display()
        );
    }
}

/// Found by `fuzz_experiment`: `seeds = N` collected N seeds before any
/// check (the process aborted allocating exabytes); agent ranges and the
/// plan's product of lists were unbounded too.
#[test]
fn fuzz_regression_huge_plans_are_refused() {
    let (path, text) = seeds()
        .into_iter()
        .find(|(_, t)| {
            t.contains("\nseeds = 10\n")
                && t.contains("\n[experiment.eval]\n")
                && !t.contains("\nagents")
        })
        .expect("an experiment with seeds = 10 and an eval table without agents");
    for (from, to, expected) in [
        (
            "\nseeds = 10\n",
            "\nseeds = 4855501409260978888\n",
            "at most 100000 runs",
        ),
        ("\nseeds = 10\n", "\nseeds = 100000\n", "the plan has"),
        (
            "\n[experiment.eval]\n",
            "\n[experiment.eval]\nagents = \"1..1000000000000\"\n",
            "at most 65534",
        ),
    ] {
        let e = Experiment::from_str(&text.replacen(from, to, 1), &path).unwrap_err();
        assert!(e.problem.contains(expected), "{}", e.problem);
    }
}
