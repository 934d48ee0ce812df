"""Trained policies: a real `learner train` checkpoint and tiny ones made
here through the package, loaded and acting."""

import json

import numpy as np
import pytest

import buridan
from buridan import GridEnv, Policy, PolicyError

from conftest import REPO, TRAINED

CHECKPOINT = TRAINED / "checkpoint"


def test_learner_train_checkpoint_loads_and_acts():
    pol = Policy.load(CHECKPOINT)
    assert (pol.mode, pol.agents, pol.obs_dim, pol.heads, pol.recurrent) == ("ctde", 4, 129, 1, False)
    on_disk = json.loads((CHECKPOINT / "spec.json").read_text())
    assert {k: pol.spec_dict[k] for k in on_disk} == on_disk
    env = GridEnv("rm-2.1", 4, seed=42, **pol.env_kwargs())
    for _ in range(20):
        masks = env.masks()
        actions = pol.act_env(env)
        assert actions.shape == (4,) and actions.dtype == np.uint8
        assert all(masks[i, a] == 1 for i, a in enumerate(actions))  # greedy under the mask
        env.step(actions)
        if env.is_over:
            break


def test_act_returns_actions_logp_and_logits():
    pol = Policy.load(CHECKPOINT)
    env = GridEnv("rm-2.1", 4, seed=1)
    obs, masks = env.obs(), env.masks()
    actions, logp, logits = pol.act(obs, masks)
    assert actions.shape == (4, 1) and logp.shape == (4,) and logits.shape == (4, 5)
    # Greedy: the best legal logit.
    masked = np.where(masks == 1, logits, -np.inf)
    assert actions[:, 0].tolist() == masked.argmax(axis=1).tolist()
    assert np.all(logp <= 0)
    # Any number of rows (CTDE runs with any fleet size).
    a8, _, _ = pol.act(np.repeat(obs, 2, axis=0), np.repeat(masks, 2, axis=0))
    assert a8[:, 0].tolist() == np.repeat(actions[:, 0], 2).tolist()


def test_greedy_evaluation_reproduces_the_committed_learner_eval():
    """`learner eval --controller checkpoint:… --episodes 100 --seed 42` as
    committed in fixtures/ppo-ctde-rm-2.1/eval-greedy/summary.json."""
    want = json.loads((TRAINED / "eval-greedy" / "summary.json").read_text())
    got = buridan.evaluate("rm-2.1", f"checkpoint:{CHECKPOINT}", agents=4, episodes=100, seed=42).summary
    for key in ("controller", "success_rate", "timesteps_median", "sum_of_costs_mean", "reward_mean"):
        assert got[key] == pytest.approx(want[key]), key


def test_tiny_checkpoint_roundtrip_in_a_run_directory(tmp_path):
    """A run directory as `learner train` lays it out: Policy.load(run) takes
    checkpoints/final, else the newest checkpoints/update-*."""
    run = tmp_path / "run"
    early = Policy.new("ctde", 2, hidden=[16], seed=1)
    late = Policy.new("ctde", 2, hidden=[16], seed=2)
    early.save(run / "checkpoints" / "update-000001")
    late.save(run / "checkpoints" / "update-000002")
    env = GridEnv("rm-1.1", 2, starts="fixed")
    obs, masks = env.obs(), env.masks()
    loaded = Policy.load(run)
    assert loaded.path.name == "update-000002"
    np.testing.assert_array_equal(loaded.act(obs, masks)[2], late.act(obs, masks)[2])
    early.save(run / "checkpoints" / "final")
    np.testing.assert_array_equal(Policy.load(run).act(obs, masks)[2], early.act(obs, masks)[2])
    # And the harness drives it.
    rep = buridan.evaluate("rm-1.1", f"checkpoint:{run}", agents=2, episodes=3)
    assert rep.summary["controller"] == "ctde-policy" and len(rep.records) == 3


def test_weights_are_plain_safetensors(tmp_path):
    """model.safetensors is readable outside Rust (here with safetensors'
    NumPy API; examples/torch_policy.py does the same with PyTorch)."""
    st = pytest.importorskip("safetensors.numpy")
    pol = Policy.load(CHECKPOINT)
    tensors = st.load_file(str(CHECKPOINT / "model.safetensors"))
    env = GridEnv("rm-2.1", 4, seed=3)
    h = env.obs().astype(np.float64)
    for i in range(len(pol.spec_dict["hidden"])):
        h = np.tanh(h @ tensors[f"net0.pi.{i}.weight"].T + tensors[f"net0.pi.{i}.bias"])
    logits = h @ tensors["net0.logits.weight"].T + tensors["net0.logits.bias"]
    _, _, rust_logits = pol.act(env.obs(), env.masks())
    np.testing.assert_allclose(rust_logits, logits, atol=1e-4)


def test_recurrent_and_cte_policies(tmp_path):
    lstm = Policy.new("ctde", 2, hidden=[8], lstm_cells=4, seed=0)
    assert lstm.recurrent
    env = GridEnv("rm-1.1", 2, starts="fixed")
    a1, _, l1 = lstm.act(env.obs(), env.masks())
    lstm.observe(a1, np.zeros(2, np.float32), np.zeros(2, np.uint8))
    _, _, l2 = lstm.act(env.obs(), env.masks())
    assert not np.allclose(l1, l2)  # the state advanced
    lstm.reset_state()
    np.testing.assert_allclose(lstm.act(env.obs(), env.masks())[2], l1, atol=1e-6)

    cte = Policy.new("cte", 2, env.central_obs().shape[0], hidden=[8])
    acts = cte.act_env(env)
    assert acts.shape == (2,) and cte.heads == 2
    cte.save(tmp_path / "cte")
    assert Policy.load(tmp_path / "cte").mode == "cte"


def test_policy_errors(tmp_path):
    with pytest.raises(PolicyError, match="holds no checkpoint"):
        Policy.load(tmp_path)
    pol = Policy.new("ctde", 2, hidden=[8])
    with pytest.raises(PolicyError, match=r"observations: expected shape \(rows >= 1, 129\), got \[2, 10\]"):
        pol.act(np.zeros((2, 10), np.float32), np.ones((2, 5), np.uint8))
    with pytest.raises(PolicyError, match=r"got \[0, 129\]"):
        pol.act(np.zeros((0, 129), np.float32), np.ones((0, 5), np.uint8))
    with pytest.raises(PolicyError, match="row 0, head 0: the action mask allows no action"):
        pol.act(np.zeros((1, 129), np.float32), np.zeros((1, 5), np.uint8))
    with pytest.raises(PolicyError, match="masks: expected 10 values, got 5"):
        pol.act(np.zeros((2, 129), np.float32), np.ones((1, 5), np.uint8))
    with pytest.raises(PolicyError, match="unknown mode 'ppo'"):
        Policy.new("ppo", 2)
    with pytest.raises(PolicyError, match="build the env with policy.env_kwargs"):
        Policy.new("ctde", 2, sensor_range=3).act_env(GridEnv("rm-1.1", 2))
    (tmp_path / "spec.json").write_text("{not json")
    with pytest.raises(PolicyError, match=r"spec file .*spec.json"):
        Policy.load(tmp_path)


def test_recurrent_learner_run_reproduces_its_learner_eval_summary():
    """A `learner train` run directory of an LSTM policy (PPO-LSTM-CTDE on
    rm-3.1, path features) and the `learner eval` summary committed beside
    it: every field but the timings is reproduced exactly."""
    run = REPO / "python" / "tests" / "data" / "ppo-lstm-ctde-rm-3.1"
    want = json.loads((run / "eval-greedy-summary.json").read_text())
    pol = Policy.load(run)
    assert pol.recurrent and pol.path == run / "checkpoints" / "final"
    assert pol.env_kwargs()["features"] == ["path"] and pol.obs_dim == 134
    got = buridan.evaluate(
        "rm-3.1", f"checkpoint:{run}", agents=4, episodes=want["episodes"], seed=want["seed"]
    ).summary
    timing = {"compute_ms_median", "compute_ms_mean", "compute_ms_max", "wall_seconds"}
    assert set(got) == set(want)
    assert {k: v for k, v in got.items() if k not in timing} == {
        k: v for k, v in want.items() if k not in timing
    }


def test_a_composed_controller_evaluates_as_its_canonical_text():
    """A backstop over a shield with lanes and goal settling, sampled: the
    general form of the controller grammar, and the same value written with
    its options in another order and `sampled:` outside the net."""
    ckpt = f"checkpoint:{CHECKPOINT}"
    a = buridan.evaluate("rm-2.1", f"backstop:sampled:shield[patience=16,settle,lanes]:{ckpt}", agents=4, episodes=3, seed=42, time_limit=1.0)
    b = buridan.evaluate("rm-2.1", f"sampled:backstop:shield[lanes,settle,patience=16]:{ckpt}", agents=4, episodes=3, seed=42, time_limit=1.0)
    assert a.summary["episodes"] == 3
    strip = lambda rs: [{k: v for k, v in r.items() if k != "compute_ms"} for r in rs]  # noqa: E731
    assert strip(a.records) == strip(b.records)
    with pytest.raises(buridan.PlannerError, match="shield option 'teleport'"):
        buridan.evaluate("rm-2.1", f"shield[teleport]:{ckpt}", agents=4, episodes=1)


def test_a_pretrained_model_loads_by_name():
    """`model:NAME` names a folder of the checkout's models/ (manifest.toml
    there says what it is)."""
    pol = Policy.load("model:rm-2.1")
    assert pol.path.resolve() == (REPO / "models" / "rm-2.1").resolve()
    assert pol.recurrent and pol.env_kwargs()["features"] == ["path", "intent"]
    with pytest.raises(PolicyError, match=r"no pretrained model 'nope' \(available: .*rm-2\.1"):
        Policy.load("model:nope")
