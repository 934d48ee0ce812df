#!/usr/bin/env python3
"""Regenerates the goal sequences of POGEMA's lifelong warehouse benchmark from the `pogema` 1.4.0 package.

POGEMA's lifelong (LMAPF) ``03-warehouse`` experiment
(Cognitive-AI-Systems/pogema-benchmark, ``raw_data_LMAPF/03-warehouse``) runs
pogema on the ``wfi_warehouse`` map with ``on_target="restart"``, N in
32..192 step 32, seeds 0..127 and 256 steps, and reports ``avg_throughput``:
goals reached per step. This script writes, per seed, the starts and the
goal sequences that pogema gives the agents in that experiment, so that any
controller can be run on exactly those tasks (``learner bench pogema
--lifelong --goals DIR``).

Where pogema 1.4.0 takes them from (``pogema/envs.py``, ``PogemaLifeLong``):

* starts and first goals: the same draw as the one-shot instances
  (``export_instances.py``): the map string's ``@`` cells are the possible
  starts and its ``$`` cells the possible goals, shuffled by
  ``numpy.random.default_rng(seed)``;
* every later goal: ``_initialize_grid`` seeds one generator per agent,
  ``default_rng(s_i)`` with ``s_i`` the i-th of
  ``default_rng(seed).integers(2**31 - 1, size=N)``; when agent i stands on
  its goal after a step, ``_generate_new_target`` draws its next goal with
  ``generate_from_possible_targets(rng_i, possible_targets_xy, position)``:
  a uniform choice among the ``$`` cells, drawn again while it equals
  ``position``. (Maps without ``$`` cells use ``generate_new_target``, a
  draw from the agent's connected component; the warehouse has them.)
  ``position`` is the agent's cell in pogema's *padded* coordinates (offset
  by ``obs_radius`` = 5) while the candidates are unpadded, so the
  rejection compares the candidate with (goal row + 5, goal col + 5): the
  agent stands on its old goal when it draws. A new goal may therefore be
  the old goal itself; the agent then reaches it again in the next step it
  stays there, as pogema counts it.

The draw depends on the agent's own generator and the cell of its old
goal only, never on when it arrives or what the other agents do, so the
whole sequence follows from the seed without stepping the env. The script
generates it so (calling pogema's own ``generate_from_possible_targets``)
and checks it against stepped pogema envs (``--check``): agents driven
along shortest paths, every goal pogema hands out compared with the file.
It also checks that the N-agent starts and sequences are the first N of the
192-agent ones (pogema's per-agent seeds come from one ``integers`` call, a
prefix-stable stream), so one file per seed serves every agent count.

How many goals: an agent cannot reach its goals faster than along shortest
paths on the empty map, and every arrival takes at least one step (a goal
drawn on the agent's own cell counts at the next step). So per agent the
file lists goals g1..gk where k is the first index with
sum_{j<=k} max(d_j, 1) > T (d_j the shortest-path distance from the start,
then from g_{j-1}, to g_j): within T steps the agent reaches at most k - 1
of them and heads for at most g_k. No controller can run out; the env
refuses to continue (a typed error) if one ever did.

Output: ``warehouse.map`` (the map, as ``export_instances.py`` writes it)
and (``lifelong-goals v1``, read by ``buridan_eval::goal_sequences`` and
``python/examples/fleet_client.py``): ``warehouse-lifelong-<seed>.goals``,
a header ``lifelong-goals v1 map warehouse agents 192 steps 256``, ``#``
comment lines, then one line per agent in pogema's order: ``row,col`` of
its start, then ``row,col`` of each goal in order, separated by spaces.

Usage (inside a virtual environment with ``requirements.txt``)::

    python3 scripts/pogema/export_lifelong.py --out /work/lifelong-goals
    python3 scripts/pogema/export_lifelong.py --check   # stepped pogema envs

Deterministic: everything depends only on the seed.
"""

import argparse
import collections
import sys
import time
from pathlib import Path

import numpy as np
import pogema
from pogema import GridConfig, pogema_v0
from pogema.generator import generate_from_possible_targets

sys.path.insert(0, str(Path(__file__).resolve().parent))
from export_instances import WFI_WAREHOUSE, distances, map_text  # noqa: E402

AGENTS = [32, 64, 96, 128, 160, 192]
SEEDS = range(128)
STEPS = 256
MAP = "warehouse"
# The actions pogema's GridConfig.MOVES lists: stay, up, down, left, right.
MOVES = [(0, 0), (-1, 0), (1, 0), (0, -1), (0, 1)]


def make_env(num_agents, seed):
    """A lifelong pogema env of the benchmark's configuration, reset as pogema-toolbox resets it."""
    config = GridConfig(
        map=WFI_WAREHOUSE,
        map_name="wfi_warehouse",
        num_agents=num_agents,
        seed=seed,
        max_episode_steps=STEPS,
        collision_system="soft",
        on_target="restart",
        observation_type="MAPF",
    )
    env = pogema_v0(grid_config=config)
    env.reset(seed=seed)
    return env


class Fields:
    """BFS distance fields on the static map, one per target cell, cached."""

    def __init__(self, obstacles):
        self.obstacles = obstacles
        self.cache = {}

    def get(self, cell):
        if cell not in self.cache:
            self.cache[cell] = distances(self.obstacles, cell)
        return self.cache[cell]

    def dist(self, a, b):
        d = self.get(b)[a[0]][a[1]]
        if d is None:
            raise RuntimeError(f"{b} unreachable from {a}")
        return d


def sequences(env, fields, steps=STEPS):
    """(starts, per-agent goal lists) of a freshly reset env, drawn as pogema draws them, as
    many goals as an agent alone on shortest paths could ask for in `steps` steps."""
    inner = env.unwrapped
    grid, config = inner.grid, inner.grid_config
    radius = config.obs_radius
    targets = config.possible_targets_xy
    if targets is None:
        raise RuntimeError("the map has no '$' goal cells: pogema would draw from components")
    starts = [tuple(map(int, c)) for c in grid.get_agents_xy(ignore_borders=True)]
    first = [tuple(map(int, c)) for c in grid.get_targets_xy(ignore_borders=True)]
    seeds = np.random.default_rng(config.seed).integers(np.iinfo(np.int32).max, size=config.num_agents)
    result = []
    for i, (start, goal) in enumerate(zip(starts, first)):
        rng = np.random.default_rng(seeds[i])
        goals, here, budget = [goal], start, 0
        while True:
            budget += max(fields.dist(here, goal), 1)
            if budget > steps:
                break
            here = goal
            # The agent stands on `goal` (padded coordinates) when pogema draws.
            drawn = generate_from_possible_targets(rng, targets, (goal[0] + radius, goal[1] + radius))
            goal = (int(drawn[0]), int(drawn[1]))
            goals.append(goal)
        result.append(goals)
    return starts, result


def goal_file(seed, starts, goals, steps=STEPS):
    lines = [
        f"lifelong-goals v1 map {MAP} agents {len(starts)} steps {steps}",
        f"# pogema {pogema.__version__}, wfi_warehouse, on_target restart, seed {seed}; "
        "per agent: start, then its goals in order (row,col); "
        "regenerate: scripts/pogema/export_lifelong.py",
    ]
    for start, seq in zip(starts, goals):
        lines.append(" ".join(f"{r},{c}" for r, c in [start] + seq))
    return "\n".join(lines) + "\n"


def regenerate(fields, seeds, steps=STEPS):
    """Yields (seed, text) per seed, goals for `steps` steps; checks the N-agent draws are
    prefixes of the 192-agent ones."""
    for seed in seeds:
        starts, goals = sequences(make_env(max(AGENTS), seed), fields, steps)
        for n in AGENTS[:-1]:
            s, g = sequences(make_env(n, seed), fields, steps)
            if s != starts[:n] or g != goals[:n]:
                raise RuntimeError(f"seed {seed}: the {n}-agent starts or goals are not the first "
                                   f"{n} of the {max(AGENTS)}-agent ones")
        yield seed, goal_file(seed, starts, goals, steps)


def step_towards(position, target, fields, obstacles):
    """pogema's action index of a shortest-path step from `position` to `target` (0 when there)."""
    field = fields.get(target)
    best, best_d = 0, field[position[0]][position[1]]
    for a, (dr, dc) in enumerate(MOVES[1:], start=1):
        r, c = position[0] + dr, position[1] + dc
        if 0 <= r < len(obstacles) and 0 <= c < len(obstacles[0]) and field[r][c] is not None \
                and field[r][c] < best_d:
            best, best_d = a, field[r][c]
    return best


def check(fields, obstacles, seeds, counts):
    """Steps pogema's own lifelong env (agents along shortest paths, one move in four random so
    that agents facing each other get apart) and compares every goal it hands out with the
    generated sequences."""
    compared, noise = 0, np.random.default_rng(0)
    for seed in seeds:
        for n in counts:
            env = make_env(n, seed)
            starts, goals = sequences(make_env(n, seed), fields)
            grid = env.unwrapped.grid
            got_starts = [tuple(map(int, c)) for c in grid.get_agents_xy(ignore_borders=True)]
            if got_starts != starts:
                raise RuntimeError(f"seed {seed}, {n} agents: starts differ from pogema's")
            seen = [[tuple(map(int, c))] for c in grid.get_targets_xy(ignore_borders=True)]
            for _ in range(STEPS):
                pos = [tuple(map(int, c)) for c in grid.get_agents_xy(ignore_borders=True)]
                tgt = [tuple(map(int, c)) for c in grid.get_targets_xy(ignore_borders=True)]
                actions = [step_towards(p, t, fields, obstacles) if noise.random() > 0.25
                           else int(noise.integers(len(MOVES))) for p, t in zip(pos, tgt)]
                env.step(actions)
                grid = env.unwrapped.grid
                now = [tuple(map(int, c)) for c in grid.get_targets_xy(ignore_borders=True)]
                for i, (before, after) in enumerate(zip(tgt, now)):
                    on = tuple(map(int, grid.get_agents_xy(ignore_borders=True)[i])) == before
                    if on:  # pogema drew a new goal (possibly the same cell)
                        seen[i].append(after)
            for i, got in enumerate(seen):
                if got != goals[i][:len(got)]:
                    raise RuntimeError(f"seed {seed}, {n} agents, agent {i}: pogema gave {got}, "
                                       f"the file says {goals[i][:len(got)]}")
                compared += len(got)
            used = max(len(s) for s in seen)
            print(f"seed {seed}, {n} agents: {compared} goals equal so far; "
                  f"most goals one agent was given: {used}")
    print(f"all equal: {compared} goals pogema {pogema.__version__} handed out in stepped envs "
          f"are the generated sequences")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument("--out", type=Path, help="write warehouse-lifelong-<seed>.goals here")
    mode.add_argument("--check", action="store_true",
                      help="step pogema envs and compare the goals they hand out with the sequences")
    parser.add_argument("--seeds", type=int, default=len(SEEDS),
                        help="first SEEDS seeds only (default all 128; --check default 3)")
    parser.add_argument("--steps", type=int, default=STEPS,
                        help=f"goals enough for this many steps (default {STEPS}, the benchmark's; "
                             "longer runs, e.g. the fleet client's 10,000, need more)")
    args = parser.parse_args()
    if pogema.__version__ != "1.4.0":
        sys.exit(f"pogema {pogema.__version__} installed, 1.4.0 required")
    start = time.perf_counter()
    env = make_env(max(AGENTS), 0)
    obstacles = [[int(x) for x in row] for row in env.unwrapped.grid.get_obstacles(ignore_borders=True)]
    fields = Fields(obstacles)
    if args.check:
        seeds = range(min(args.seeds, 3) if args.seeds == len(SEEDS) else args.seeds)
        check(fields, obstacles, seeds, [32, 192])
    else:
        args.out.mkdir(parents=True, exist_ok=True)
        # The map beside the goal files (the one-shot instances' warehouse.map).
        (args.out / f"{MAP}.map").write_text(map_text(obstacles))
        lengths = []
        for seed, text in regenerate(fields, range(args.seeds), args.steps):
            (args.out / f"warehouse-lifelong-{seed}.goals").write_text(text)
            lengths += [len(line.split()) - 1 for line in text.splitlines()[2:]]
        print(f"wrote {args.seeds} goal files to {args.out}; goals per agent "
              f"{min(lengths)}..{max(lengths)} (mean {sum(lengths) / len(lengths):.1f})")
    print(f"{time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    main()
