"""The env from Python: dynamics against the Rust tests' reference trace,
the zero-copy vector env, and errors with the Rust messages."""

import numpy as np
import pytest

import buridan
from buridan import EnvError, GridEnv, Map, MapError, VecEnv


def status(terminated, truncated):
    return "terminated" if terminated else "truncated" if truncated else "running"


# ------------------------------------------------------------ reference trace


def test_trace_file_has_the_four_traces(traces):
    assert [t["map"] for t in traces] == ["rm-1.1", "rm-2.1", "rm-3.1", "rm-2.1"]
    assert sum(len(t["steps"]) for t in traces) >= 4 * 12


def test_grid_env_replays_the_reference_trace(traces):
    """`env/tests/reference_trace.rs`, step for step, through GridEnv."""
    for tr in traces:
        env = GridEnv(
            tr["map"], tr["agents"], starts=tr["starts"], seed=tr["seed"],
            t_max=tr["t_max"], episode=tr["episode"],
        )
        assert env.positions() == tr["start_cells"], tr["map"]
        assert env.goals() == tr["goal_cells"], tr["map"]
        for s in tr["steps"]:
            rewards, term, trunc, blocked = env.step(np.array(s["actions"], dtype=np.uint8))
            ctx = f'{tr["map"]} step {s["t"]}'
            assert env.t == s["t"], ctx
            assert env.positions() == s["positions"], ctx
            assert rewards.dtype == np.float32
            assert rewards.tolist() == s["rewards"], ctx
            assert blocked == s["blocked"], ctx
            assert status(term, trunc) == s["status"], ctx
        assert env.is_over == (tr["steps"][-1]["status"] != "running")
        assert env.stats()["reward"] == pytest.approx(tr["end_reward"]), tr["map"]


def test_parallel_env_replays_the_reference_trace(traces):
    """The same trace through the PettingZoo dict API."""
    pz = pytest.importorskip("buridan.pettingzoo")
    for tr in traces:
        env = pz.ParallelEnv(
            tr["map"], tr["agents"], starts=tr["starts"], seed=tr["seed"], t_max=tr["t_max"]
        )
        obs, infos = env.reset(options={"episode": tr["episode"]})
        assert set(obs) == set(env.possible_agents)
        assert env.unwrapped_env.positions() == tr["start_cells"]
        for s in tr["steps"]:
            actions = {a: act for a, act in zip(env.possible_agents, s["actions"])}
            obs, rew, term, trunc, info = env.step(actions)
            ctx = f'{tr["map"]} step {s["t"]}'
            assert [rew[a] for a in env.possible_agents] == s["rewards"], ctx
            assert env.unwrapped_env.positions() == s["positions"], ctx
            assert sum(i["blocked_moves"] for i in info.values()) == s["blocked"] * len(info)
            want = s["status"]
            assert all(v == (want == "terminated") for v in term.values()), ctx
            assert all(v == (want == "truncated") for v in trunc.values()), ctx
            assert (env.agents == []) == (want != "running"), ctx
            for a, o in obs.items():
                assert o["observation"].shape == (129,)
                assert env.observation_space(a).contains(o), ctx
        if tr["steps"][-1]["status"] != "running":
            assert info[env.possible_agents[0]]["episode"]["reward"] == pytest.approx(tr["end_reward"])


def test_vec_env_replays_the_reference_trace(traces):
    """The same trace through a one-env VecEnv (env 0 plays episode 0; at the
    end of an episode it resets itself, so positions are compared until then)."""
    for tr in (t for t in traces if t["episode"] == 0):
        venv = VecEnv(
            tr["map"], tr["agents"], 1, starts=tr["starts"], seed=tr["seed"], t_max=tr["t_max"]
        )
        assert [tuple(p) for p in venv.positions()[0]] == tr["start_cells"]
        rewards, term, trunc = venv.rewards, venv.terminated, venv.truncated
        for s in tr["steps"]:
            venv.step([s["actions"]])
            ctx = f'{tr["map"]} step {s["t"]}'
            assert rewards[0].tolist() == s["rewards"], ctx
            assert status(term[0], trunc[0]) == s["status"], ctx
            if s["status"] == "running":
                assert [tuple(p) for p in venv.positions()[0]] == s["positions"], ctx
        done = venv.drain_episodes()
        if tr["steps"][-1]["status"] != "running":
            assert len(done) == 1 and done[0]["reward"] == pytest.approx(tr["end_reward"])
            assert venv.episodes().tolist() == [1]  # auto-reset to the next episode


def test_grid_env_observation_layout_and_masks():
    env = GridEnv("rm-1.1", 2, starts="fixed")
    obs, masks = env.obs(), env.masks()
    assert obs.shape == (2, 129) and obs.dtype == np.float32
    assert masks.shape == (2, 5) and masks.dtype == np.uint8
    # One-hot window: every one of the 25 cells has exactly one code.
    assert np.all(obs[:, :125].reshape(2, 25, 5).sum(axis=2) == 1)
    assert np.all(masks[:, 0] == 1)  # stay is always legal
    # rm-1.1 agent 0 at (1,1): row 0 above is wall, row 1 is the corridor.
    assert masks[0].tolist() == [1, 0, 1, 0, 1]
    assert env.central_obs().shape == ((1 + 2 * 2) * env.map.height * env.map.width,)
    assert env.joint_mask().tolist() == masks.ravel().tolist()


def test_episodes_are_a_function_of_seed_and_index():
    a = GridEnv("rm-2.1", 4, seed=3)
    b = GridEnv("rm-2.1", 4, seed=3, episode=5)
    a.reset(5)
    assert a.positions() == b.positions() and a.goals() == b.goals()
    c = GridEnv("rm-2.1", 4, seed=4, episode=5)
    assert (c.positions(), c.goals()) != (a.positions(), a.goals())


# ----------------------------------------------------------------- vector env


def test_vec_env_arrays_are_read_only_views_updated_in_place():
    venv = VecEnv("rm-2.1", 4, 8, seed=1)
    obs, masks, rewards = venv.obs, venv.masks, venv.rewards
    assert obs.shape == (8, 4, 129) and masks.shape == (8, 4, 5) and rewards.shape == (8, 4)
    assert not obs.flags.writeable and not obs.flags.owndata
    before = obs.copy()
    rng = np.random.default_rng(0)
    for _ in range(5):
        venv.step(rng.integers(0, 5, size=(8, 4), dtype=np.uint8))
    # The old view sees the new state: same memory, no copy per step.
    assert np.shares_memory(obs, venv.obs)
    assert np.array_equal(obs, venv.obs) and not np.array_equal(obs, before)
    with pytest.raises(ValueError):
        obs[0, 0, 0] = 1.0
    # The view keeps the env alive.
    del venv
    assert np.isfinite(obs).all()


def test_vec_env_auto_resets_and_reports_episodes():
    venv = VecEnv("rm-2.1", 4, 3, t_max=5)
    for _ in range(5):
        venv.step(np.zeros((3, 4), np.int64))
    assert venv.truncated.tolist() == [1, 1, 1] and venv.terminated.tolist() == [0, 0, 0]
    eps = venv.drain_episodes()
    assert sorted(e["episode"] for e in eps) == [0, 1, 2]
    assert all(e["length"] == 5 and not e["success"] for e in eps)
    assert venv.episodes().tolist() == [3, 4, 5]
    # -1 per agent off its goal at truncation.
    assert np.all(venv.rewards <= 0)


def test_vec_env_same_step_auto_reset_matches_grid_env():
    """After an episode ends, `final_obs` holds its last observation and
    `obs` the next episode's first (env 0 of 1 plays episodes 0, 1, …)."""
    venv = VecEnv("rm-2.1", 4, 1, seed=5, t_max=3)
    env = GridEnv("rm-2.1", 4, seed=5, t_max=3)
    moves = [[1, 2, 3, 4], [2, 2, 0, 1], [3, 0, 4, 4]]
    for a in moves:
        venv.step([a])
        env.step(a)
    assert venv.truncated[0] == 1
    np.testing.assert_array_equal(venv.final_obs[0], env.obs())
    env.reset(1)
    np.testing.assert_array_equal(venv.obs[0], env.obs())
    np.testing.assert_array_equal(venv.masks[0], env.masks())


def test_vec_env_threads_match_one_thread():
    rng = np.random.default_rng(7)
    acts = rng.integers(0, 5, size=(50, 6, 4))
    one, two = VecEnv("rm-2.1", 4, 6, seed=9), VecEnv("rm-2.1", 4, 6, seed=9, threads=2)
    for a in acts:
        one.step(a)
        two.step(a)
        assert np.array_equal(one.obs, two.obs) and np.array_equal(one.rewards, two.rewards)


def test_central_vec_env():
    venv = VecEnv("rm-1.1", 2, 2, obs="central")
    assert venv.rows_per_env == 1 and venv.mask_dim == 10
    assert venv.obs.shape == (2, 1, 5 * venv.map.height * venv.map.width)


# --------------------------------------------------------------------- errors


def test_malformed_map_names_file_and_line():
    text = "type octile\nheight 1\nwidth 2\nmap\n.?\n"
    with pytest.raises(MapError) as e:
        Map.from_text(text, name="x")
    # The Rust message (env/src/map.rs doctest), with file and line.
    assert str(e.value) == "x.map:5: unknown terrain character '?' in column 2"
    assert (e.value.file, e.value.line) == ("x.map", 5)
    assert isinstance(e.value, buridan.BuridanError)


def test_malformed_map_file_names_the_path(tmp_path):
    bad = tmp_path / "bad.map"
    bad.write_text("type octile\nheight 2\nwidth 2\nmap\n..\n")
    with pytest.raises(MapError) as e:
        GridEnv(str(bad), 1)
    assert str(e.value) == f"{bad}:6: expected 2 grid rows, found 1"
    assert (e.value.file, e.value.line, e.value.problem) == (str(bad), 6, "expected 2 grid rows, found 1")


def test_unknown_map():
    with pytest.raises(MapError, match="unknown map 'rm-9.9': not a file and not a reference model id"):
        Map("rm-9.9")


def test_generated_maps_load_by_their_spec():
    m = Map("maze/19x19/seed=3")
    assert m.name == "maze/19x19/seed=3" and m.walls.shape == (19, 19) and m.scenario is None
    assert (Map("maze/19x19/seed=3").walls == m.walls).all()
    assert not (Map("maze/19x19/seed=4").walls == m.walls).all()
    # POGEMA's warehouse is the warehouse family at its defaults.
    assert int(Map("warehouse/33x46/seed=0").walls.sum()) == 240
    env = GridEnv("random/16x16/density=0.2/seed=1", 8)
    env.reset(3)
    assert env.map.name == "random/16x16/density=0.2/seed=1"
    with pytest.raises(MapError, match=r"^map spec 'braid/20x19/seed=0': a braid maze's height and width are odd") as e:
        Map("braid/20x19/seed=0")
    assert e.value.name == "braid/20x19/seed=0"


def test_map_properties():
    m = Map("rm-1.1")
    assert m.name == "rm-1.1" and m.walls.shape == (m.height, m.width)
    starts, goals = m.scenario
    assert starts == [(1, 1), (1, 7)] and goals == [(1, 8), (1, 0)]
    assert len(m.free_cells) == int((~m.walls).sum())
    assert m.distances_to(1, 8)[1, 1] == 7
    assert ("rm-2.1" in dict(buridan.reference_models())) and len(buridan.reference_models()) == 17


@pytest.mark.parametrize(
    "actions, message",
    [
        ([0, 7], r"^agent 1: action 7 is outside 0\.\.5 \(0 stay, 1 up, 2 right, 3 down, 4 left\)$"),
        ([-1, 0], r"^agent 0: action -1 is outside 0\.\.5"),
        ([0, 300], r"^agent 1: action 300 is outside 0\.\.5"),
        ([0, 0, 0], r"^expected 2 actions, got 3$"),
        (np.zeros((2, 1), np.uint8), r"^expected actions of shape \(2,\), got shape \[2, 1\]$"),
    ],
)
def test_bad_actions_raise_env_error(actions, message):
    env = GridEnv("rm-1.1", 2, starts="fixed")
    with pytest.raises(EnvError, match=message):
        env.step(actions)
    assert env.t == 0  # nothing moved


def test_non_integer_actions_raise_type_error():
    env = GridEnv("rm-1.1", 2, starts="fixed")
    with pytest.raises(TypeError, match="actions must be integers"):
        env.step(np.array([0.5, 1.0]))


def test_vec_env_wrong_action_shape():
    venv = VecEnv("rm-2.1", 4, 2)
    with pytest.raises(EnvError, match=r"^expected 8 actions, got 4$"):
        venv.step(np.zeros(4, np.uint8))
    with pytest.raises(EnvError, match=r"expected actions of shape \(2, 4\) or \(8,\)"):
        venv.step(np.zeros((4, 2), np.uint8))


def test_stepping_a_finished_episode():
    env = GridEnv("rm-1.1", 2, t_max=1)
    env.step([0, 0])
    with pytest.raises(EnvError, match="the episode is over: call reset before stepping again"):
        env.step([0, 0])


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(agents=40), r"^map 'rm-1.1' has 10 free cells, but 40 agents need 80 \(2 per agent for distinct starts and goals; agents \+ 1 for lifelong goal draws\)$"),
        (dict(agents=3, starts="fixed"), r"map 'rm-1.1' has fixed starts for 2 agents, 3 requested"),
        (dict(agents=0), r"invalid configuration: agents must be in 1\.\.65534, got 0"),
        (dict(agents=2, rules="chess"), r"unknown rules 'chess': expected 'thesis' or 'pogema'"),
        (dict(agents=2, starts="somewhere"), r"unknown starts 'somewhere'"),
        (dict(agents=2, features=["x-ray"]), r"unknown observation feature 'x-ray'"),
    ],
)
def test_bad_configurations(kwargs, message):
    with pytest.raises(EnvError, match=message):
        GridEnv("rm-1.1", **kwargs)
