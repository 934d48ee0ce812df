#!/usr/bin/env python3
"""A SimPy plant behind Buridan's env API: how a simulator plugs in.

Buridan's actors step envs on any server of ``buridan.v1.Environment``
(``proto/proto/buridan/v1/env.proto``: Spec, Reset, Step). This file is
such a server for a small production-logistics model written in SimPy, in
the shape a Plant Simulation, AnyLogic or in-house model would take:

    pip install grpcio grpcio-tools protobuf simpy     # pinned: python/requirements-test.txt
    python python/examples/simpy_env_server.py --listen 127.0.0.1:50061 --envs 4 --agents 2

**The model** (``LineParams`` has every number). A single-lane track of
``cells`` cells (one metre each, say); the source at cell 0 and the sink at
the last cell, both at dead ends; one passing siding in the middle, the only
cell two AGVs can share and so the only place they can pass. Products
arrive at the source at exponential intervals into a buffer of limited
capacity (arrivals at a full buffer are lost). AGVs drive one cell per
second; an empty AGV's goal is the source, a loaded one's the sink. An AGV
that ends a step at its goal loads (if a product waits) or unloads, which
takes ``handling_time`` seconds during which it can only hold.

- Actions per AGV: 0 hold, 1 forward (towards the sink), 2 backward
  (towards the source). Masks forbid driving off the track ends and moving
  while handling; a masked action is played as hold and counted as a
  blocked move.
- Two AGVs that drive at each other — swapping cells, or into one cell
  from both sides unless it is the empty siding — collide: −1 each, and
  neither moves. A move into a cell that stays full is blocked (no
  penalty). Rewards otherwise: +1 per delivery, +0.1 per pickup.
- Episodes are truncated at ``t_max`` steps; with ``order`` > 0 one also
  ends (terminated, a success) once that many products are delivered.
- Observation, 11 floats per AGV in [0, 1]: its index, position, goal,
  loaded, handling, the source buffer's fill, AGVs on the siding, and per
  direction the distance to the nearest other AGV and whether that AGV's
  goal lies towards this one. Eleven is the native plant's local
  observation size, which is what a ``learner serve --plant`` run checks
  an env server's spec against (README.md, "External simulators").
- KPIs per finished episode: deliveries, pickups, lost products,
  collisions, blocked moves, deadlocks, throughput per hour, mean lead time.

**Simulation time.** Each env of the batch is a ``simpy.Environment``:
the source and every AGV are SimPy processes; Step hands each idle AGV its
move and runs the model one second (``env.run(until=now + 1)``).

**Serving.** grpcio runs the service on a thread pool; sessions (one per
Reset, keyed by a random id) are independent and seeded, and the least
recently used is evicted beyond ``--max-sessions``. Bad input gets the
status codes env.proto names, with a message; the server carries on.
"""

from __future__ import annotations

import argparse
import collections
import logging
import random
import secrets
import signal
import sys
import threading
from concurrent import futures
from dataclasses import dataclass, field
from pathlib import Path
from typing import List, Optional, Sequence, Tuple

import grpc
import simpy

sys.path.insert(0, str(Path(__file__).resolve().parent))
import env_stubs  # noqa: E402

log = logging.getLogger("simpy_env_server")

HOLD, FORWARD, BACKWARD = 0, 1, 2
NUM_ACTIONS = 3
ACTION_NAMES = "0 hold, 1 forward, 2 backward"
OBS_DIM = 11
REWARD_DELIVERY = 1.0
REWARD_PICKUP = 0.1
REWARD_COLLISION = -1.0


@dataclass(frozen=True)
class LineParams:
    """The plant and its episodes; every number a modeller would change."""

    agents: int = 2
    # Cells of the track; the source is cell 0, the sink the last one.
    cells: int = 9
    # The passing siding's cell (default: the middle).
    siding: Optional[int] = None
    t_max: int = 1000
    # Seconds to load at the source or unload at the sink.
    handling_time: int = 2
    # Mean seconds between products at the source (exponential).
    arrival_mean: float = 8.0
    source_capacity: int = 3
    # Products in the source buffer when an episode starts.
    initial_stock: int = 0
    # Deliveries that complete an episode (terminated); 0: episodes only
    # end at t_max, as on the native plant.
    order: int = 0
    # Steps a pair of AGVs must wait for each other to count as a deadlock.
    deadlock_after: int = 10
    # Fixed (cell, loaded) per AGV for every episode; None draws distinct
    # cells and loads from the episode's seed.
    starts: Optional[Tuple[Tuple[int, bool], ...]] = None

    @property
    def siding_cell(self) -> int:
        return self.cells // 2 if self.siding is None else self.siding

    def capacity(self, cell: int) -> int:
        return 2 if cell == self.siding_cell else 1

    def check(self) -> None:
        """Raises ValueError naming the first bad parameter."""
        if self.cells < 3:
            raise ValueError(
                f"cells = {self.cells}: the track needs at least 3 (source, siding, sink)"
            )
        if not 0 < self.siding_cell < self.cells - 1:
            raise ValueError(
                f"siding = {self.siding_cell} must lie strictly between the source (0) "
                f"and the sink ({self.cells - 1})"
            )
        if not 1 <= self.agents <= self.cells:
            raise ValueError(
                f"agents = {self.agents}: must be 1..{self.cells} (one per cell at the start)"
            )
        if self.t_max < 1:
            raise ValueError(f"t_max = {self.t_max} must be at least 1")
        if self.handling_time < 0 or self.arrival_mean <= 0 or self.source_capacity < 1:
            raise ValueError(
                "handling_time >= 0, arrival_mean > 0 and source_capacity >= 1 are required"
            )
        if not 0 <= self.initial_stock <= self.source_capacity:
            raise ValueError(
                f"initial_stock = {self.initial_stock} must be 0..source_capacity "
                f"({self.source_capacity})"
            )
        if self.order < 0 or self.deadlock_after < 1:
            raise ValueError("order >= 0 and deadlock_after >= 1 are required")
        if self.starts is not None:
            if len(self.starts) != self.agents:
                raise ValueError(f"starts has {len(self.starts)} AGVs, agents = {self.agents}")
            cells = [c for c, _ in self.starts]
            if any(not 0 <= c < self.cells for c in cells):
                raise ValueError(f"starts {cells}: cells must be 0..{self.cells - 1}")
            if any(cells.count(c) > self.capacity(c) for c in cells):
                raise ValueError(f"starts {cells}: more AGVs on a cell than it holds")


def resolve_moves(
    positions: Sequence[int], wanted: Sequence[int], capacity
) -> Tuple[List[int], List[Tuple[int, int]], List[int]]:
    """Who moves this step: ``(moves, collisions, blocked)``.

    ``wanted`` holds −1, 0 or +1 per AGV. Head-on pairs collide and stay;
    then moves into cells that would hold more AGVs than ``capacity(cell)``
    are cancelled (lower indices first in), repeatedly, since a cancelled
    move leaves its AGV in the cell it meant to free. AGVs following each
    other in one direction move together.
    """
    n = len(positions)
    moves = list(wanted)
    collisions = []
    for i in range(n):
        for j in range(i + 1, n):
            if not wanted[i] or wanted[j] != -wanted[i]:
                continue
            ti, tj = positions[i] + wanted[i], positions[j] + wanted[j]
            swap = ti == positions[j] and tj == positions[i]
            # Two AGVs can meet only on a siding nobody stands on.
            meet = ti == tj and (capacity(ti) < 2 or ti in positions)
            if swap or meet:
                collisions.append((i, j))
    for i, j in collisions:
        moves[i] = moves[j] = 0
    changed = True
    while changed:
        changed = False
        for cell in set(p + m for p, m in zip(positions, moves) if m):
            staying = sum(1 for p, m in zip(positions, moves) if p == cell and not m)
            coming = [i for i in range(n) if moves[i] and positions[i] + moves[i] == cell]
            for i in coming[max(capacity(cell) - staying, 0) :]:
                moves[i] = 0
                changed = True
    collided = {i for pair in collisions for i in pair}
    blocked = [i for i in range(n) if wanted[i] and not moves[i] and i not in collided]
    return moves, collisions, blocked


@dataclass
class Product:
    created: float


@dataclass
class Agv:
    index: int
    cell: int
    load: Optional[Product]
    orders: simpy.Store
    handling: bool = False


@dataclass
class Kpis:
    deliveries: int = 0
    pickups: int = 0
    lost: int = 0
    collisions: int = 0
    blocked_moves: int = 0
    deadlock_steps: int = 0
    deadlock_events: int = 0
    lead_times: List[float] = field(default_factory=list)


class LineEpisode:
    """One episode of one env: a SimPy model stepped a second at a time.

    Episode ``episode`` of env ``env`` in a session seeded ``seed`` is a
    pure function of those three numbers and the actions played.
    """

    def __init__(self, params: LineParams, seed: int, env: int, episode: int):
        self.p = params
        self.episode = episode
        # A string seed is hashed with SHA-512: stable across processes and
        # Python versions, unlike hash().
        self.rng = random.Random(f"simpy-line:{seed}:{env}:{episode}")
        self.sim = simpy.Environment()
        self.source = simpy.Store(self.sim, capacity=params.source_capacity)
        for _ in range(params.initial_stock):
            self.source.put(Product(created=0.0))
        if params.starts is not None:
            starts = list(params.starts)
        else:
            cells = self.rng.sample(range(params.cells), params.agents)
            starts = [(c, self.rng.random() < 0.5) for c in cells]
        self.agvs = [
            Agv(i, cell, Product(created=0.0) if loaded else None, simpy.Store(self.sim))
            for i, (cell, loaded) in enumerate(starts)
        ]
        self.rewards = [0.0] * params.agents
        self.kpis = Kpis()
        self.t = 0
        self.total_reward = 0.0
        self.waiting_since: dict = {}
        self.sim.process(self._arrivals())
        for agv in self.agvs:
            self.sim.process(self._drive(agv))

    # --- SimPy processes -------------------------------------------------

    def _arrivals(self):
        while True:
            yield self.sim.timeout(self.rng.expovariate(1.0 / self.p.arrival_mean))
            if len(self.source.items) < self.source.capacity:
                self.source.put(Product(created=self.sim.now))
            else:
                self.kpis.lost += 1

    def _drive(self, agv: Agv):
        while True:
            move = yield agv.orders.get()
            if move:
                yield self.sim.timeout(1)
                agv.cell += move
            if agv.cell == self.goal(agv):
                yield from self._handle(agv)

    def _handle(self, agv: Agv):
        if agv.load is None:
            if not self.source.items:
                return
            agv.handling = True
            product = yield self.source.get()
            yield self.sim.timeout(self.p.handling_time)
            agv.load = product
            self.kpis.pickups += 1
            self.rewards[agv.index] += REWARD_PICKUP
        else:
            agv.handling = True
            yield self.sim.timeout(self.p.handling_time)
            self.kpis.deliveries += 1
            self.kpis.lead_times.append(self.sim.now - agv.load.created)
            agv.load = None
            self.rewards[agv.index] += REWARD_DELIVERY
        agv.handling = False

    # --- the step --------------------------------------------------------

    def goal(self, agv: Agv) -> int:
        return 0 if agv.load is None else self.p.cells - 1

    def mask(self, agv: Agv) -> bytes:
        if agv.handling:
            return bytes((1, 0, 0))
        return bytes((1, int(agv.cell < self.p.cells - 1), int(agv.cell > 0)))

    def step(self, actions: Sequence[int]) -> List[float]:
        """Plays one action per AGV; the AGVs' rewards for this second."""
        wanted, masked = [], 0
        for agv, action in zip(self.agvs, actions):
            if action != HOLD and not self.mask(agv)[action]:
                masked += 1
                action = HOLD
            wanted.append({HOLD: 0, FORWARD: 1, BACKWARD: -1}[action])
        moves, collisions, blocked = resolve_moves(
            [a.cell for a in self.agvs], wanted, self.p.capacity
        )
        for i, j in collisions:
            self.rewards[i] += REWARD_COLLISION
            self.rewards[j] += REWARD_COLLISION
        self.kpis.collisions += len(collisions)
        self.kpis.blocked_moves += len(blocked) + masked
        for agv, move in zip(self.agvs, moves):
            # A handling AGV is inside its SimPy process's timeout, not
            # waiting for orders; an order now would be read after it.
            if not agv.handling:
                agv.orders.put(move)
        end = self.sim.now + 1
        self.sim.run(until=end)
        # run(until=t) stops before the events due at t itself; the moves
        # and handling that end at this second belong to this step.
        while self.sim.peek() <= end:
            self.sim.step()
        self.t += 1
        self._watch_deadlocks()
        rewards, self.rewards = self.rewards, [0.0] * self.p.agents
        self.total_reward += sum(rewards)
        return rewards

    def _waits_for(self, agv: Agv) -> set:
        """The AGVs filling the next cell on ``agv``'s way to its goal."""
        goal = self.goal(agv)
        if agv.handling or agv.cell == goal:
            return set()
        ahead = agv.cell + (1 if goal > agv.cell else -1)
        there = {b.index for b in self.agvs if b.cell == ahead}
        return there if len(there) >= self.p.capacity(ahead) else set()

    def _watch_deadlocks(self) -> None:
        # On a line every cycle of waiting AGVs contains two that wait for
        # each other, so pairs are enough.
        waits = [self._waits_for(a) for a in self.agvs]
        pairs = {(i, j) for i in range(len(waits)) for j in waits[i] if i < j and i in waits[j]}
        self.waiting_since = {pair: self.waiting_since.get(pair, self.t) for pair in pairs}
        ages = [self.t - since + 1 for since in self.waiting_since.values()]
        if any(age >= self.p.deadlock_after for age in ages):
            self.kpis.deadlock_steps += 1
        self.kpis.deadlock_events += sum(1 for age in ages if age == self.p.deadlock_after)

    @property
    def terminated(self) -> bool:
        return self.p.order > 0 and self.kpis.deliveries >= self.p.order

    @property
    def truncated(self) -> bool:
        return not self.terminated and self.t >= self.p.t_max

    def observe(self) -> List[float]:
        """The AGVs' rows, ``agents x OBS_DIM`` floats in [0, 1]."""
        p, span = self.p, self.p.cells - 1
        on_siding = sum(1 for a in self.agvs if a.cell == p.siding_cell)
        fill = len(self.source.items) / p.source_capacity
        out: List[float] = []
        for agv in self.agvs:
            row = [
                agv.index / max(p.agents - 1, 1),
                agv.cell / span,
                self.goal(agv) / span,
                float(agv.load is not None),
                float(agv.handling),
                fill,
                on_siding / 2,
            ]
            for direction in (1, -1):
                others = [
                    b for b in self.agvs if b is not agv and (b.cell - agv.cell) * direction >= 0
                ]
                if others:
                    near = min(others, key=lambda b: abs(b.cell - agv.cell))
                    coming = (self.goal(near) - near.cell) * direction < 0
                    row += [abs(near.cell - agv.cell) / span, float(coming)]
                else:
                    row += [1.0, 0.0]
            out += row
        return out

    def masks(self) -> bytes:
        return b"".join(self.mask(a) for a in self.agvs)

    def finished(self, env: int, pb2):
        """The ended episode as a ``FinishedEpisode``."""
        k = self.kpis
        kpis = {
            "deliveries": k.deliveries,
            "pickups": k.pickups,
            "lost_products": k.lost,
            "collisions": k.collisions,
            "blocked_moves": k.blocked_moves,
            "deadlocks": k.deadlock_events,
            "throughput_per_hour": k.deliveries * 3600.0 / self.t,
        }
        if k.lead_times:
            # env.proto allows finite values only: no lead time without
            # a delivery.
            kpis["mean_lead_time"] = sum(k.lead_times) / len(k.lead_times)
        return pb2.FinishedEpisode(
            env=env,
            episode=self.episode,
            reward=self.total_reward,
            length=self.t,
            success=self.terminated,
            agents_at_goal=sum(1 for a in self.agvs if a.cell == self.goal(a)),
            blocked_moves=k.blocked_moves,
            goals_reached=k.deliveries,
            deadlock_steps=k.deadlock_steps,
            deadlock_events=k.deadlock_events,
            kpis={name: float(v) for name, v in kpis.items()},
        )


class Session:
    """A batch of envs stepped in lockstep, as one Reset made it."""

    def __init__(self, params: LineParams, num_envs: int, seed: int):
        self.params, self.seed = params, seed
        self.envs = [LineEpisode(params, seed, e, 0) for e in range(num_envs)]
        # gRPC may run two Steps of one session on two threads.
        self.lock = threading.Lock()

    def observe(self) -> Tuple[List[float], bytes]:
        obs: List[float] = []
        for env in self.envs:
            obs += env.observe()
        return obs, b"".join(env.masks() for env in self.envs)

    def step(self, actions: bytes, pb2):
        agents = self.params.agents
        rewards: List[float] = []
        terminated, truncated = bytearray(), bytearray()
        final_obs: List[float] = []
        episodes = []
        for e, env in enumerate(self.envs):
            rewards += env.step(actions[e * agents : (e + 1) * agents])
            terminated.append(env.terminated)
            truncated.append(env.truncated)
            if env.terminated or env.truncated:
                final_obs += env.observe()
                episodes.append(env.finished(e, pb2))
                log.debug(
                    "session env %d episode %d ended after %d steps: %s",
                    e,
                    env.episode,
                    env.t,
                    dict(episodes[-1].kpis),
                )
                # Envs reset themselves: the reply shows the next episode.
                self.envs[e] = LineEpisode(self.params, self.seed, e, env.episode + 1)
        obs, masks = self.observe()
        return pb2.StepReply(
            obs=obs,
            masks=masks,
            rewards=rewards,
            terminated=bytes(terminated),
            truncated=bytes(truncated),
            final_obs=final_obs,
            episodes=episodes,
        )


class _Undecodable:
    """A request whose bytes are no message (see ``_decoder``)."""

    def __init__(self, error: Exception):
        self.error = error


def _decoder(message_type):
    # grpcio answers a request it cannot decode with INTERNAL; env.proto
    # promises INVALID_ARGUMENT, so decoding happens in the handler's reach.
    def decode(data: bytes):
        try:
            return message_type.FromString(data)
        except Exception as e:  # protobuf's DecodeError, or worse
            return _Undecodable(e)

    return decode


class EnvironmentService:
    """``buridan.v1.Environment`` over ``LineEpisode`` batches."""

    def __init__(self, params: LineParams, num_envs: int, max_sessions: int = 64):
        params.check()
        if num_envs < 1 or max_sessions < 1:
            raise ValueError("num_envs and max_sessions must be at least 1")
        self.pb2, _ = env_stubs.load()
        self.params, self.num_envs, self.max_sessions = params, num_envs, max_sessions
        self.sessions: "collections.OrderedDict[int, Session]" = collections.OrderedDict()
        self.lock = threading.Lock()

    def spec(self):
        return self.pb2.EnvSpec(
            num_envs=self.num_envs,
            agents=self.params.agents,
            obs_kind=self.pb2.OBS_KIND_LOCAL,
            obs_dim=OBS_DIM,
            num_actions=NUM_ACTIONS,
            t_max=self.params.t_max,
            name=f"simpy:line-{self.params.cells}",
        )

    def Spec(self, request, context):
        self._decoded(request, context)
        return self.spec()

    def Reset(self, request, context):
        self._decoded(request, context)
        session = Session(self.params, self.num_envs, request.seed)
        with self.lock:
            # Random ids: a restarted server must not take an old session's
            # id for one of its own (the client would step the wrong envs).
            sid = 0
            while sid == 0 or sid in self.sessions:
                sid = secrets.randbits(63)
            self.sessions[sid] = session
            while len(self.sessions) > self.max_sessions:
                old, _ = self.sessions.popitem(last=False)
                log.info("session %d evicted (more than %d sessions)", old, self.max_sessions)
        log.info("session %d: %d envs, seed %d", sid, self.num_envs, request.seed)
        obs, masks = session.observe()
        return self.pb2.ResetReply(session=sid, obs=obs, masks=masks)

    def Step(self, request, context):
        self._decoded(request, context)
        if request.session == 0:
            context.abort(
                grpc.StatusCode.FAILED_PRECONDITION,
                "step before reset: this request names no session (0); call Reset first",
            )
        with self.lock:
            session = self.sessions.get(request.session)
            if session is not None:
                self.sessions.move_to_end(request.session)
        if session is None:
            context.abort(
                grpc.StatusCode.NOT_FOUND,
                f"session {request.session} is unknown to this server (restarted, or evicted "
                f"beyond {self.max_sessions} sessions): call Reset again",
            )
        agents = self.params.agents
        expected = self.num_envs * agents
        if len(request.actions) != expected:
            context.abort(
                grpc.StatusCode.INVALID_ARGUMENT,
                f"actions holds {len(request.actions)} values, expected {expected} "
                f"({self.num_envs} envs x {agents} agents, env-major; one byte per agent)",
            )
        for i, a in enumerate(request.actions):
            if a >= NUM_ACTIONS:
                context.abort(
                    grpc.StatusCode.INVALID_ARGUMENT,
                    f"actions[{i}] = {a} is out of range (must be < {NUM_ACTIONS}: {ACTION_NAMES})",
                )
        with session.lock:
            try:
                return session.step(request.actions, self.pb2)
            except Exception:
                # Some envs may have stepped and others not: the session is
                # no longer a batch in lockstep, so its client must reset.
                with self.lock:
                    self.sessions.pop(request.session, None)
                raise

    @staticmethod
    def _decoded(request, context) -> None:
        if isinstance(request, _Undecodable):
            context.abort(
                grpc.StatusCode.INVALID_ARGUMENT,
                f"the request is no valid message: {request.error}",
            )

    def handler(self) -> grpc.GenericRpcHandler:
        pb2 = self.pb2

        def method(fn, request_type):
            def guarded(request, context):
                try:
                    return fn(request, context)
                except Exception:
                    # context.abort raises too; only other exceptions are
                    # our bugs, which must cost one call, not the server.
                    if context.code() is None:
                        log.exception("%s failed", fn.__name__)
                        context.abort(
                            grpc.StatusCode.INTERNAL,
                            f"{fn.__name__} failed in the simulator (logged on the server); "
                            "a failed Step closes its session: call Reset",
                        )
                    raise

            return grpc.unary_unary_rpc_method_handler(
                guarded,
                request_deserializer=_decoder(request_type),
                response_serializer=lambda m: m.SerializeToString(),
            )

        return grpc.method_handlers_generic_handler(
            "buridan.v1.Environment",
            {
                "Spec": method(self.Spec, pb2.SpecRequest),
                "Reset": method(self.Reset, pb2.ResetRequest),
                "Step": method(self.Step, pb2.StepRequest),
            },
        )


def serve(listen: str, params: LineParams, num_envs: int, max_sessions: int = 64, workers: int = 4):
    """Starts the server on ``listen`` (``host:port``, port 0 picks one):
    ``(server, port)``."""
    service = EnvironmentService(params, num_envs, max_sessions)
    server = grpc.server(futures.ThreadPoolExecutor(max_workers=workers))
    server.add_generic_rpc_handlers((service.handler(),))
    try:
        port = server.add_insecure_port(listen)
    except RuntimeError as e:  # grpcio >= 1.5x raises instead of returning 0
        raise OSError(f"cannot listen on {listen}: {e}") from e
    if port == 0:
        raise OSError(f"cannot listen on {listen}")
    server.start()
    return server, port


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--listen", default="127.0.0.1:50061", help="host:port (default %(default)s)")
    ap.add_argument("--envs", type=int, default=4, help="envs per session (default %(default)s)")
    ap.add_argument("--agents", type=int, default=2, help="AGVs per env (default %(default)s)")
    ap.add_argument(
        "--t-max",
        type=int,
        default=LineParams.t_max,
        help="steps per episode (default %(default)s)",
    )
    ap.add_argument(
        "--cells", type=int, default=LineParams.cells, help="track cells (default %(default)s)"
    )
    ap.add_argument(
        "--order",
        type=int,
        default=0,
        help="deliveries that end an episode as done (default 0: t_max only)",
    )
    ap.add_argument(
        "--arrival-mean",
        type=float,
        default=LineParams.arrival_mean,
        help="mean seconds between products (default %(default)s)",
    )
    ap.add_argument(
        "--max-sessions",
        type=int,
        default=64,
        help="sessions kept; the least recently used is evicted beyond (default %(default)s)",
    )
    ap.add_argument(
        "--workers", type=int, default=4, help="gRPC worker threads (default %(default)s)"
    )
    ap.add_argument("--log-level", default="INFO", help="logging level (default %(default)s)")
    args = ap.parse_args(argv)
    logging.basicConfig(
        level=args.log_level.upper(), format="%(asctime)s %(levelname)s %(name)s: %(message)s"
    )
    params = LineParams(
        agents=args.agents,
        cells=args.cells,
        t_max=args.t_max,
        order=args.order,
        arrival_mean=args.arrival_mean,
    )
    try:
        params.check()
        server, port = serve(args.listen, params, args.envs, args.max_sessions, args.workers)
    except (ValueError, OSError) as e:
        ap.error(str(e))
    log.info(
        "serving buridan.v1.Environment on %s (port %d): %d envs x %d AGVs, %d cells, T_max %d",
        args.listen,
        port,
        args.envs,
        args.agents,
        args.cells,
        args.t_max,
    )
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    stop.wait()
    log.info("stopping")
    server.stop(grace=1).wait()
    return 0


if __name__ == "__main__":
    sys.exit(main())
