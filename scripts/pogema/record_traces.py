#!/usr/bin/env python3
"""Records POGEMA 1.4.0 episodes for the env's parity test (`env/tests/pogema_parity.rs`).

Every episode runs in the `pogema` package itself with `collision_system="soft"`
and `on_target="nothing"` (the rules of the published warehouse results) and
stores the map, starts, goals, each step's joint action (pogema's own action
indices) and resulting positions, how the episode ended and pogema's own
metrics, with the per-agent costs behind its SoC and makespan.

Episodes: the benchmark's warehouse instances (``warehouse.map`` and
``warehouse-<N>-<seed>.scen``, 32 to 192 agents) and small maps from pogema's
own generator, each under three action streams: uniform random, goal-directed
with some noise (agents arrive, leave and return, and some episodes succeed),
and a crowd in which everyone heads for one hotspot (contested cells, chains,
swaps and cycles in every step).

Usage (inside a virtual environment with ``requirements.txt``)::

    python3 scripts/pogema/record_traces.py --shared ../shared/pogema \\
        --out env/tests/data/pogema/traces.json.gz

The output is deterministic for given arguments (fixed seeds, gzip without a
timestamp).
"""

import argparse
import collections
import gzip
import json
import sys
from pathlib import Path

import numpy as np
import pogema
from pogema import GridConfig, pogema_v0
from pogema.wrappers.metrics import SumOfCostsAndMakespanMetric

# pogema's action order (GridConfig.MOVES): stay, up, down, left, right.
MOVES = [(0, 0), (-1, 0), (1, 0), (0, -1), (0, 1)]
WALL_CHARS = set("@OTW")

# (scenario agents, agents used = its first lines, scenario seeds) of the
# warehouse episodes; every seed runs each policy. The 8-agent ones succeed.
WAREHOUSE = [(32, 8, [0, 1, 2, 3]), (32, 32, [0, 1]), (64, 64, [0, 1]), (96, 96, [2]),
             (128, 128, [3]), (160, 160, [4]), (192, 192, [5, 6, 7, 8, 9])]
# (size, density, agents, t_max, seed) of the generated small maps.
SMALL = [
    (6, 0.2, 4, 32, 11), (6, 0.1, 12, 32, 12), (8, 0.3, 6, 64, 13), (8, 0.2, 20, 64, 14),
    (10, 0.3, 8, 64, 15), (10, 0.2, 30, 128, 16), (12, 0.3, 16, 128, 17), (12, 0.1, 60, 128, 18),
    (16, 0.3, 24, 128, 19), (16, 0.2, 80, 128, 20), (5, 0.0, 2, 16, 21), (5, 0.0, 12, 16, 22),
    (7, 0.3, 3, 48, 23), (9, 0.25, 10, 48, 24), (20, 0.3, 40, 128, 25), (24, 0.2, 100, 128, 26),
    (8, 0.1, 2, 64, 27), (8, 0.1, 3, 64, 28), (10, 0.2, 3, 64, 29), (10, 0.1, 4, 64, 30),
    (12, 0.2, 4, 96, 31), (12, 0.1, 5, 96, 32), (14, 0.2, 5, 128, 33), (16, 0.1, 6, 128, 34),
    (6, 0.0, 3, 24, 35), (20, 0.2, 6, 128, 36), (4, 0.0, 2, 12, 37), (32, 0.2, 8, 128, 38),
]
POLICIES = ["random", "greedy", "crowd"]


def read_map(path):
    lines = Path(path).read_text().splitlines()
    start = lines.index("map") + 1
    height = int(lines[1].split()[1])
    rows = [line.rstrip("\r") for line in lines[start:start + height]]
    return ["".join("@" if ch in WALL_CHARS else "." for ch in row) for row in rows]


def read_scen(path, agents):
    """Starts and goals as (row, col), agent i = line i (MovingAI x = column, y = row)."""
    starts, goals = [], []
    for line in Path(path).read_text().splitlines()[1:1 + agents]:
        f = line.split("\t")
        starts.append((int(f[5]), int(f[4])))
        goals.append((int(f[7]), int(f[6])))
    return starts, goals


def distances(rows, target):
    """BFS step distances to `target` on the static layout (None = unreachable)."""
    h, w = len(rows), len(rows[0])
    dist = [[None] * w for _ in range(h)]
    dist[target[0]][target[1]] = 0
    queue = collections.deque([target])
    while queue:
        r, c = queue.popleft()
        for dr, dc in MOVES[1:]:
            nr, nc = r + dr, c + dc
            if 0 <= nr < h and 0 <= nc < w and rows[nr][nc] == "." and dist[nr][nc] is None:
                dist[nr][nc] = dist[r][c] + 1
                queue.append((nr, nc))
    return dist


def downhill(dist, pos, rng):
    """A random move that gets closer on `dist`, or stay if none does."""
    r, c = pos
    here = dist[r][c]
    options = []
    for a, (dr, dc) in enumerate(MOVES):
        if a == 0:
            continue
        nr, nc = r + dr, c + dc
        if 0 <= nr < len(dist) and 0 <= nc < len(dist[0]):
            d = dist[nr][nc]
            if d is not None and here is not None and d < here:
                options.append(a)
    return int(rng.choice(options)) if options else 0


def find_metric(env):
    while env is not None:
        if isinstance(env, SumOfCostsAndMakespanMetric):
            return env
        env = getattr(env, "env", None)
    raise RuntimeError("no SumOfCostsAndMakespanMetric in the wrapper chain")


def record(name, rows, starts, goals, t_max, policy, seed):
    h, w = len(rows), len(rows[0])
    text = "\n".join(row.replace("@", "#") for row in rows)
    config = GridConfig(
        map=text,
        agents_xy=[list(s) for s in starts],
        targets_xy=[list(g) for g in goals],
        num_agents=len(starts),
        collision_system="soft",
        on_target="nothing",
        max_episode_steps=t_max,
        obs_radius=1,
        seed=seed,
    )
    env = pogema_v0(grid_config=config)
    env.reset()
    metric = find_metric(env)
    # The metric rebinds `_solve_time` when the episode ends: the old list
    # keeps the final per-agent values.
    solve_time = metric._solve_time
    rng = np.random.default_rng(seed)
    n = len(starts)
    if policy == "greedy":
        fields = [distances(rows, tuple(g)) for g in goals]
    elif policy == "crowd":
        free = [(r, c) for r in range(h) for c in range(w) if rows[r][c] == "."]
        hub = free[len(free) // 2]
        fields = [distances(rows, hub)] * n
    got = [tuple(p) for p in env.grid.get_agents_xy(ignore_borders=True)]
    assert got == [tuple(s) for s in starts], "pogema moved the starts"
    actions, positions = [], []
    stalled = [False] * n
    while True:
        pos = [tuple(p) for p in env.grid.get_agents_xy(ignore_borders=True)]
        if policy == "random":
            joint = [int(a) for a in rng.integers(0, 5, size=n)]
        else:
            # Greedy agents blocked last step often step aside, which breaks
            # most head-on jams, so many greedy episodes succeed; the crowd
            # keeps pushing into the hub.
            joint = []
            for i in range(n):
                noise = 0.15 if policy == "crowd" else (0.4 if stalled[i] else 0.03)
                joint.append(int(rng.integers(0, 5)) if rng.random() < noise
                             else downhill(fields[i], pos[i], rng))
        # pogema rewrites repaired actions in place: give it a copy.
        _, _, terminated, truncated, infos = env.step(list(joint))
        actions.append("".join(map(str, joint)))
        after = env.grid.get_agents_xy(ignore_borders=True)
        stalled = [joint[i] != 0 and tuple(after[i]) == pos[i] for i in range(n)]
        positions.append([int(r) * w + int(c) for r, c in after])
        if all(terminated) or all(truncated):
            break
    metrics = infos[0]["metrics"]
    costs = [int(t) + 1 for t in solve_time]
    assert sum(costs) == metrics["SoC"] and max(costs) == metrics["makespan"]
    return {
        "name": f"{name} {policy}",
        "map": rows,
        "t_max": t_max,
        "starts": [[int(r), int(c)] for r, c in starts],
        "goals": [[int(r), int(c)] for r, c in goals],
        "actions": actions,
        "positions": positions,
        "terminated": bool(all(terminated)),
        "truncated": bool(all(truncated)),
        "success": bool(metrics["CSR"] == 1.0),
        "costs": costs,
        "soc": int(metrics["SoC"]),
        "makespan": int(metrics["makespan"]),
        "isr": float(metrics["ISR"]),
        "ep_length": int(metrics["ep_length"]),
    }


def small_instance(size, density, agents, seed):
    """A map, starts and goals from pogema's own generator."""
    config = GridConfig(size=size, density=density, num_agents=agents, seed=seed, obs_radius=1,
                        collision_system="soft", on_target="nothing")
    env = pogema_v0(grid_config=config)
    env.reset()
    obstacles = env.grid.get_obstacles(ignore_borders=True)
    rows = ["".join("@" if x else "." for x in row) for row in obstacles]
    starts = [tuple(map(int, p)) for p in env.grid.get_agents_xy(ignore_borders=True)]
    goals = [tuple(map(int, p)) for p in env.grid.get_targets_xy(ignore_borders=True)]
    return rows, starts, goals


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--shared", default="../shared/pogema",
                        help="folder with warehouse.map and warehouse-<N>-<seed>.scen")
    parser.add_argument("--out", default="env/tests/data/pogema/traces.json.gz")
    args = parser.parse_args()
    if pogema.__version__ != "1.4.0":
        sys.exit(f"pogema {pogema.__version__} installed, 1.4.0 required")
    shared = Path(args.shared)
    episodes = []
    warehouse = read_map(shared / "warehouse.map")
    for scen_agents, agents, seeds in WAREHOUSE:
        for scen_seed in seeds:
            scen = f"warehouse-{scen_agents}-{scen_seed}"
            starts, goals = read_scen(shared / f"{scen}.scen", agents)
            name = scen if agents == scen_agents else f"{scen} (first {agents})"
            for k, policy in enumerate(POLICIES):
                episodes.append(record(name, warehouse, starts, goals, 128, policy,
                                       1000 * agents + 10 * scen_seed + k))
    for size, density, agents, t_max, seed in SMALL:
        rows, starts, goals = small_instance(size, density, agents, seed)
        for k, policy in enumerate(POLICIES):
            episodes.append(record(f"generated-{size}-{density}-{agents}-{seed}", rows, starts, goals,
                                   t_max, policy, 100 * seed + k))
    data = {
        "pogema": pogema.__version__,
        "collision_system": "soft",
        "on_target": "nothing",
        "actions": "pogema's indices: 0 stay, 1 up, 2 down, 3 left, 4 right",
        "positions": "after each step, one cell index row * width + col per agent",
        "episodes": episodes,
    }
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    payload = json.dumps(data, separators=(",", ":")).encode()
    with open(out, "wb") as raw, gzip.GzipFile(fileobj=raw, mode="wb", compresslevel=9, mtime=0,
                                               filename="") as gz:
        gz.write(payload)
    steps = sum(len(e["actions"]) for e in episodes)
    crowd = sum(len(e["actions"]) for e in episodes if len(e["starts"]) == 192)
    print(f"{len(episodes)} episodes, {steps} steps ({crowd} with 192 agents), "
          f"{sum(e['success'] for e in episodes)} successful, "
          f"{len(payload)} bytes of JSON, {out.stat().st_size} gzipped -> {out}")


if __name__ == "__main__":
    main()
