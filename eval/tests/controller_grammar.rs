//! The controller grammar: parse ∘ display is the identity over generated
//! controller trees, today's names keep their meaning, and the one error
//! lists the forms.

use std::path::PathBuf;

use buridan_eval::by_name::{
    Act, Controller, Fallback, Labelled, Net, NetKind, PlannerKind, Policy, Portfolio, Problem,
    Shield, ShieldOptions, FORMS,
};
use buridan_eval::shield::Ranking;
use proptest::prelude::*;

fn planner() -> impl Strategy<Value = Portfolio> {
    prop::collection::vec(prop::sample::select(PlannerKind::ALL.to_vec()), 1..4)
        .prop_map(|v| Portfolio::new(v).unwrap())
}

fn policy() -> impl Strategy<Value = Policy> {
    // Any text may follow `checkpoint:`, separators included.
    ("[a-z0-9/._:=@+\\[\\] -]{0,24}", any::<bool>()).prop_map(|(dir, sampled)| Policy {
        checkpoint: PathBuf::from(dir),
        act: if sampled { Act::Sampled } else { Act::Greedy },
    })
}

fn shield() -> impl Strategy<Value = Shield> {
    (
        policy(),
        any::<bool>(),
        prop::option::of((any::<u32>(), any::<bool>())),
        any::<bool>(),
        any::<bool>(),
        any::<bool>(),
        any::<bool>(),
    )
        .prop_map(
            |(policy, env, fallback, ordered, evict, lanes, aside)| Shield {
                policy,
                options: ShieldOptions {
                    ranking: if env { Ranking::Env } else { Ranking::Walls },
                    fallback: fallback.map(|(patience, goal_settling)| Fallback {
                        patience,
                        goal_settling,
                    }),
                    dead_end_order: ordered,
                    dead_end_eviction: evict,
                    one_way_lanes: lanes,
                    stepping_aside: aside,
                },
            },
        )
}

fn controller() -> impl Strategy<Value = Controller> {
    let leaf = prop_oneof![
        planner().prop_map(Controller::Planner),
        Just(Controller::Random),
        Just(Controller::LifelongPibt),
        policy().prop_map(Controller::Policy),
        shield().prop_map(Controller::Shield),
    ];
    leaf.prop_recursive(4, 8, 1, |inner| {
        (
            prop::sample::select(NetKind::ALL.to_vec()),
            prop::option::of(planner()),
            inner,
        )
            .prop_map(|(kind, planner, inner)| {
                Controller::Net(Net {
                    kind,
                    planner,
                    inner: Box::new(inner),
                })
            })
    })
}

proptest! {
    #[test]
    fn parse_of_display_is_the_identity(c in controller()) {
        let text = c.to_string();
        let back: Controller = text.parse().map_err(|e| TestCaseError::fail(format!("{text}: {e}")))?;
        prop_assert_eq!(&back, &c, "{}", text);
        // Serde carries the same text.
        let json = serde_json::to_string(&c).unwrap();
        prop_assert_eq!(&json, &serde_json::to_string(&text).unwrap());
        prop_assert_eq!(serde_json::from_str::<Controller>(&json).unwrap(), c);
    }

    #[test]
    fn labelled_controllers_round_trip(c in controller(), label in "[a-z0-9][a-z0-9._+#-]{0,8}") {
        let l = Labelled { label, controller: c };
        prop_assert_eq!(l.to_string().parse::<Labelled>().unwrap(), l);
    }
}

fn ckpt(dir: &str, act: Act) -> Policy {
    Policy {
        checkpoint: PathBuf::from(dir),
        act,
    }
}

fn shield_over(dir: &str) -> Shield {
    Shield::over(ckpt(dir, Act::Greedy))
}

fn shield_with(dir: &str, options: ShieldOptions) -> Shield {
    Shield {
        options,
        ..shield_over(dir)
    }
}

/// Every form of today means what it meant, and displays as it is written.
#[test]
fn todays_names_keep_their_meaning() {
    let fallback = |patience, goal_settling| {
        Some(Fallback {
            patience,
            goal_settling,
        })
    };
    let cases: Vec<(&str, Controller)> = vec![
        (
            "cbs",
            Controller::Planner(Portfolio::new(vec![PlannerKind::Cbs]).unwrap()),
        ),
        (
            "lacam+od-astar",
            Controller::Planner(
                Portfolio::new(vec![PlannerKind::Lacam, PlannerKind::OdAstar]).unwrap(),
            ),
        ),
        ("random", Controller::Random),
        ("lifelong-pibt", Controller::LifelongPibt),
        (
            "checkpoint:runs/a",
            Controller::Policy(ckpt("runs/a", Act::Greedy)),
        ),
        (
            "shield:checkpoint:runs/a",
            Controller::Shield(shield_over("runs/a")),
        ),
        (
            "shield-env:checkpoint:runs/a",
            Controller::Shield(shield_with(
                "runs/a",
                ShieldOptions {
                    ranking: Ranking::Env,
                    ..ShieldOptions::default()
                },
            )),
        ),
        (
            "shield=16:checkpoint:runs/a",
            Controller::Shield(shield_with(
                "runs/a",
                ShieldOptions {
                    fallback: fallback(16, false),
                    ..ShieldOptions::default()
                },
            )),
        ),
        (
            "shield-env=8:checkpoint:runs/a",
            Controller::Shield(shield_with(
                "runs/a",
                ShieldOptions {
                    ranking: Ranking::Env,
                    fallback: fallback(8, false),
                    ..ShieldOptions::default()
                },
            )),
        ),
        (
            "shield-ordered:checkpoint:runs/a",
            Controller::Shield(shield_with(
                "runs/a",
                ShieldOptions {
                    dead_end_order: true,
                    ..ShieldOptions::default()
                },
            )),
        ),
        (
            "shield-ordered=16:checkpoint:runs/a",
            Controller::Shield(shield_with(
                "runs/a",
                ShieldOptions {
                    fallback: fallback(16, false),
                    dead_end_order: true,
                    ..ShieldOptions::default()
                },
            )),
        ),
        (
            "shield-lanes=16:checkpoint:runs/a",
            Controller::Shield(shield_with(
                "runs/a",
                ShieldOptions {
                    fallback: fallback(16, false),
                    dead_end_order: true,
                    one_way_lanes: true,
                    ..ShieldOptions::default()
                },
            )),
        ),
        (
            "shield-lanes:checkpoint:runs/a",
            Controller::Shield(shield_with(
                "runs/a",
                ShieldOptions {
                    dead_end_order: true,
                    one_way_lanes: true,
                    ..ShieldOptions::default()
                },
            )),
        ),
        (
            "shield[patience=16,ordered,lanes,aside]:checkpoint:runs/a",
            Controller::Shield(shield_with(
                "runs/a",
                ShieldOptions {
                    fallback: fallback(16, false),
                    dead_end_order: true,
                    one_way_lanes: true,
                    stepping_aside: true,
                    ..ShieldOptions::default()
                },
            )),
        ),
        (
            "shield-settle=16:checkpoint:runs/a",
            Controller::Shield(shield_with(
                "runs/a",
                ShieldOptions {
                    fallback: fallback(16, true),
                    ..ShieldOptions::default()
                },
            )),
        ),
        (
            "rescue:shield:checkpoint:runs/a",
            Controller::Net(Net {
                kind: NetKind::Rescue,
                planner: None,
                inner: Box::new(Controller::Shield(shield_over("runs/a"))),
            }),
        ),
        (
            "pace=od-astar+lacam:random",
            Controller::Net(Net {
                kind: NetKind::Pace,
                planner: Some(
                    Portfolio::new(vec![PlannerKind::OdAstar, PlannerKind::Lacam]).unwrap(),
                ),
                inner: Box::new(Controller::Random),
            }),
        ),
        (
            "lookahead=lacam:backstop:checkpoint:a:b=c",
            Controller::Net(Net {
                kind: NetKind::Lookahead,
                planner: Some(Portfolio::new(vec![PlannerKind::Lacam]).unwrap()),
                inner: Box::new(Controller::Net(Net {
                    kind: NetKind::Backstop,
                    planner: None,
                    inner: Box::new(Controller::Policy(ckpt("a:b=c", Act::Greedy))),
                })),
            }),
        ),
    ];
    for (text, want) in cases {
        let got: Controller = text.parse().unwrap_or_else(|e| panic!("{text}: {e}"));
        assert_eq!(got, want, "{text}");
        assert_eq!(got.to_string(), text, "{text} displays as written");
    }
}

/// Aliases parse to the planner `buridan_mapf` makes of them; display
/// gives its canonical name.
#[test]
fn planner_aliases_are_mapfs() {
    for alias in [
        "ma-astar",
        "maastar",
        "MA-A*",
        "ma_astar",
        "od-astar",
        "odastar",
        "od-a*",
        "od_astar",
        "od-astar-soc",
        "cbs",
        "CBS",
        "pibt",
        "lacam",
        "LaCAM*",
        "lacam-star",
        "lacam_star",
        "lacamstar",
        "lacam-star-makespan",
        "pp",
        "prioritized",
        "lacam+od-astar",
    ] {
        let c: Controller = alias.parse().unwrap_or_else(|e| panic!("{alias}: {e}"));
        let want = buridan_mapf::planner_by_name(alias)
            .unwrap()
            .name()
            .to_string();
        assert_eq!(c.to_string(), want, "{alias}");
    }
}

#[test]
fn the_composed_form_reads_in_any_option_order() {
    let c: Controller = "backstop:sampled:shield[lanes,settle,patience=16]:checkpoint:runs/a"
        .parse()
        .unwrap();
    let same: Controller = "sampled:backstop:shield[patience=16,settle,lanes]:checkpoint:runs/a"
        .parse()
        .unwrap();
    assert_eq!(c, same);
    let Controller::Net(net) = &c else {
        panic!("{c:?}")
    };
    let Controller::Shield(s) = &*net.inner else {
        panic!("{c:?}")
    };
    assert_eq!(s.policy.act, Act::Sampled);
    assert_eq!(
        (
            s.options.fallback,
            s.options.dead_end_order,
            s.options.one_way_lanes
        ),
        (
            Some(Fallback {
                patience: 16,
                goal_settling: true
            }),
            false,
            true
        )
    );
    assert_eq!(
        c.to_string(),
        "backstop:sampled:shield[patience=16,settle,lanes]:checkpoint:runs/a"
    );
    // Options that today's names have display as those names.
    let named: Controller = "shield[ordered,patience=16,lanes]:checkpoint:d"
        .parse()
        .unwrap();
    assert_eq!(named.to_string(), "shield-lanes=16:checkpoint:d");
    let plain: Controller = "shield[]:checkpoint:d".parse().unwrap();
    assert_eq!(plain.to_string(), "shield:checkpoint:d");
}

/// Every error names the problem and lists the grammar's forms.
#[test]
fn errors_name_the_problem_and_list_the_forms() {
    let cases = [
        ("dijkstra", "unknown controller 'dijkstra'"),
        ("", "no controller"),
        (
            "rescue:dijkstra",
            "'rescue:dijkstra': unknown controller 'dijkstra'",
        ),
        (
            "rescue=dijkstra:random",
            "unknown rescue planner 'dijkstra'",
        ),
        (
            "shield:cbs",
            "the shield drives trained policies only (shield:checkpoint:DIR)",
        ),
        (
            "shield-lanes=16:cbs",
            "the shield drives trained policies only (shield-lanes:checkpoint:DIR)",
        ),
        (
            "shield=soon:checkpoint:d",
            "the shield's patience 'soon' is not a number of steps",
        ),
        (
            "shield-settle:checkpoint:d",
            "shield-settle needs the fallback's patience",
        ),
        (
            "shield[settle]:checkpoint:d",
            "shield-settle needs the fallback's patience",
        ),
        (
            "shield[teleport]:checkpoint:d",
            "shield option 'teleport' is unknown",
        ),
        (
            "shield[lanes,lanes]:checkpoint:d",
            "shield option 'lanes' is unknown or given twice",
        ),
        (
            "shield[patience=x]:checkpoint:d",
            "patience 'x' is not a number of steps",
        ),
        ("shield[lanes:checkpoint:d", "shield option"),
        ("16:checkpoint:d", "unknown controller '16:checkpoint:d'"),
    ];
    for (text, problem) in cases {
        let err = text.parse::<Controller>().unwrap_err();
        let message = err.to_string();
        assert!(message.contains(problem), "{text}: {message}");
        assert!(
            message.ends_with(&format!("; a controller is {FORMS}")),
            "{text}: {message}"
        );
        assert_eq!(err.text, text);
    }
    for form in [
        "PLANNER",
        "random",
        "checkpoint:DIR",
        "shield[OPTION,...]:checkpoint:DIR",
        "shield-lanes[=K]:",
        "sampled:CONTROLLER",
        "rescue[=PLANNER]:CONTROLLER",
        "lookahead[=PLANNER]:CONTROLLER",
        "backstop[=PLANNER]:CONTROLLER",
        "pace[=PLANNER]:CONTROLLER",
    ] {
        assert!(FORMS.contains(form), "{form}");
    }
    let err = "@lacam".parse::<Labelled>().unwrap_err();
    assert!(matches!(err.problem, Problem::Label { .. }), "{err}");
    let err = "learned=shield:cbs".parse::<Labelled>().unwrap_err();
    assert!(
        err.to_string()
            .starts_with("'learned=shield:cbs': the shield drives trained policies only"),
        "{err}"
    );
}

/// A net's default planner, and a controller's policies, as the study and
/// the CLI set them.
#[test]
fn sampling_checkpoints_and_default_planners_reach_every_leaf() {
    let c: Controller = "rescue:lookahead=pp:shield:checkpoint:".parse().unwrap();
    let lacam: Portfolio = "lacam".parse().unwrap();
    let c = c
        .with_checkpoint("runs/x".as_ref())
        .with_default_planner(&lacam)
        .with_act(Act::Sampled);
    assert_eq!(
        c.to_string(),
        "rescue=lacam:lookahead=pp:sampled:shield:checkpoint:runs/x"
    );
    assert!(c.has_net());
    assert_eq!(c.policies().len(), 1);
}
