"""The planners on the reference models' fixed scenarios, and the
evaluation harness with `learner eval`'s summary."""

import json

import numpy as np
import pytest

import buridan
from buridan import Map, PlannerError, SolveError

from conftest import REPO

MODELS = [m for m, _ in buridan.reference_models()]
# As `mapf/tests/reference_models.rs`: plain CBS cannot refute the corridor
# models within a short limit, MA-A* with the spec's inadmissible heuristic
# floods plateaus on three; both are given a second and may time out there.
HARD_FOR_CBS = {"rm-1.2b", "rm-1.4", "rm-1.4b", "rm-1.4c"}
HARD_FOR_MA_ASTAR = {"rm-2.1b", "rm-3.1", "rm-3.1b"}


def check_plan(p, map_id):
    scen_starts, scen_goals = Map(map_id).scenario
    assert p.starts == scen_starts and p.goals == scen_goals
    assert [path[0] for path in p.paths] == scen_starts
    assert [path[-1] for path in p.paths] == scen_goals
    p.validate()  # the independent validator, thesis rules (no following)
    r = p.replay(t_max=1000)
    assert r["exact"] and r["success"] and r["blocked_moves"] == 0, (map_id, r)
    assert r["terminated_at"] == max(p.makespan, 1)
    assert r["final_positions"] == scen_goals
    acts = p.actions()
    assert acts.shape == (p.makespan, p.agents)


def test_planner_names_all_resolve():
    assert {"cbs", "ma-astar", "od-astar", "pibt", "lacam", "lacam-star", "pp"} <= set(
        buridan.planner_names()
    )
    # The incomplete ones fail on rm-1.1's head-on corridor, and say so.
    incomplete = {
        "pibt": r"^gave up after 1000 steps without reaching all goals \(incomplete planner\)$",
        "pp": r"^every one of the 2 priority orders failed \(incomplete planner\)$",
    }
    for name in buridan.planner_names():
        if name in incomplete:
            with pytest.raises(SolveError, match=incomplete[name]):
                buridan.plan("rm-1.1", name)
            continue
        p = buridan.plan("rm-1.1", name)
        assert p.agents == 2 and p.replay()["success"], name


def test_incomplete_planners_solve_where_they_can():
    for name in ("pibt", "pp"):
        p = buridan.plan("rm-2.1", name)
        p.validate()
        assert p.replay()["success"], name


@pytest.mark.parametrize("map_id", MODELS)
def test_lacam_and_od_astar_solve_every_fixed_scenario(map_id):
    for planner in ("lacam", "od-astar"):
        p = buridan.plan(map_id, planner, time_limit=20)
        assert p.planner == planner
        check_plan(p, map_id)


@pytest.mark.parametrize("map_id", MODELS)
def test_cbs_and_ma_astar_on_the_fixed_scenarios(map_id):
    for planner, hard in (("cbs", HARD_FOR_CBS), ("ma-astar", HARD_FOR_MA_ASTAR)):
        try:
            p = buridan.plan(map_id, planner, time_limit=1.0 if map_id in hard else 20)
        except SolveError as e:
            assert map_id in hard, f"{planner} on {map_id}: {e}"
            assert str(e).startswith("time limit reached after")
            continue
        check_plan(p, map_id)


@pytest.mark.parametrize(
    "map_id, makespan, soc",
    # Hand-derived, confirmed by brute force in mapf/tests/optimality.rs.
    [("rm-1.1", 10, 18), ("rm-1.2", 16, 24), ("rm-1.3", 7, 11)],
)
def test_optimal_planners_match_the_hand_derived_values(map_id, makespan, soc):
    assert buridan.plan(map_id, "od-astar").makespan == makespan
    assert buridan.plan(map_id, "cbs").sum_of_costs == soc


def test_pogema_rules_allow_following():
    # Simultaneous moves: rm-1.1 in 9 steps, as in the dissertation.
    p = buridan.plan("rm-1.1", "cbs", rules="pogema")
    assert (p.makespan, p.sum_of_costs) == (9, 17)
    assert p.replay()["exact"]


def test_plan_on_given_starts_and_goals_and_portfolio():
    m = Map("rm-2.1")
    starts, goals = m.free_cells[:3], m.free_cells[-3:]
    p = buridan.plan(m, "lacam+od-astar", starts=starts, goals=goals)
    assert p.planner == "lacam+od-astar" and p.starts == starts
    p.validate()
    assert p.replay()["success"]


def test_unknown_planner_and_unsupported_rules():
    with pytest.raises(PlannerError) as e:
        buridan.plan("rm-1.1", "dijkstra")
    assert str(e.value) == (
        "unknown planner 'dijkstra' (expected pibt, lacam, lacam-star, lacam-star-makespan, "
        "cbs, ma-astar, pp, od-astar, od-astar-soc, or several joined by '+')"
    )
    with pytest.raises(PlannerError, match="planner 'od-astar' cannot plan under pogema rules"):
        buridan.plan("rm-1.1", "od-astar", rules="pogema")


def test_solve_errors():
    walled = Map.from_text("type octile\nheight 1\nwidth 3\nmap\n.@.\n", name="walled")
    with pytest.raises(SolveError, match="no solution"):
        buridan.plan(walled, "lacam", starts=[(0, 0)], goals=[(0, 2)])
    with pytest.raises(SolveError, match=r"agent 0: start \(0, 1\) is a wall or outside the grid"):
        buridan.plan(walled, "lacam", starts=[(0, 1)], goals=[(0, 2)])
    with pytest.raises(buridan.EnvError, match="map 'walled' has fixed starts for 0 agents"):
        buridan.plan(walled, "lacam")
    with pytest.raises(ValueError, match="time_limit must be a positive"):
        buridan.plan("rm-1.1", "cbs", time_limit=0)


# ------------------------------------------------------------------ evaluate


def committed_summary():
    # `learner eval --map rm-3.1 --agents 4 --controller cbs` (tests/data/README.md).
    path = REPO / "python/tests/data/cbs-rm-3.1-agents-4-summary.json"
    return json.loads(path.read_text())


def test_evaluate_returns_learner_eval_summary_fields():
    rep = buridan.evaluate("rm-3.1", "cbs", agents=4, episodes=5, seed=42, time_limit=5.0)
    s = rep.summary
    # Exactly the fields `learner eval` writes (a committed summary.json).
    assert set(s) == set(committed_summary())
    assert (s["controller"], s["map"], s["agents"], s["episodes"], s["seed"]) == ("cbs", "rm-3.1", 4, 5, 42)
    assert s["rules"] == "thesis" and s["t_max"] == 100
    assert len(rep.records) == 5 and [r["episode"] for r in rep.records] == list(range(5))
    assert rep.visits.shape == (Map("rm-3.1").height, Map("rm-3.1").width)
    assert json.loads(rep.summary_json()) == s


def test_evaluate_planners_on_the_fixed_scenario():
    for planner in ("cbs", "lacam", "od-astar", "ma-astar"):
        rep = buridan.evaluate("rm-1.1", planner, agents=2, episodes=1, starts="fixed")
        s, r = rep.summary, rep.records[0]
        assert s["success_rate"] == 1.0, planner
        assert r["timesteps"] == 10 and r["reward"] == 3.0, planner
        assert r["plan_makespan"] == 10


def test_evaluate_random_is_reproducible():
    a = buridan.evaluate("rm-2.1", "random", agents=4, episodes=6, seed=1).records
    b = buridan.evaluate("rm-2.1", "random", agents=4, episodes=6, seed=1, jobs=2).records
    strip = lambda rs: [{k: v for k, v in r.items() if k != "compute_ms"} for r in rs]  # noqa: E731
    assert strip(a) == strip(b)


def test_evaluate_under_delays_is_seeded_and_recorded():
    a = buridan.evaluate("rm-2.1", "pibt", agents=4, episodes=6, rules="pogema", delay=0.3)
    b = buridan.evaluate("rm-2.1", "pibt", agents=4, episodes=6, rules="pogema", delay=0.3)
    prompt = buridan.evaluate("rm-2.1", "pibt", agents=4, episodes=6, rules="pogema")
    steps = lambda rep: [r["timesteps"] for r in rep.records]  # noqa: E731
    assert steps(a) == steps(b) and steps(a) != steps(prompt)
    assert abs(a.summary["delay"] - 0.3) < 1e-6 and "delay" not in prompt.summary
    with pytest.raises(buridan.EnvError, match=r"delay must be a probability in \[0, 1\)"):
        buridan.evaluate("rm-2.1", "pibt", agents=4, episodes=1, delay=1.5)


def test_evaluate_bad_controller_names():
    with pytest.raises(PlannerError, match="unknown controller 'dijkstra'"):
        buridan.evaluate("rm-1.1", "dijkstra", agents=2)
    with pytest.raises(PlannerError, match="the shield drives trained policies only"):
        buridan.evaluate("rm-1.1", "shield:cbs", agents=2)
    with pytest.raises(buridan.PolicyError, match="holds no checkpoint"):
        buridan.evaluate("rm-1.1", "checkpoint:/nonexistent", agents=2)
