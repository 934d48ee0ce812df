"""PettingZoo conformance, the Gymnasium vector env and the RLlib adapter."""

import numpy as np
import pytest

pettingzoo = pytest.importorskip("pettingzoo")
gymnasium = pytest.importorskip("gymnasium")

from pettingzoo.test import parallel_api_test  # noqa: E402

import buridan  # noqa: E402
from buridan.pettingzoo import ParallelEnv  # noqa: E402
from buridan.vector import VectorEnv  # noqa: E402


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(map="rm-2.1", agents=4),
        dict(map="rm-1.1", agents=2, starts="fixed"),
        dict(map="rm-3.1", agents=8, rules="pogema", t_max=40),
    ],
)
def test_parallel_api_test(kwargs):
    """PettingZoo's own conformance test."""
    parallel_api_test(ParallelEnv(**kwargs), num_cycles=1000)


def test_parallel_env_dict_observations_with_action_mask():
    env = buridan.parallel_env(map="rm-2.1", agents=4, seed=5)
    obs, infos = env.reset()
    assert env.agents == env.possible_agents == [f"agent_{i}" for i in range(4)]
    for a in env.agents:
        space = env.observation_space(a)
        assert set(space.spaces) == {"observation", "action_mask"}
        assert obs[a]["action_mask"].dtype == np.int8 and obs[a]["action_mask"][0] == 1
        assert space.contains(obs[a])
        np.testing.assert_array_equal(env.observe(a)["observation"], obs[a]["observation"])
    assert env.state().shape == env.state_space.shape


def test_parallel_env_episodes_follow_the_seed():
    env = ParallelEnv("rm-2.1", 4, seed=11)
    env.reset()
    first = env.unwrapped_env.positions()
    env.reset()
    assert env.episode == 1
    env.reset(seed=11)
    assert env.episode == 0 and env.unwrapped_env.positions() == first
    # The same episode as a bare GridEnv.
    assert buridan.GridEnv("rm-2.1", 4, seed=11).positions() == first


def test_parallel_env_masked_random_play_runs_to_truncation():
    env = ParallelEnv("rm-2.1", 4, t_max=30, render_mode="ansi")
    obs, _ = env.reset(seed=0)
    free = set(env.unwrapped_env.map.free_cells)
    rng = np.random.default_rng(0)
    steps, blocked = 0, 0
    while env.agents:
        actions = {a: int(rng.choice(np.flatnonzero(obs[a]["action_mask"]))) for a in env.agents}
        obs, rew, term, trunc, info = env.step(actions)
        steps += 1
        blocked += info["agent_0"]["blocked_moves"]
        cells = env.unwrapped_env.positions()
        assert set(cells) <= free and len(set(cells)) == 4
    assert steps <= 30
    assert info["agent_0"]["episode"]["blocked_moves"] == blocked
    assert info["agent_0"]["episode"]["length"] == steps
    assert "A" in env.render()
    with pytest.raises(RuntimeError, match="call reset"):
        env.step({})


def test_vector_env_spaces_and_zero_copy_steps():
    env = VectorEnv("rm-2.1", agents=4, num_envs=8, seed=2, t_max=10)
    obs, info = env.reset(seed=2)
    assert env.observation_space.contains(obs)
    assert obs["observation"].shape == (8, 4, 129)
    first = obs["observation"]
    total_done = 0
    for t in range(25):
        actions = env.action_space.sample()
        obs, rew, term, trunc, info = env.step(actions)
        assert obs["observation"] is first  # the same view, refreshed in place
        assert rew.shape == (8, 4) and term.dtype == np.bool_ and trunc.shape == (8,)
        if (term | trunc).any():
            assert info["_final_obs"].tolist() == (term | trunc).tolist()
            assert info["final_obs"]["observation"].shape == (8, 4, 129)
            total_done += len(info["episodes"])
    assert total_done >= 16  # t_max 10: every env ended at least twice


def test_vector_env_reset_with_seed_restarts_the_sequence():
    env = VectorEnv("rm-2.1", agents=4, num_envs=2)
    env.reset(seed=3)
    a = env.unwrapped_vec_env.positions()
    env.step(np.ones((2, 4), np.int64))
    env.reset(seed=3)
    assert np.array_equal(env.unwrapped_vec_env.positions(), a)


def test_rllib_adapter():
    """Skipped only when Ray RLlib is not installed (it is optional)."""
    pytest.importorskip("ray.rllib")
    from ray.rllib.utils.pre_checks.env import check_multiagent_environments

    from buridan.rllib import BuridanMultiAgentEnv

    check_multiagent_environments(BuridanMultiAgentEnv({"map": "rm-2.1", "agents": 4}))  # RLlib's own check
    env = BuridanMultiAgentEnv({"map": "rm-1.1", "agents": 2, "starts": "fixed"})
    obs, infos = env.reset(seed=0)
    assert set(obs) == {"agent_0", "agent_1"}
    # The reference trace's rm-1.1 actions end with everybody home at step 12.
    seq = [[4, 4], [2, 4], [2, 1], [2, 4], [2, 1], [2, 3], [2, 3], [2, 4], [2, 4], [2, 4], [4, 4], [2, 0]]
    for a0, a1 in seq:
        obs, rew, term, trunc, info = env.step({"agent_0": a0, "agent_1": a1})
    assert term["__all__"] and not trunc["__all__"]
    assert rew == {"agent_0": 1.0, "agent_1": 1.0}


def test_rllib_module_says_what_to_install_without_ray():
    try:
        import ray.rllib  # noqa: F401
    except ImportError:
        with pytest.raises(ImportError, match=r"pip install 'ray\[rllib\]'"):
            import buridan.rllib  # noqa: F401
    else:
        pytest.skip("ray is installed")
