//! The experiment planner's unit tests.

use super::*;
use buridan_learner::train::TrainConfig;

fn write_config(dir: &Path) -> PathBuf {
    let p = dir.join("tiny.toml");
    std::fs::write(
        &p,
        "map = \"rm-1.1\"\nagents = 2\nsteps = 3000\n[ppo]\ntrain_batch = 1000\n",
    )
    .unwrap();
    p
}

#[test]
fn cells_cover_layouts_methods_seeds_actions_and_agents() {
    let dir = tempfile::tempdir().unwrap();
    write_config(dir.path());
    let file = dir.path().join("exp.toml");
    let x = Experiment::from_str(
        r#"
        [experiment]
        name = "t"
        layouts = ["rm-1.1", "rm-2.1"]
        seeds = 3
        planners = ["cbs"]
        [experiment.eval]
        agents = "2..4"
        [[method]]
        name = "ppo"
        config = "tiny.toml"
        set = ["ppo.lr=5e-4"]
        "#,
        &file,
    )
    .unwrap();
    assert_eq!(x.train.len(), 2 * 3);
    // 2 layouts × 3 seeds × 2 action modes × 3 agent counts, + 2 × cbs × 3.
    assert_eq!(x.evals.len(), 36 + 6);
    let cmd = x.train[4].command(Path::new("out"));
    assert!(cmd.contains("--map rm-2.1 --seed 1"), "{cmd}");
    assert!(cmd.contains("--set ppo.lr=5e-4"), "{cmd}");
    assert!(cmd.ends_with("--out out/runs/rm-2.1/ppo/seed-1"), "{cmd}");
    let e = x.eval_command(&x.evals[0], Path::new("out"));
    assert!(
        e.contains("--controller checkpoint:out/runs/rm-1.1/ppo/seed-0"),
        "{e}"
    );
    assert!(e.contains("--sample"), "{e}");
    let p = x.evals.iter().find(|c| c.method == "cbs").unwrap();
    assert!(x
        .eval_command(p, Path::new("out"))
        .contains("--controller cbs"));
}

#[test]
fn a_method_with_stop_false_trains_its_whole_budget() {
    let dir = tempfile::tempdir().unwrap();
    let x = Experiment::from_str(
        r#"
        [experiment]
        name = "s"
        layouts = ["rm-2.1"]
        seeds = 1
        steps = 50_000
        [[method]]
        name = "recipe"
        [[method]]
        name = "whole"
        stop = false
        "#,
        &dir.path().join("s.toml"),
    )
    .unwrap();
    let (recipe, whole) = (&x.train[0], &x.train[1]);
    assert!(!recipe.no_stop && whole.no_stop);
    let out = Path::new("out");
    assert!(recipe.config_in(out).unwrap().run.stop.is_some());
    assert_eq!(whole.config_in(out).unwrap().run.stop, None);
    let cmd = whole.command(out);
    assert!(
        cmd.contains("--steps 50000 --no-stop --resume auto"),
        "{cmd}"
    );
    assert!(!recipe.command(out).contains("--no-stop"));
    // A plan written before the key existed reads as stopping.
    let old = serde_json::to_value(recipe).unwrap();
    assert!(old.get("no_stop").is_none(), "{old}");
    let back: TrainCell = serde_json::from_value(old).unwrap();
    assert!(!back.no_stop);
}

#[test]
fn a_method_without_a_config_trains_the_default_recipe() {
    let dir = tempfile::tempdir().unwrap();
    write_config(dir.path());
    let x = Experiment::from_str(
        r#"
        [experiment]
        name = "r"
        layouts = ["rm-2.1", "rm-2.2"]
        seeds = 1
        [[method]]
        name = "recipe"
        [[method]]
        name = "partial"
        configs = { "rm-2.1" = "tiny.toml" }
        "#,
        &dir.path().join("r.toml"),
    )
    .unwrap_err();
    assert!(
        x.problem
            .contains("'partial': no config for layout 'rm-2.2'"),
        "{x}"
    );
    let x = Experiment::from_str(
        "[experiment]\nname = \"r\"\nlayouts = [\"rm-2.1\"]\nseeds = 1\n[[method]]\nname = \"recipe\"\n",
        &dir.path().join("r.toml"),
    )
    .unwrap();
    let cmd = x.train[0].command(Path::new("out"));
    assert!(
        cmd.starts_with("learner train --map rm-2.1 --seed 0"),
        "{cmd}"
    );
    let cfg = x.train[0].config_in(Path::new("out")).unwrap();
    let recipe = TrainConfig::recipe();
    assert_eq!(
        (&cfg.algorithm, cfg.features),
        (&recipe.algorithm, recipe.features)
    );
    assert_eq!((cfg.shaping, cfg.model.lstm), (recipe.shaping, true));
    assert_eq!(cfg.imitation, recipe.imitation);
    // The shipped study that measured the recipe trains it (its
    // method names a config and settings, so its kept runs stay valid):
    // the intent study's second method, since the intent feature joined.
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../learner/studies/recipe-lstm-imitation-intent.toml");
    let shipped = Experiment::from_file(&shipped).unwrap();
    let cell = shipped
        .train
        .iter()
        .find(|c| {
            c.layout == "rm-2.1" && c.seed == 0 && c.method == "ppo-lstm-imitation-intent-ctde"
        })
        .unwrap();
    assert!(cell.config.is_some());
    // It trains the recipe for its whole budget: everything but `[stop]`,
    // the `[polish]` that joined after it, and the update's threads (one
    // per run then; the run's share of the cores now, which is one for
    // each of a study's two runs at a time).
    assert!(cfg.run.stop.is_some() && cfg.polish.is_some());
    let mut whole_budget = cfg;
    whole_budget.run.stop = None;
    whole_budget.polish = None;
    let mut shipped = cell.config_in(Path::new("out")).unwrap();
    let ppo = shipped.algorithm.ppo_mut().unwrap();
    assert_eq!(ppo.update_threads, 1);
    ppo.update_threads = 0;
    assert_eq!(shipped, whole_budget);
}

#[test]
fn shielded_cells_run_the_greedy_policy_through_the_shield() {
    let dir = tempfile::tempdir().unwrap();
    write_config(dir.path());
    let x = Experiment::from_str(
        r#"
        [experiment]
        name = "s"
        layouts = ["rm-1.1"]
        seeds = 1
        [experiment.eval]
        actions = ["shielded", "greedy", "rescued"]
        rescue_time = 0.5
        [[method]]
        name = "ppo"
        config = "tiny.toml"
        "#,
        &dir.path().join("s.toml"),
    )
    .unwrap();
    let cmds: Vec<String> = x
        .evals
        .iter()
        .map(|c| x.eval_command(c, Path::new("out")))
        .collect();
    assert_eq!(cmds.len(), 3);
    assert!(
        cmds[2].contains("--controller rescue:shield:checkpoint:out/runs/rm-1.1/ppo/seed-0")
            && cmds[2].contains("--time-limit 0.5"),
        "{}",
        cmds[2]
    );
    assert!(
        cmds[0].contains("--controller shield:checkpoint:out/runs/rm-1.1/ppo/seed-0"),
        "{}",
        cmds[0]
    );
    assert!(x.evals[0].dir.ends_with("shielded/agents-2"));
    assert!(
        cmds[1].contains("--controller checkpoint:out/runs/rm-1.1/ppo/seed-0"),
        "{}",
        cmds[1]
    );
    assert!(cmds.iter().all(|c| !c.contains("--sample")));
    assert!(!cmds[0].contains("--time-limit"), "{}", cmds[0]);
    // In-process evaluations use the same limits as the commands.
    assert_eq!(x.time_limit(&x.evals[2]), 0.5);
    assert_eq!(x.time_limit(&x.evals[0]), 60.0);
}

#[test]
fn rescued_lookahead_and_backstop_cells_use_the_named_rescue_planner() {
    let dir = tempfile::tempdir().unwrap();
    write_config(dir.path());
    let study = |planner: &str| {
        Experiment::from_str(
            &format!(
                "[experiment]\nname = \"s\"\nlayouts = [\"rm-1.1\"]\nseeds = 1\n\
                 [experiment.eval]\nactions = [\"rescued\", \"lookahead\", \"backstop\"]\nrescue_planner = \"{planner}\"\n\
                 [[method]]\nname = \"ppo\"\nconfig = \"tiny.toml\"\n"
            ),
            &dir.path().join("s.toml"),
        )
    };
    let x = study("od-astar+lacam").unwrap();
    let cmd = x.eval_command(&x.evals[0], Path::new("out"));
    assert!(
        cmd.contains(
            "--controller rescue=od-astar+lacam:shield:checkpoint:out/runs/rm-1.1/ppo/seed-0"
        ),
        "{cmd}"
    );
    let ahead = x.eval_command(&x.evals[1], Path::new("out"));
    assert!(
        ahead.contains(
            "--controller lookahead=od-astar+lacam:shield:checkpoint:out/runs/rm-1.1/ppo/seed-0"
        ) && ahead.contains("--time-limit 1"),
        "{ahead}"
    );
    let backstop = x.eval_command(&x.evals[2], Path::new("out"));
    assert!(
        backstop.contains(
            "--controller backstop=od-astar+lacam:shield:checkpoint:out/runs/rm-1.1/ppo/seed-0"
        ) && backstop.contains("--time-limit 1"),
        "{backstop}"
    );
    let err = study("od-astar+dijkstra").err().unwrap().to_string();
    assert!(
        err.contains("s.toml")
            && err.contains("rescue_planner: unknown planner 'od-astar+dijkstra'"),
        "{err}"
    );
}

#[test]
fn a_composed_action_is_a_labelled_controller_over_each_run() {
    let dir = tempfile::tempdir().unwrap();
    write_config(dir.path());
    let study = |actions: &str| {
        Experiment::from_str(
            &format!(
                "[experiment]\nname = \"s\"\nlayouts = [\"rm-1.1\"]\nseeds = 1\n\
                 [experiment.eval]\nactions = {actions}\nrescue_planner = \"lacam\"\n\
                 [[method]]\nname = \"ppo\"\nconfig = \"tiny.toml\"\n"
            ),
            &dir.path().join("s.toml"),
        )
    };
    let x =
        study(r#"["lanes", "bss@backstop:sampled:shield[patience=16,settle,lanes]:checkpoint:"]"#)
            .unwrap();
    let names: Vec<_> = x.eval.actions.iter().map(Actions::name).collect();
    assert_eq!(names, ["lanes", "bss"]);
    assert!(x.evals[1].dir.ends_with("bss/agents-2"));
    let c = x.controller(&x.evals[1], Path::new("out")).unwrap();
    assert_eq!(
        c.to_string(),
        "backstop=lacam:sampled:shield[patience=16,settle,lanes]:checkpoint:out/runs/rm-1.1/ppo/seed-0"
    );
    let cmd = x.eval_command(&x.evals[1], Path::new("out"));
    assert!(
        cmd.contains("--controller 'backstop=lacam:shield[patience=16,settle,lanes]:checkpoint:out/runs/rm-1.1/ppo/seed-0' --sample --time-limit 1 "),
        "{cmd}"
    );
    assert_eq!(x.time_limit(&x.evals[1]), 1.0);
    assert_eq!(x.eval.action_order("bss"), Some(NAMED_ACTIONS.len() + 1));
    // The plan keeps the action's text and reads back the same.
    let json = serde_json::to_string(&x).unwrap();
    assert!(json.contains(r#""bss@backstop:sampled:shield[patience=16,settle,lanes]:checkpoint:""#));
    assert_eq!(serde_json::from_str::<Experiment>(&json).unwrap(), x);
    for (actions, needle) in [
        (r#"["cbs"]"#, "evaluates no policy"),
        (r#"["checkpoint:runs/a"]"#, "without DIR"),
        (r#"["shielded@checkpoint:"]"#, "names one of sampled"),
        (
            r#"["a@checkpoint:", "a@shield:checkpoint:"]"#,
            "two actions are named 'a'",
        ),
        (r#"["teleport"]"#, "neither one of sampled, greedy"),
    ] {
        let e = study(actions).unwrap_err().to_string();
        assert!(e.contains(needle), "{needle}: {e}");
    }
}

#[test]
fn mixtures_train_on_several_maps_and_evaluate_on_the_eval_layouts() {
    let dir = tempfile::tempdir().unwrap();
    write_config(dir.path());
    let file = dir.path().join("gen.toml");
    let x = Experiment::from_str(
        r#"
        [experiment]
        name = "gen"
        layouts = ["rm-2.2:1,rm-3.1:1", "rm-2.1"]
        seeds = 2
        planners = ["cbs"]
        [experiment.eval]
        actions = ["sampled"]
        layouts = ["rm-2.1", "rm-2.1b", "rm-3.1"]
        [[method]]
        name = "ppo"
        config = "tiny.toml"
        "#,
        &file,
    )
    .unwrap();
    assert_eq!(x.train.len(), 2 * 2);
    let cmd = x.train[0].command(Path::new("out"));
    assert!(cmd.contains("--maps rm-2.2:1,rm-3.1:1 --seed 0"), "{cmd}");
    assert!(
        cmd.ends_with("--out out/runs/rm-2.2_1+rm-3.1_1/ppo/seed-0"),
        "{cmd}"
    );
    let cfg = x.train[0].config_in(Path::new("out")).unwrap();
    assert_eq!(cfg.layout_names(), ["rm-2.2", "rm-3.1"]);
    assert_eq!(
        x.train[2].config_in(Path::new("out")).unwrap().task.maps(),
        None
    );
    // Every policy on every eval layout, cbs once per eval layout.
    assert_eq!(x.evals.len(), 4 * 3 + 3);
    let first: Vec<_> = x
        .evals
        .iter()
        .filter(|e| {
            e.evaluated
                == (Evaluated::Policy {
                    train: 0,
                    actions: "sampled".parse().unwrap(),
                })
        })
        .collect();
    assert_eq!(
        first.iter().map(|e| e.layout.as_str()).collect::<Vec<_>>(),
        ["rm-2.1", "rm-2.1b", "rm-3.1"]
    );
    assert!(first
        .iter()
        .all(|e| e.trained_on.as_deref() == Some("rm-2.2:1,rm-3.1:1")));
    let e = x.eval_command(first[1], Path::new("out"));
    assert!(e.starts_with("learner eval --map rm-2.1b"), "{e}");
    assert!(
        e.contains("checkpoint:out/runs/rm-2.2_1+rm-3.1_1/ppo/seed-0"),
        "{e}"
    );
    let dirs: BTreeSet<_> = x.evals.iter().map(|e| &e.dir).collect();
    assert_eq!(dirs.len(), x.evals.len(), "one directory per cell");
    assert_eq!(
        x.evals
            .iter()
            .filter(|e| e.evaluated == Evaluated::Planner)
            .map(|e| e.layout.as_str())
            .collect::<Vec<_>>(),
        ["rm-2.1", "rm-2.1b", "rm-3.1"]
    );

    let base =
        "[experiment]\nname = \"x\"\nseeds = 2\n[[method]]\nname = \"m\"\nconfig = \"tiny.toml\"\n";
    let cases = [
        (
            "layouts = [\"rm-2.2,rm-3.1\"]\n",
            "[experiment.eval] layouts",
        ),
        (
            "layouts = [\"rm-2.1\"]\n[experiment.eval]\nlayouts = []\n",
            "at least one layout",
        ),
        (
            "layouts = [\"rm-2.1\"]\n[experiment.eval]\nlayouts = [\"rm-2.2,rm-3.1\"]\n",
            "is a mixture",
        ),
        (
            "layouts = [\"rm-2.1\"]\n[experiment.eval]\nlayouts = [\"rm-8.8\"]\n",
            "layout 'rm-8.8'",
        ),
        (
            "layouts = [\"rm-2.1,rm-8.8\"]\n[experiment.eval]\nlayouts = [\"rm-2.1\"]\n",
            "rm-8.8",
        ),
    ];
    for (extra, needle) in cases {
        let text = base.replacen("seeds = 2\n", &format!("seeds = 2\n{extra}"), 1);
        // `[experiment.eval]` has to come after the [experiment] keys.
        let text = text.replacen("[[method]]", "\n[[method]]", 1);
        let e = Experiment::from_str(&text, &file).unwrap_err().to_string();
        assert!(e.contains(needle), "{needle}: {e}");
    }
}

#[test]
fn a_study_of_planners_alone_needs_no_seeds() {
    let text = "[experiment]\nname = \"p\"\nlayouts = [\"rm-1.1\", \"rm-2.1\"]\nplanners = [\"lacam\", \"cbs\"]\n[experiment.eval]\nagents = \"4..6\"";
    let x = Experiment::from_str(text, Path::new("p.toml")).unwrap();
    assert!(x.seeds.is_empty() && x.train.is_empty());
    // 2 layouts × 2 planners × 3 agent counts, one evaluation each.
    assert_eq!(x.evals.len(), 12);
    assert!(x.evals.iter().all(|e| e.evaluated == Evaluated::Planner));
}

#[test]
fn errors_name_the_file_and_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    write_config(dir.path());
    let file = dir.path().join("bad.toml");
    let cases = [
        ("[experiment]\nname = \"x\"\nlayouts = [\"rm-1.1\"]\nseeds = 2\nplanners = [\"dijkstra\"]", "planner 'dijkstra'"),
        ("[experiment]\nname = \"x\"\nlayouts = [\"rm-9.9\"]\nseeds = 2\nplanners = [\"cbs\"]", "layout 'rm-9.9'"),
        ("[experiment]\nname = \"x\"\nlayouts = [\"rm-1.1\"]\nseeds = 2\nsteps = 10\nplaners = [\"cbs\"]", "planers"),
        ("[experiment]\nname = \"x\"\nlayouts = [\"rm-1.1\"]\nseeds = 2", "nothing to run"),
        ("[experiment]\nname = \"x\"\nlayouts = [\"rm-1.1\"]\nseeds = 2\n[[method]]\nname = \"m\"\nconfig = \"missing.toml\"", "missing.toml"),
        ("[experiment]\nname = \"x\"\nlayouts = [\"rm-1.1\"]\nseeds = 2\n[[method]]\nname = \"m\"\nconfig = \"tiny.toml\"\nset = [\"ppo.nope=1\"]", "'m' on 'rm-1.1'"),
        ("[experiment]\nname = \"x\"\nlayouts = [\"rm-1.1\"]\nseeds = 2\n[experiment.eval]\nagents = \"5..2\"\n[[method]]\nname = \"m\"\nconfig = \"tiny.toml\"", "agents"),
        ("[experiment\nname = \"x\"", "line"),
        ("[experiment]\nname = \"x\"\nlayouts = [\"rm-1.1\"]\n[[method]]\nname = \"m\"\nconfig = \"tiny.toml\"", "at least one seed"),
    ];
    for (text, needle) in cases {
        let e = Experiment::from_str(text, &file).unwrap_err().to_string();
        assert!(e.starts_with(&format!("{}: ", file.display())), "{e}");
        assert!(e.contains(needle), "{needle}: {e}");
    }
}
