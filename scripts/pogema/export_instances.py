#!/usr/bin/env python3
"""Regenerates the POGEMA warehouse benchmark's 768 instances from the `pogema` 1.4.0 package.

The instances in ``../shared/pogema/`` (``warehouse.map`` and
``warehouse-<N>-<seed>.scen``, N in 32..192 step 32, seeds 0..127) are the ones
behind the published results of the benchmark's ``03-warehouse`` experiment
(Cognitive-AI-Systems/pogema-benchmark, commit c5dd4fd,
``algorithms/experiments/03-warehouse``). That experiment runs pogema with

    GridConfig(map=<wfi_warehouse string below>, map_name="wfi_warehouse",
               num_agents=N, seed=seed, max_episode_steps=128,
               collision_system="soft", on_target="nothing",
               observation_type="MAPF", obs_radius=5 (the default))

through pogema-toolbox's ``MultiMapWrapper``, which puts the map string from the
experiment's ``maps.yaml`` into the config and resets with ``seed``. In that
string ``#`` is a shelf, ``!`` a free corridor cell, ``@`` a free cell where an
agent may start (the end blocks) and ``$`` a free cell that may be a goal (the
rows beside the shelves). For such maps pogema 1.4.0 draws an instance in
``pogema.generator.generate_from_possible_positions``: one
``numpy.random.default_rng(seed)`` shuffles the row-major list of ``@`` cells,
then the list of ``$`` cells, and agent i gets the i-th of each. So the
N-agent instance of a seed is the first N agents of its 192-agent one (the
script checks that too, by generating every count separately).

The trap: the 192-agent ``scenarios:`` pinned in the benchmark's later config
come from the string in ``raw_data_MAPF/03-warehouse/maps.yaml``, whose
corridors are ``.`` (start and goal candidates alike) and whose ``@``/``$``
roles are swapped; they are not the published instances and this script does
not use them.

Output format (as shipped): ``warehouse.map`` is a MovingAI map (``@`` shelf,
``.`` free); each ``.scen`` is MovingAI scen v1, one line per agent in pogema's
order: ``bucket map width height start_x start_y goal_x goal_y optimal`` with
tabs, x = column, y = row, ``optimal`` the 4-connected shortest-path length on
the static map and ``bucket`` = optimal // 4.

Usage (inside a virtual environment with ``requirements.txt``)::

    # regenerate in memory and compare with the shipped files, cell by cell
    python3 scripts/pogema/export_instances.py --shared ../shared/pogema
    # write the map and all 768 .scen files
    python3 scripts/pogema/export_instances.py --out /tmp/warehouse-instances

Deterministic: pogema's draw depends only on the seed.
"""

import argparse
import collections
import sys
import time
from pathlib import Path

import pogema
from pogema import GridConfig, pogema_v0

AGENTS = [32, 64, 96, 128, 160, 192]
SEEDS = range(128)
MAP_NAME = "warehouse.map"

# `wfi_warehouse` from the experiment's maps.yaml: a 3-row rack block (goal
# row, shelf row, goal row, with start end-blocks left and right) between
# corridor rows, eight times.
_CORRIDOR = "!" * 46
_RACK = [
    "!@@!@@!$$$$$$$$$$!$$$$$$$$$$!$$$$$$$$$$!@@!@@!",
    "!@@!@@!##########!##########!##########!@@!@@!",
    "!@@!@@!$$$$$$$$$$!$$$$$$$$$$!$$$$$$$$$$!@@!@@!",
]
WFI_WAREHOUSE = "\n".join([_CORRIDOR] + [row for _ in range(8) for row in _RACK + [_CORRIDOR]])


def generate(num_agents, seed):
    """Obstacles (rows of 0/1) and the (row, col) starts and goals pogema draws."""
    config = GridConfig(
        map=WFI_WAREHOUSE,
        map_name="wfi_warehouse",
        num_agents=num_agents,
        seed=seed,
        max_episode_steps=128,
        collision_system="soft",
        on_target="nothing",
        observation_type="MAPF",
    )
    env = pogema_v0(grid_config=config)
    # As pogema-toolbox's MultiMapWrapper does: reset with the config's seed.
    env.reset(seed=seed)
    grid = env.grid
    obstacles = [[int(x) for x in row] for row in grid.get_obstacles(ignore_borders=True)]
    starts = [(int(r), int(c)) for r, c in grid.get_agents_xy(ignore_borders=True)]
    goals = [(int(r), int(c)) for r, c in grid.get_targets_xy(ignore_borders=True)]
    return obstacles, starts, goals


def distances(obstacles, source):
    """BFS step distances from `source` over free cells, 4-connected (None = unreachable)."""
    h, w = len(obstacles), len(obstacles[0])
    dist = [[None] * w for _ in range(h)]
    dist[source[0]][source[1]] = 0
    queue = collections.deque([source])
    while queue:
        r, c = queue.popleft()
        for dr, dc in ((-1, 0), (1, 0), (0, -1), (0, 1)):
            nr, nc = r + dr, c + dc
            if 0 <= nr < h and 0 <= nc < w and not obstacles[nr][nc] and dist[nr][nc] is None:
                dist[nr][nc] = dist[r][c] + 1
                queue.append((nr, nc))
    return dist


def map_text(obstacles):
    rows = ["".join("@" if x else "." for x in row) for row in obstacles]
    return f"type octile\nheight {len(rows)}\nwidth {len(rows[0])}\nmap\n" + "\n".join(rows) + "\n"


def scen_text(obstacles, starts, goals, fields):
    """`fields` caches one BFS per start cell: every seed draws from the same 192 cells."""
    h, w = len(obstacles), len(obstacles[0])
    lines = ["version 1"]
    for (sr, sc), (gr, gc) in zip(starts, goals):
        if (sr, sc) not in fields:
            fields[(sr, sc)] = distances(obstacles, (sr, sc))
        d = fields[(sr, sc)][gr][gc]
        if d is None:
            raise RuntimeError(f"goal ({gr}, {gc}) unreachable from start ({sr}, {sc})")
        lines.append("\t".join(map(str, [d // 4, MAP_NAME, w, h, sc, sr, gc, gr, d])))
    return "\n".join(lines) + "\n"


def regenerate():
    """Yields (file name, text) for the map and every instance, checking the prefix property."""
    obstacles, fields = None, {}
    for seed in SEEDS:
        full_obstacles, full_starts, full_goals = generate(max(AGENTS), seed)
        if obstacles is None:
            obstacles = full_obstacles
            yield MAP_NAME, map_text(obstacles)
        elif full_obstacles != obstacles:
            raise RuntimeError(f"seed {seed}: pogema changed the map")
        for n in AGENTS:
            _, starts, goals = generate(n, seed)
            if starts != full_starts[:n] or goals != full_goals[:n]:
                raise RuntimeError(f"seed {seed}: the {n}-agent instance is not the first {n} "
                                   f"agents of the {max(AGENTS)}-agent one")
            yield f"warehouse-{n}-{seed}.scen", scen_text(obstacles, starts, goals, fields)


def diff(name, expected, shipped):
    """Human-readable differences between a regenerated and a shipped file."""
    exp, got = expected.splitlines(), shipped.splitlines()
    out = []
    for i in range(max(len(exp), len(got))):
        e = exp[i] if i < len(exp) else "<missing>"
        g = got[i] if i < len(got) else "<missing>"
        if e != g:
            agent = f" (agent {i - 1})" if name.endswith(".scen") and i >= 1 else ""
            out.append(f"{name} line {i + 1}{agent}: pogema {e!r}, shipped {g!r}")
    if not out and expected != shipped:
        out.append(f"{name}: same lines, different line endings or trailing newline")
    return out


def compare(shared):
    differences, files, agent_lines, bad_files = [], 0, 0, []
    for name, text in regenerate():
        path = shared / name
        if not path.is_file():
            differences.append(f"{name}: missing in {shared}")
            bad_files.append(name)
            continue
        found = diff(name, text, path.read_text())
        files += 1
        if name.endswith(".scen"):
            agent_lines += text.count("\n") - 1
        if found:
            bad_files.append(name)
            differences.extend(found)
    expected = 1 + len(AGENTS) * len(SEEDS)
    if differences:
        print(f"MISMATCH: {len(bad_files)} of {expected} files differ "
              f"({len(differences)} differing lines); first differences:")
        for line in differences[:20]:
            print("  " + line)
        sys.exit(1)
    print(f"all equal: {MAP_NAME} and {files - 1} instances ({len(AGENTS)} agent counts x "
          f"{len(SEEDS)} seeds, {agent_lines} agent lines) in {shared} are what pogema "
          f"{pogema.__version__} generates")


def write(out):
    out.mkdir(parents=True, exist_ok=True)
    count = 0
    for name, text in regenerate():
        (out / name).write_text(text)
        count += 1
    print(f"wrote {count} files ({MAP_NAME} and {count - 1} instances) to {out}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument("--shared", type=Path,
                      help="compare with the shipped warehouse.map and .scen files in this folder")
    mode.add_argument("--out", type=Path, help="write warehouse.map and the .scen files here")
    args = parser.parse_args()
    if pogema.__version__ != "1.4.0":
        sys.exit(f"pogema {pogema.__version__} installed, 1.4.0 required")
    start = time.perf_counter()
    if args.shared is not None:
        if not args.shared.is_dir():
            sys.exit(f"{args.shared}: not a directory")
        compare(args.shared)
    else:
        write(args.out)
    print(f"{time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    main()
