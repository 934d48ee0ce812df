#!/usr/bin/env python3
"""Agent-steps per second of Buridan's Python envs beside POGEMA 1.4.0, in one run.

Both step the warehouse block layout rm-2.1 (10 x 20) with 4 and 16 agents
and uniformly random actions, on one core, with episodes of 100 steps and
observations built every step (a 5 x 5 window: POGEMA's ``obs_radius=2``,
our sensor range 2):

- ``buridan VecEnv``: ``buridan.VecEnv`` with 64 envs, thesis rules (the
  dissertation's sequential moves), one Rust thread: ``step`` takes a
  ``(64, n)`` uint8 array and refreshes the NumPy views of observations
  ``(64, n, 129)``, masks, rewards and done flags (auto-reset inside).
- ``buridan VecEnv (pogema rules)``: the same under POGEMA's simultaneous
  moves (``rules="pogema"``).
- ``buridan ParallelEnv``: the PettingZoo API, one env, dicts of per-agent
  observations and masks per step (a Python loop over agents).
- ``pogema``: ``pogema_v0`` (``collision_system="soft"``,
  ``on_target="nothing"``, ``obs_radius=2``, ``max_episode_steps=100``)
  on the same grid from the same starts and goals (our episode 0 of seed
  0), reset when every agent is done. Its observations are three
  ``5 x 5`` planes per agent (obstacles, agents, target direction).

Usage, in a virtual environment with ``pogema==1.4.0`` and the package
installed (``pip install ./python``), from the repository root::

    python python/benchmarks/vector_env_speed.py --out docs/results/python

Writes ``vector_env_speed.csv`` and ``vector_env_speed.json``. Numbers
depend on the machine and its load (the load average is recorded).
"""

import argparse
import csv
import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np

import buridan

MAP = "rm-2.1"
T_MAX = 100
NUM_ENVS = 64


def timed(run, steps_per_call, agent_steps_per_step, seconds, samples):
    """Median (min, max) agent-steps/s over `samples` runs of about `seconds` each."""
    run(steps_per_call)  # warm-up
    t0 = time.perf_counter()
    run(steps_per_call)
    per_call = max(time.perf_counter() - t0, 1e-6)
    calls = max(1, int(seconds / per_call))
    rates = []
    for _ in range(samples):
        start = time.perf_counter()
        for _ in range(calls):
            run(steps_per_call)
        rates.append(calls * steps_per_call * agent_steps_per_step / (time.perf_counter() - start))
    return statistics.median(rates), min(rates), max(rates)


def buridan_vec(n, rules, seconds, samples):
    venv = buridan.VecEnv(MAP, n, NUM_ENVS, rules=rules, t_max=T_MAX, seed=0)
    rng = np.random.default_rng(n)
    batches = rng.integers(0, 5, size=(256, NUM_ENVS, n), dtype=np.uint8)
    k = [0]

    def run(steps):
        for _ in range(steps):
            venv.step(batches[k[0] % 256])
            k[0] += 1
        venv.drain_episodes()

    return timed(run, 100, NUM_ENVS * n, seconds, samples)


def buridan_parallel(n, seconds, samples):
    from buridan.pettingzoo import ParallelEnv

    env = ParallelEnv(MAP, n, t_max=T_MAX, seed=0)
    env.reset()
    rng = np.random.default_rng(n)
    batches = rng.integers(0, 5, size=(256, n)).tolist()
    names = env.possible_agents
    k = [0]

    def run(steps):
        for _ in range(steps):
            env.step(dict(zip(names, batches[k[0] % 256])))
            k[0] += 1
            if not env.agents:
                env.reset()

    return timed(run, 100, n, seconds, samples)


def pogema_env(n):
    from pogema import GridConfig, pogema_v0

    m = buridan.Map(MAP)
    rows = ["".join("#" if w else "." for w in row) for row in m.walls]
    env0 = buridan.GridEnv(MAP, n, seed=0)  # episode 0: the same instance
    starts = [list(p) for p in env0.positions()]
    goals = [list(g) for g in env0.goals()]
    env = pogema_v0(grid_config=GridConfig(
        map="\n".join(rows), agents_xy=starts, targets_xy=goals, num_agents=n,
        collision_system="soft", on_target="nothing", max_episode_steps=T_MAX,
        obs_radius=2, seed=0))
    env.reset()
    placed = [list(p) for p in env.unwrapped.grid.get_agents_xy(ignore_borders=True)]
    if placed != starts:
        raise RuntimeError(f"pogema placed {placed}, not {starts}")
    return env


def pogema_rate(n, seconds, samples):
    env = pogema_env(n)
    rng = np.random.default_rng(n)
    batches = rng.integers(0, 5, size=(256, n)).tolist()
    k = [0]

    def run(steps):
        for _ in range(steps):
            _, _, terminated, truncated, _ = env.step(list(batches[k[0] % 256]))
            k[0] += 1
            if all(terminated) or all(truncated):
                env.reset()

    return timed(run, 100, n, seconds, samples)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", type=Path, default=Path("docs/results/python"))
    ap.add_argument("--agents", type=int, nargs="+", default=[4, 16])
    ap.add_argument("--seconds", type=float, default=1.0, help="per timed sample")
    ap.add_argument("--samples", type=int, default=5)
    args = ap.parse_args()

    import pogema

    load_before = os.getloadavg()
    rows = []
    for n in args.agents:
        for name, rate in [
            ("buridan VecEnv", lambda: buridan_vec(n, "thesis", args.seconds, args.samples)),
            ("buridan VecEnv (pogema rules)", lambda: buridan_vec(n, "pogema", args.seconds, args.samples)),
            ("buridan ParallelEnv", lambda: buridan_parallel(n, args.seconds, args.samples)),
            ("pogema", lambda: pogema_rate(n, args.seconds, args.samples)),
        ]:
            med, lo, hi = rate()
            rows.append({"env": name, "map": MAP, "agents": n, "agent_steps_per_s": round(med),
                         "min": round(lo), "max": round(hi)})
            print(f"{name:32} {n:3} agents  {med:14,.0f} agent-steps/s  (min {lo:,.0f}, max {hi:,.0f})",
                  flush=True)
    by = {(r["env"], r["agents"]): r["agent_steps_per_s"] for r in rows}
    for r in rows:
        r["vs_pogema"] = round(r["agent_steps_per_s"] / by[("pogema", r["agents"])], 2)

    args.out.mkdir(parents=True, exist_ok=True)
    with open(args.out / "vector_env_speed.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    meta = {
        "command": "python python/benchmarks/vector_env_speed.py " + " ".join(sys.argv[1:]),
        "buridan": buridan.__version__,
        "pogema": pogema.__version__,
        "numpy": np.__version__,
        "python": platform.python_version(),
        "machine": platform.processor() or platform.machine(),
        "cpu_count": os.cpu_count(),
        "load_average_before": load_before,
        "load_average_after": os.getloadavg(),
        "num_envs": NUM_ENVS,
        "t_max": T_MAX,
        "seconds_per_sample": args.seconds,
        "samples": args.samples,
        "results": rows,
    }
    (args.out / "vector_env_speed.json").write_text(json.dumps(meta, indent=2) + "\n")
    print(f"wrote {args.out}/vector_env_speed.csv and .json")


if __name__ == "__main__":
    main()
