"""The SimPy example server (python/examples/simpy_env_server.py) through
gRPC, as an actor would see it: Spec, Reset, Step against env.proto's
conventions, scripted deliveries and collisions, and bad input.

Needs grpcio, grpcio-tools, protobuf and simpy (python/requirements-test.txt),
not the buridan package.
"""

import contextlib
import random
import sys

import pytest

from conftest import REPO

grpc = pytest.importorskip("grpc")
pytest.importorskip("simpy")
pytest.importorskip("grpc_tools")

sys.path.insert(0, str(REPO / "python" / "examples"))
import simpy_env_server as sim  # noqa: E402

pb2, pb2_grpc = sim.env_stubs.load()
D = sim.OBS_DIM
# No product arrives in a scripted test unless it says so.
NEVER = 1e12


@contextlib.contextmanager
def served(params, envs=1, max_sessions=64):
    server, port = sim.serve("127.0.0.1:0", params, envs, max_sessions)
    channel = grpc.insecure_channel(f"127.0.0.1:{port}")
    try:
        yield pb2_grpc.EnvironmentStub(channel), channel
    finally:
        channel.close()
        server.stop(None)


def rows(obs, agents):
    return [list(obs[i * D : (i + 1) * D]) for i in range(len(obs) // D)]


def cells_of(obs, params):
    """Each AGV's cell, read back from its normalised position."""
    return [round(r[1] * (params.cells - 1)) for r in rows(obs, params.agents)]


def step(stub, session, actions):
    return stub.Step(pb2.StepRequest(session=session, actions=bytes(actions)))


def test_spec():
    p = sim.LineParams(agents=3, cells=11, t_max=77)
    with served(p, envs=5) as (stub, _):
        s = stub.Spec(pb2.SpecRequest())
    assert (s.num_envs, s.agents, s.obs_kind, s.obs_dim, s.num_actions, s.t_max) == (
        5,
        3,
        pb2.OBS_KIND_LOCAL,
        11,
        3,
        77,
    )
    assert s.name == "simpy:line-11"


def test_reset_shapes_masks_and_seeds():
    p = sim.LineParams(agents=2, cells=9)
    envs = 3
    with served(p, envs=envs) as (stub, _):
        a = stub.Reset(pb2.ResetRequest(seed=7))
        b = stub.Reset(pb2.ResetRequest(seed=7))
        c = stub.Reset(pb2.ResetRequest(seed=8))
    assert a.session != 0 and b.session != 0 and a.session != b.session
    assert len(a.obs) == envs * p.agents * D
    assert len(a.masks) == envs * p.agents * sim.NUM_ACTIONS
    assert all(0.0 <= x <= 1.0 for x in a.obs)
    assert (list(a.obs), a.masks) == (list(b.obs), b.masks)
    assert list(a.obs) != list(c.obs)
    # Masks follow the positions: hold always, no driving off either end.
    for agent, cell in enumerate(cells_of(a.obs, p)):
        m = a.masks[agent * 3 : (agent + 1) * 3]
        assert list(m) == [1, int(cell < p.cells - 1), int(cell > 0)], (agent, cell)
    # Env-major: env e's agents are rows 2e and 2e+1, agent ids 0 and 1.
    assert [r[0] for r in rows(a.obs, p.agents)] == [0.0, 1.0] * envs


def test_same_seed_same_episodes():
    # Across episode ends (t_max 15), with arrivals, moves and collisions.
    p = sim.LineParams(agents=2, t_max=15, arrival_mean=3.0)
    envs = 2
    with served(p, envs=envs) as (stub, _):
        replies = []
        for _ in range(2):
            r = stub.Reset(pb2.ResetRequest(seed=11))
            rng, masks, got = random.Random(5), r.masks, []
            for _ in range(40):
                acts = [
                    rng.choice([a for a in range(3) if masks[k * 3 + a]])
                    for k in range(envs * p.agents)
                ]
                reply = step(stub, r.session, acts)
                masks = reply.masks
                got.append(reply)
            replies.append(got)
    assert replies[0] == replies[1]
    assert sum(len(r.episodes) for r in replies[0]) == 2 * envs
    assert any(
        x != 0 for r in replies[0] for x in r.rewards
    ), "the random walk should score something"


def test_truncation_at_t_max_and_auto_reset():
    p = sim.LineParams(agents=2, t_max=5)
    envs = 2
    with served(p, envs=envs) as (stub, _):
        r = stub.Reset(pb2.ResetRequest(seed=3))
        before = list(r.obs)
        for t in range(1, 6):
            reply = step(stub, r.session, [sim.HOLD] * (envs * p.agents))
            assert len(reply.obs) == envs * p.agents * D
            assert len(reply.masks) == envs * p.agents * 3
            assert len(reply.rewards) == envs * p.agents
            assert len(reply.terminated) == len(reply.truncated) == envs
            if t < 5:
                assert (
                    list(reply.truncated) == [0, 0] and not reply.final_obs and not reply.episodes
                )
                last = list(reply.obs)
    assert list(reply.truncated) == [1, 1] and list(reply.terminated) == [0, 0]
    assert len(reply.final_obs) == envs * p.agents * D
    assert [e.env for e in reply.episodes] == [0, 1]
    assert all(e.length == 5 and e.episode == 0 and not e.success for e in reply.episodes)
    # Holding AGVs end where they started...
    assert cells_of(reply.final_obs, p) == cells_of(before, p)
    # ...and the episode's last observation is the model's own after five
    # holds, while the reply shows episode 1's first.
    for e in range(envs):
        ep = sim.LineEpisode(p, 3, e, 0)
        for _ in range(5):
            ep.step([sim.HOLD] * p.agents)
        span = slice(e * p.agents * D, (e + 1) * p.agents * D)
        assert list(reply.final_obs[span]) == pytest.approx(ep.observe())
        assert list(reply.obs[span]) == pytest.approx(sim.LineEpisode(p, 3, e, 1).observe())
    assert list(reply.obs) != last


def test_delivery_ends_exactly_that_env():
    # AGV 0 loaded next to the sink; an order of one product ends the episode.
    p = sim.LineParams(
        agents=2, starts=((7, True), (0, False)), order=1, arrival_mean=NEVER, t_max=50
    )
    with served(p, envs=2) as (stub, _):
        s = stub.Reset(pb2.ResetRequest(seed=1)).session
        # Env 0 drives AGV 0 to the sink, env 1 holds.
        r1 = step(stub, s, [sim.FORWARD, sim.HOLD, sim.HOLD, sim.HOLD])
        assert cells_of(r1.obs, p) == [8, 0, 7, 0]
        assert list(r1.masks[:3]) == [1, 0, 0], "unloading: hold only"
        assert rows(r1.obs, 2)[0][4] == 1.0
        assert list(r1.rewards) == [0, 0, 0, 0]
        r2 = step(stub, s, [sim.HOLD] * 4)
        assert list(r2.rewards) == [0, 0, 0, 0] and not r2.episodes
        # Unloading takes 2 s: the product is delivered in the third second.
        r3 = step(stub, s, [sim.HOLD] * 4)
    assert list(r3.rewards) == [1.0, 0, 0, 0]
    assert list(r3.terminated) == [1, 0] and list(r3.truncated) == [0, 0]
    assert len(r3.final_obs) == 2 * D
    last = rows(r3.final_obs, 2)
    assert (
        last[0][1] == 1.0 and last[0][3] == 0.0 and last[0][2] == 0.0
    )  # at the sink, empty, goal source
    (ep,) = r3.episodes
    assert (ep.env, ep.episode, ep.length, ep.success, ep.goals_reached, ep.reward) == (
        0,
        0,
        3,
        True,
        1,
        1.0,
    )
    assert ep.kpis["deliveries"] == 1 and ep.kpis["mean_lead_time"] == 3.0
    assert ep.kpis["throughput_per_hour"] == pytest.approx(1200.0)
    # Env 0 starts over; env 1 is still in its first episode.
    assert cells_of(r3.obs, p) == [7, 0, 7, 0]


def test_pickup_after_loading():
    p = sim.LineParams(
        agents=2, starts=((1, False), (5, False)), initial_stock=1, arrival_mean=NEVER, t_max=3
    )
    with served(p) as (stub, _):
        s = stub.Reset(pb2.ResetRequest(seed=0)).session
        r1 = step(stub, s, [sim.BACKWARD, sim.HOLD])
        assert cells_of(r1.obs, p) == [0, 5] and list(r1.masks[:3]) == [1, 0, 0]
        assert rows(r1.obs, 2)[0][5] == 0.0, "the product left the source buffer"
        r2 = step(stub, s, [sim.HOLD, sim.HOLD])
        r3 = step(stub, s, [sim.HOLD, sim.HOLD])
    assert list(r2.rewards) == [0, 0]
    assert list(r3.rewards) == pytest.approx([0.1, 0.0])
    row = rows(r3.final_obs, 2)[0]
    assert row[3] == 1.0 and row[2] == 1.0  # loaded, goal the sink
    assert r3.episodes[0].kpis["pickups"] == 1 and r3.episodes[0].kpis["deliveries"] == 0


@pytest.mark.parametrize(
    "starts, actions, rewards, cells, collisions, blocked",
    [
        # Swapping cells on the lane: head-on, both −1, neither moves.
        (((2, False), (3, True)), [sim.FORWARD, sim.BACKWARD], [-1, -1], [2, 3], 1, 0),
        # Into one lane cell from both sides: head-on too.
        (((1, False), (3, True)), [sim.FORWARD, sim.BACKWARD], [-1, -1], [1, 3], 1, 0),
        # Into the empty siding (cell 4) from both sides: they meet there.
        (((3, True), (5, False)), [sim.FORWARD, sim.BACKWARD], [0, 0], [4, 4], 0, 0),
        # Into an AGV that stands: blocked, no penalty.
        (((2, False), (3, True)), [sim.FORWARD, sim.HOLD], [0, 0], [2, 3], 0, 1),
        # One behind the other, the same way: they move as a train.
        (((2, True), (3, True)), [sim.FORWARD, sim.FORWARD], [0, 0], [3, 4], 0, 0),
        # Off the track's end: masked, played as hold, a blocked move.
        (((0, False), (3, True)), [sim.BACKWARD, sim.HOLD], [0, 0], [0, 3], 0, 1),
    ],
)
def test_moves_and_collisions(starts, actions, rewards, cells, collisions, blocked):
    p = sim.LineParams(agents=2, starts=starts, arrival_mean=NEVER, t_max=1)
    with served(p) as (stub, _):
        s = stub.Reset(pb2.ResetRequest(seed=0)).session
        r = step(stub, s, actions)
    assert list(r.rewards) == rewards
    assert cells_of(r.final_obs, p) == cells
    (ep,) = r.episodes
    assert ep.kpis["collisions"] == collisions and ep.blocked_moves == blocked
    assert ep.reward == sum(rewards)


def test_passing_at_the_siding():
    p = sim.LineParams(agents=2, starts=((3, True), (5, False)), arrival_mean=NEVER, t_max=10)
    with served(p) as (stub, _):
        s = stub.Reset(pb2.ResetRequest(seed=0)).session
        r = step(stub, s, [sim.FORWARD, sim.BACKWARD])
        assert cells_of(r.obs, p) == [4, 4]
        assert rows(r.obs, 2)[0][6] == 1.0  # two AGVs on the siding
        r = step(stub, s, [sim.FORWARD, sim.BACKWARD])
    assert cells_of(r.obs, p) == [5, 3] and list(r.rewards) == [0, 0]


def test_facing_agvs_deadlock():
    # Loaded AGV 0 must pass AGV 1, which wants the source, on the lane.
    p = sim.LineParams(
        agents=2, starts=((2, True), (3, False)), arrival_mean=NEVER, t_max=6, deadlock_after=4
    )
    with served(p) as (stub, _):
        s = stub.Reset(pb2.ResetRequest(seed=0)).session
        for _ in range(6):
            r = step(stub, s, [sim.HOLD, sim.HOLD])
    (ep,) = r.episodes
    assert (ep.deadlock_events, ep.deadlock_steps) == (1, 3)
    assert ep.kpis["deadlocks"] == 1
    # Either way each is the other's nearest neighbour, heading its way.
    a, b = rows(r.final_obs, 2)
    assert a[7:9] == [pytest.approx(1 / 8), 1.0] and b[9:11] == [pytest.approx(1 / 8), 1.0]


def test_bad_input_gets_status_codes_and_the_server_carries_on():
    p = sim.LineParams(agents=2)
    with served(p, envs=2) as (stub, channel):
        s = stub.Reset(pb2.ResetRequest(seed=0)).session

        def code_of(call):
            with pytest.raises(grpc.RpcError) as e:
                call()
            return e.value.code(), e.value.details()

        code, msg = code_of(lambda: step(stub, s, [0, 0, 0]))
        assert code == grpc.StatusCode.INVALID_ARGUMENT and "holds 3 values, expected 4" in msg
        code, msg = code_of(lambda: step(stub, s, [0, 3, 0, 0]))
        assert code == grpc.StatusCode.INVALID_ARGUMENT and "actions[1] = 3 is out of range" in msg
        code, msg = code_of(lambda: step(stub, s ^ 1, [0] * 4))
        assert code == grpc.StatusCode.NOT_FOUND and "call Reset" in msg
        code, msg = code_of(lambda: step(stub, 0, [0] * 4))
        assert code == grpc.StatusCode.FAILED_PRECONDITION and "Reset first" in msg
        raw = channel.unary_unary("/buridan.v1.Environment/Step")
        # Field 2 (actions) announces 5 bytes and brings 2: no message.
        code, msg = code_of(lambda: raw(b"\x12\x05ab"))
        assert code == grpc.StatusCode.INVALID_ARGUMENT and "no valid message" in msg
        # The session is intact and steps.
        assert len(step(stub, s, [0] * 4).rewards) == 4


def test_least_recently_used_session_is_evicted():
    with served(sim.LineParams(agents=1), max_sessions=2) as (stub, _):
        s1, s2 = (stub.Reset(pb2.ResetRequest(seed=k)).session for k in (1, 2))
        step(stub, s1, [0])  # s2 is now the least recently used
        s3 = stub.Reset(pb2.ResetRequest(seed=3)).session
        with pytest.raises(grpc.RpcError) as e:
            step(stub, s2, [0])
        assert e.value.code() == grpc.StatusCode.NOT_FOUND
        for s in (s1, s3):
            step(stub, s, [0])


def test_bad_parameters_are_refused():
    with pytest.raises(ValueError, match="starts has 1 AGVs"):
        sim.LineParams(agents=2, starts=((0, False),)).check()
    with pytest.raises(ValueError, match="siding"):
        sim.LineParams(cells=5, siding=4).check()


def test_a_failing_model_costs_one_call_and_its_session(monkeypatch):
    with served(sim.LineParams(agents=1)) as (stub, _):
        s = stub.Reset(pb2.ResetRequest(seed=0)).session
        monkeypatch.setattr(sim.LineEpisode, "step", lambda self, actions: 1 / 0)
        with pytest.raises(grpc.RpcError) as e:
            step(stub, s, [0])
        assert e.value.code() == grpc.StatusCode.INTERNAL and "call Reset" in e.value.details()
        monkeypatch.undo()
        with pytest.raises(grpc.RpcError) as e:
            step(stub, s, [0])
        assert e.value.code() == grpc.StatusCode.NOT_FOUND
        s = stub.Reset(pb2.ResetRequest(seed=0)).session
        assert len(step(stub, s, [0]).rewards) == 1
