#!/usr/bin/env python3
"""A fleet manager driving robots through the fleet controller service.

Opens a session on `fleet-control` (buridan.v1.FleetControl, the proto in
proto/proto/buridan/v1/control.proto), then plays robots on a MovingAI map:
each step it reports every robot's actual cell and goal, gets every robot's
next move, and carries the moves out — each robot independently fails to
move with probability --delay (it stalls and reports the cell it is still
on). With --lifelong a robot that reaches its goal gets a new one (seeded).
With --goals FILE (a `lifelong-goals v1` file, as
scripts/pogema/export_lifelong.py writes POGEMA's) the robots start where
the file says and take their goals from it in order, so that the run can
be compared with `learner bench pogema --lifelong` on the same goals.

Needs grpcio and grpcio-tools (pip install grpcio grpcio-tools); the stubs
are generated from the repository's protos at start, into a temporary
directory. Start a server first:

    cargo run --release -p buridan-control --bin fleet-control -- --listen 127.0.0.1:50071
    python3 python/examples/fleet_client.py --controller lacam --delay 0.1 --steps 200

Prints the steps, the goals reached, the throughput (goals per step), the
moves the shield changed (shielded policies), the longest wait of a robot
off its goal, and the client-side p50/p99 step latency. Exits 1 if two
robots ever share a cell or swap cells.
"""

import argparse
import importlib
import random
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PROTO_DIR = ROOT / "proto" / "proto"
MOVES = {0: (0, 0), 1: (-1, 0), 2: (0, 1), 3: (1, 0), 4: (0, -1)}


def generate_stubs():
    """The messages and stubs of control.proto, generated into a temporary
    directory by grpcio-tools and imported from there."""
    from grpc_tools import protoc

    import grpc_tools

    out = Path(tempfile.mkdtemp(prefix="buridan-stubs-"))
    include = Path(grpc_tools.__file__).parent / "_proto"
    args = [
        "protoc",
        f"-I{PROTO_DIR}",
        f"-I{include}",
        f"--python_out={out}",
        f"--grpc_python_out={out}",
        str(PROTO_DIR / "buridan" / "v1" / "learner.proto"),
        str(PROTO_DIR / "buridan" / "v1" / "control.proto"),
    ]
    if protoc.main(args) != 0:
        raise SystemExit("grpc_tools.protoc failed on control.proto")
    sys.path.insert(0, str(out))
    pb = importlib.import_module("buridan.v1.control_pb2")
    learner_pb = importlib.import_module("buridan.v1.learner_pb2")
    grpc_pb = importlib.import_module("buridan.v1.control_pb2_grpc")
    return pb, learner_pb, grpc_pb


def read_map(path):
    """The map's text and its free cells (MovingAI: '.', 'G', 'S' are free)."""
    text = Path(path).read_text()
    lines = text.splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.strip() == "map") + 1
    free = [
        (r, c)
        for r, row in enumerate(lines[start:])
        for c, ch in enumerate(row.rstrip("\r"))
        if ch in ".GS"
    ]
    return text, free


def read_goal_file(path, robots):
    """Starts and goal sequences of the first `robots` agents of a
    `lifelong-goals v1` file: a header `lifelong-goals v1 map M agents N
    steps T`, then per agent `row,col` of its start and of its goals."""
    lines = [ln.strip() for ln in Path(path).read_text().splitlines()]
    body = [(i + 1, ln) for i, ln in enumerate(lines) if ln and not ln.startswith("#")]
    if not body or not body[0][1].startswith("lifelong-goals v1 "):
        raise SystemExit(f"{path}: no 'lifelong-goals v1' header")
    agents = body[1:]
    if len(agents) < robots:
        raise SystemExit(f"{path}: {len(agents)} agents, fewer than --robots {robots}")
    starts, sequences = [], []
    for number, line in agents[:robots]:
        try:
            cells = [tuple(int(v) for v in cell.split(",")) for cell in line.split()]
        except ValueError:
            raise SystemExit(f"{path}:{number}: cells must read row,col")
        if len(cells) < 2 or any(len(c) != 2 for c in cells):
            raise SystemExit(f"{path}:{number}: a start and at least one goal, each row,col")
        starts.append(cells[0])
        sequences.append(cells[1:])
    return starts, sequences


def execute(positions, moves, delay, rng):
    """Carries the moves out: each robot stalls with probability `delay`;
    a robot whose target is held by one that stays, or claimed by another,
    stays too (a real robot's local safety), so robots never collide."""
    target = []
    for (r, c), m in zip(positions, moves):
        if m != 0 and rng.random() < delay:
            m = 0
        dr, dc = MOVES[m]
        target.append((r + dr, c + dc))
    standing = {p: i for i, p in enumerate(positions)}
    changed = True
    while changed:
        changed = False
        staying = {positions[i] for i in range(len(positions)) if target[i] == positions[i]}
        claimed = {}
        for i, t in enumerate(target):
            claimed.setdefault(t, []).append(i)
        for i, t in enumerate(target):
            if t == positions[i]:
                continue
            j = standing.get(t)
            swap = j is not None and target[j] == positions[i]
            if t in staying or len(claimed[t]) > 1 or swap:
                target[i] = positions[i]
                changed = True
    return target


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--server", default="127.0.0.1:50071", help="host:port of fleet-control")
    ap.add_argument("--token", help="the server's --token, if it has one")
    ap.add_argument("--map-file", default=str(ROOT / "env" / "maps" / "rm-2.1.map"), help="a MovingAI .map file, sent as text")
    ap.add_argument("--controller", default="lacam", help="a controller name, e.g. pibt, lacam, shield-lanes=16:checkpoint:model:rm-2.1")
    ap.add_argument("--rules", default="thesis", choices=["thesis", "pogema"])
    ap.add_argument("--robots", type=int, default=4)
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--delay", type=float, default=0.1, help="probability that a robot fails to carry out its move")
    ap.add_argument("--lifelong", action="store_true", help="a new goal on arrival")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--goals", help="a lifelong-goals v1 file: starts and goal sequences (lifelong, no draws)")
    ap.add_argument("--seconds", type=float, help="stop after this much wall time even if --steps are not done (soak runs)")
    args = ap.parse_args()

    import grpc

    pb, learner_pb, grpc_pb = generate_stubs()
    rng = random.Random(args.seed)
    text, free = read_map(args.map_file)
    if args.goals:
        positions, sequences = read_goal_file(args.goals, args.robots)
        goals = [seq[0] for seq in sequences]
        taken_goals = [1] * args.robots
    else:
        cells = rng.sample(free, 2 * args.robots)
        positions, goals = cells[: args.robots], cells[args.robots :]

    channel = grpc.insecure_channel(args.server)
    stub = grpc_pb.FleetControlStub(channel)
    metadata = [("authorization", f"Bearer {args.token}")] if args.token else []
    rules = {"thesis": learner_pb.RULES_THESIS, "pogema": learner_pb.RULES_POGEMA}[args.rules]
    cell = lambda rc: pb.GridCell(row=rc[0], col=rc[1])  # noqa: E731
    opened = stub.Open(
        pb.FleetOpenRequest(
            map=pb.FleetMap(text=learner_pb.MapSource(name=Path(args.map_file).stem, map_text=text)),
            rules=rules,
            controller=args.controller,
            positions=[cell(p) for p in positions],
            goals=[cell(g) for g in goals],
            seed=args.seed,
            # POGEMA's goal sequences may send two robots to one cell.
            shared_goals=bool(args.goals),
        ),
        metadata=metadata,
    )
    print(f"session {opened.session}: {opened.agents} robots, {opened.controller} on {opened.map_name} ({opened.height}x{opened.width})")

    reached, overridden, latencies, longest = 0, 0, [], 0
    waits = [0] * args.robots
    collisions = 0
    steps = 0
    deadline = None if args.seconds is None else time.monotonic() + args.seconds
    for steps in range(1, args.steps + 1):
        if deadline is not None and time.monotonic() >= deadline:
            steps -= 1
            break
        t0 = time.perf_counter()
        reply = stub.Step(
            pb.FleetStepRequest(session=opened.session, positions=[cell(p) for p in positions], goals=[cell(g) for g in goals]),
            metadata=metadata,
        )
        latencies.append(time.perf_counter() - t0)
        overridden += sum(reply.overridden)
        after = execute(positions, list(reply.moves), args.delay, rng)
        standing = {p: i for i, p in enumerate(positions)}
        swapped = any(
            (j := standing.get(now)) is not None and j != i and after[j] == positions[i]
            for i, now in enumerate(after)
        )
        if len(set(after)) < len(after) or swapped:
            collisions += 1
        for i, (before, now) in enumerate(zip(positions, after)):
            waits[i] = waits[i] + 1 if now == before and now != goals[i] else 0
            longest = max(longest, waits[i])
        positions = after
        for i in range(args.robots):
            if positions[i] == goals[i]:
                if args.goals:
                    reached += 1
                    if taken_goals[i] == len(sequences[i]):
                        print(f"robot {i} has used all {taken_goals[i]} goals of its sequence", file=sys.stderr)
                        return 1
                    goals[i] = sequences[i][taken_goals[i]]
                    taken_goals[i] += 1
                elif args.lifelong:
                    reached += 1
                    taken = set(goals)
                    goals[i] = rng.choice([c for c in free if c not in taken])
        if not (args.lifelong or args.goals) and positions == goals:
            reached = args.robots
            break
    stub.Close(pb.FleetCloseRequest(session=opened.session), metadata=metadata)
    latencies.sort()
    p = lambda q: 1000 * latencies[min(len(latencies) - 1, int(q * len(latencies)))] if latencies else 0.0  # noqa: E731
    print(
        f"{steps} steps: {reached} goals reached ({reached / max(steps, 1):.3f} per step), "
        f"{overridden} moves changed by the shield, longest wait {longest} steps, "
        f"step latency p50 {p(0.5):.2f} ms, p99 {p(0.99):.2f} ms (client side)"
    )
    if collisions:
        print(f"{collisions} steps with robots on one cell or swapping", file=sys.stderr)
        return 1
    if not (args.lifelong or args.goals) and positions != goals:
        print("not every robot reached its goal", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
