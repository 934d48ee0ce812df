#!/usr/bin/env python3
"""Env speed under POGEMA rules against the `pogema` 1.4.0 package, in one run.

Both sides step the benchmark's warehouse (``warehouse.map``) from the starts
and goals of ``warehouse-64-0`` and ``warehouse-192-0``, one core each, and
report agent-steps per second (joint steps/s x agents):

- **ours**: the criterion benchmark ``grid_env_step_warehouse/pogema/{64,192}_agents``
  in ``env/benches/step.rs``, run first by this script through criterion's
  filter. One iteration is ``GridEnv::step`` under ``Rules::Pogema``
  (simultaneous moves and their repair, rewards, goal/cost bookkeeping, the
  deadlock monitor) and, when the episode ends (T_max 128), ``reset_to(0)``.
  No observations are built. The rate is the agent count over criterion's
  median time per iteration.
- **pogema, rules only**: ``pogema_v0`` with ``collision_system="soft"``,
  ``on_target="nothing"``, ``max_episode_steps=128``, ``observation_type="MAPF"``
  (the benchmark's), and ``env.reset()`` when every agent is terminated or
  truncated. Its whole ``env.step`` (the soft-collision repair, goal checks,
  time limit and the four metric wrappers: ISR, CSR, episode length, SoC and
  makespan) with observation generation replaced by a no-op, so that it does
  what our bench does. This is the like-for-like row and the ratio's base.
- **pogema, full step**: the same, with pogema's observations (per agent an
  11x11 obstacle and agent window, positions, and under ``MAPF`` the global
  state), as a user of the package gets it. Shown for reference only: our
  bench builds no observations.

The actions are the very sequence our bench uses: 512 batches of uniform
actions in 0..5 from ``ChaCha8Rng::seed_from_u64(200 + agents)`` (ported
below from rand 0.9 / rand_chacha 0.9 and checked bit for bit against them),
cycled, mapped from our indices (stay, up, right, down, left) to pogema's
(stay, up, down, left, right). Each pogema step gets a fresh copy of its
batch because pogema rewrites repaired actions in place.

Usage (inside a virtual environment with ``requirements.txt``, from the
repository root; cargo must be on PATH)::

    nice -n 10 python3 scripts/pogema/speed.py --shared ../shared/pogema \\
        --out docs/results/pogema/speed

Writes ``speed.csv`` and ``speed.md`` to ``--out``. Timings depend on the
machine and its load; the load average before and after each part is
recorded beside them.
"""

import argparse
import csv
import json
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

import pogema
from pogema import GridConfig, pogema_v0

AGENTS = [64, 192]
BATCHES = 512
# Ours -> pogema action index (ours: stay, up, right, down, left).
OURS_TO_POGEMA = [0, 1, 4, 2, 3]
BENCH_FILTER = "grid_env_step_warehouse/pogema/"

M32 = 0xFFFFFFFF
M64 = 0xFFFFFFFFFFFFFFFF
QUARTERS = [(0, 4, 8, 12), (1, 5, 9, 13), (2, 6, 10, 14), (3, 7, 11, 15),
            (0, 5, 10, 15), (1, 6, 11, 12), (2, 7, 8, 13), (3, 4, 9, 14)]


class ChaCha8:
    """rand_chacha 0.9's ChaCha8Rng as rand 0.9 uses it: seeded by rand_core's
    PCG32 expansion of a u64, 64-bit block counter, stream 0, words in order."""

    def __init__(self, seed):
        state, key = seed, []
        for _ in range(8):
            state = (state * 6364136223846793005 + 11634580027462260723) & M64
            xorshifted = (((state >> 18) ^ state) >> 27) & M32
            rot = state >> 59
            key.append(((xorshifted >> rot) | (xorshifted << ((32 - rot) & 31))) & M32)
        self.key, self.counter, self.buf, self.idx = key, 0, [], 0

    def _block(self):
        c = self.counter
        s = [0x61707865, 0x3320646E, 0x79622D32, 0x6B206574] + self.key + [c & M32, c >> 32, 0, 0]
        x = list(s)

        def quarter(a, b, c, d):
            x[a] = (x[a] + x[b]) & M32
            x[d] ^= x[a]
            x[d] = ((x[d] << 16) | (x[d] >> 16)) & M32
            x[c] = (x[c] + x[d]) & M32
            x[b] ^= x[c]
            x[b] = ((x[b] << 12) | (x[b] >> 20)) & M32
            x[a] = (x[a] + x[b]) & M32
            x[d] ^= x[a]
            x[d] = ((x[d] << 8) | (x[d] >> 24)) & M32
            x[c] = (x[c] + x[d]) & M32
            x[b] ^= x[c]
            x[b] = ((x[b] << 7) | (x[b] >> 25)) & M32

        for _ in range(4):  # 8 rounds = 4 double rounds: columns, then diagonals
            for a, b, c, d in QUARTERS:
                quarter(a, b, c, d)
        self.counter += 1
        return [(a + b) & M32 for a, b in zip(x, s)]

    def next_u32(self):
        if self.idx == len(self.buf):
            self.buf, self.idx = self._block(), 0
        self.idx += 1
        return self.buf[self.idx - 1]

    def below(self, n):
        """`rng.random_range(0..n)` for u8 in rand 0.9: Canon's method on u32, one
        extra draw when the low word is in the biased zone."""
        m = self.next_u32() * n
        result, lo = m >> 32, m & M32
        if lo > (-n & M32) and lo + ((self.next_u32() * n) >> 32) > M32:
            result += 1
        return result


def action_batches(agents, seed):
    """Our bench's `action_batches(agents, seed)`, in pogema's action indices."""
    rng = ChaCha8(seed)
    return [[OURS_TO_POGEMA[rng.below(5)] for _ in range(agents)] for _ in range(BATCHES)]


# First actions of ChaCha8Rng::seed_from_u64(264) under random_range(0..5u8),
# printed by rand 0.9.5 / rand_chacha 0.9.0: guards the port.
RUST_264_PREFIX = "2413223434423312242313040314041420111212"


def read_map(path):
    lines = Path(path).read_text().splitlines()
    height = int(lines[1].split()[1])
    start = lines.index("map") + 1
    return ["".join("#" if ch == "@" else "." for ch in row) for row in lines[start:start + height]]


def read_scen(path):
    """(row, col) starts and goals, agent i = line i (MovingAI x = column, y = row)."""
    starts, goals = [], []
    for line in Path(path).read_text().splitlines()[1:]:
        f = line.split("\t")
        starts.append([int(f[5]), int(f[4])])
        goals.append([int(f[7]), int(f[6])])
    return starts, goals


def pogema_rate(rows, starts, goals, with_obs, steps, samples):
    """Median agent-steps/s over `samples` timed runs of `steps` joint steps each."""
    n = len(starts)
    env = pogema_v0(grid_config=GridConfig(
        map="\n".join(rows), agents_xy=starts, targets_xy=goals, num_agents=n,
        collision_system="soft", on_target="nothing", max_episode_steps=128,
        observation_type="MAPF", seed=0))
    if not with_obs:
        # Pogema computes observations inside `step` and `reset`; an instance
        # attribute shadows the method, so the rest of the step is untouched.
        env.unwrapped._obs = lambda: None
    env.reset()
    if [list(p) for p in env.unwrapped.grid.get_agents_xy(ignore_borders=True)] != starts:
        raise RuntimeError("pogema did not place the instance's starts")
    batches = action_batches(n, 200 + n)
    k = 0

    def run(count):
        nonlocal k
        for _ in range(count):
            _, _, terminated, truncated, _ = env.step(list(batches[k % BATCHES]))
            k += 1
            if all(terminated) or all(truncated):
                env.reset()

    run(256)  # warm-up: two episodes
    rates = []
    for _ in range(samples):
        start = time.perf_counter()
        run(steps)
        rates.append(steps * n / (time.perf_counter() - start))
    return statistics.median(rates), min(rates), max(rates)


def run_criterion(repo, warm_up, measurement):
    cmd = ["cargo", "bench", "-p", "buridan-env", "--bench", "step", "--",
           "--warm-up-time", str(warm_up), "--measurement-time", str(measurement), BENCH_FILTER]
    print("$ " + " ".join(cmd), flush=True)
    result = subprocess.run(cmd, cwd=repo)
    if result.returncode != 0:
        sys.exit(f"cargo bench failed with exit code {result.returncode}")
    meta = subprocess.run(["cargo", "metadata", "--format-version", "1", "--no-deps"], cwd=repo,
                          capture_output=True, text=True, check=True)
    criterion = Path(json.loads(meta.stdout)["target_directory"]) / "criterion"
    rates = {}
    for n in AGENTS:
        path = criterion / "grid_env_step_warehouse" / "pogema" / f"{n}_agents" / "new" / "estimates.json"
        if not path.is_file():
            sys.exit(f"criterion wrote no estimate at {path}")
        median = json.loads(path.read_text())["median"]
        ns, lo, hi = (median["point_estimate"], median["confidence_interval"]["lower_bound"],
                      median["confidence_interval"]["upper_bound"])
        # Per iteration, n agent-steps: rate = n / time; the interval flips.
        rates[n] = (n / ns * 1e9, n / hi * 1e9, n / lo * 1e9)
    return " ".join(cmd), rates


def load():
    return "{:.2f} {:.2f} {:.2f}".format(*os.getloadavg())


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--shared", default="../shared/pogema",
                        help="folder with warehouse.map and warehouse-<N>-0.scen")
    parser.add_argument("--out", default="docs/results/pogema/speed")
    parser.add_argument("--warm-up-time", type=float, default=3, help="criterion warm-up, seconds")
    parser.add_argument("--measurement-time", type=float, default=10,
                        help="criterion measurement, seconds")
    parser.add_argument("--steps", type=int, default=1280,
                        help="pogema joint steps per timed sample (10 episodes)")
    parser.add_argument("--samples", type=int, default=5, help="pogema timed samples per case")
    args = parser.parse_args()
    if pogema.__version__ != "1.4.0":
        sys.exit(f"pogema {pogema.__version__} installed, 1.4.0 required")
    rng = ChaCha8(264)
    prefix = "".join(str(rng.below(5)) for _ in range(len(RUST_264_PREFIX)))
    if prefix != RUST_264_PREFIX:
        sys.exit(f"ChaCha8 port broken: {prefix} != {RUST_264_PREFIX}")
    repo = Path(__file__).resolve().parents[2]
    shared = Path(args.shared)
    rows = read_map(shared / "warehouse.map")

    load_before = load()
    cmd, ours = run_criterion(repo, args.warm_up_time, args.measurement_time)
    load_mid = load()
    table = []
    for n in AGENTS:
        starts, goals = read_scen(shared / f"warehouse-{n}-0.scen")
        if len(starts) != n:
            sys.exit(f"warehouse-{n}-0.scen has {len(starts)} agents, expected {n}")
        rules = pogema_rate(rows, starts, goals, False, args.steps, args.samples)
        full = pogema_rate(rows, starts, goals, True, args.steps, args.samples)
        print(f"{n} agents: ours {ours[n][0]:,.0f}, pogema rules only {rules[0]:,.0f}, "
              f"pogema full step {full[0]:,.0f} agent-steps/s", flush=True)
        table.append((n, ours[n], rules, full))
    load_after = load()

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "speed.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["instance", "agents", "ours_agent_steps_per_s", "ours_ci_low", "ours_ci_high",
                    "pogema_rules_only_agent_steps_per_s", "pogema_rules_only_min",
                    "pogema_rules_only_max", "pogema_full_step_agent_steps_per_s",
                    "pogema_full_step_min", "pogema_full_step_max", "ratio_vs_rules_only",
                    "ratio_vs_full_step"])
        for n, o, r, fl in table:
            w.writerow([f"warehouse-{n}-0", n, *(round(x) for x in o), *(round(x) for x in r),
                        *(round(x) for x in fl), round(o[0] / r[0], 1), round(o[0] / fl[0], 1)])
    lines = [
        "# Env speed under POGEMA rules: ours against the `pogema` package",
        "",
        "Agent-steps per second (joint steps/s × agents), one core, on the warehouse",
        "from the starts and goals of `warehouse-<N>-0`, with the identical uniform",
        "random action stream on both sides, reset when the episode ends (T_max 128).",
        "Ours: `GridEnv::step` under `Rules::Pogema`, no observations (criterion median,",
        "95 % interval). Pogema rules only: its whole `env.step` (repair, goal checks,",
        "time limit, metric wrappers) with observation generation replaced by a no-op;",
        "full step: with its `MAPF` observations, as the package ships (median of",
        f"{args.samples} samples of {args.steps} joint steps, min–max). Ratio = ours / pogema.",
        "",
        "| agents | ours | pogema, rules only | ratio | pogema, full step | ratio |",
        "|---|---|---|---|---|---|",
    ]
    for n, o, r, fl in table:
        lines.append(f"| {n} | {o[0]:,.0f} [{o[1]:,.0f}, {o[2]:,.0f}] | {r[0]:,.0f} "
                     f"[{r[1]:,.0f}, {r[2]:,.0f}] | {o[0] / r[0]:,.0f}× | {fl[0]:,.0f} "
                     f"[{fl[1]:,.0f}, {fl[2]:,.0f}] | {o[0] / fl[0]:,.0f}× |")
    lines += [
        "",
        f"Ours: `{cmd}` (criterion warm-up {args.warm_up_time:g} s, measurement "
        f"{args.measurement_time:g} s). Pogema {pogema.__version__} on Python "
        f"{platform.python_version()}.",
        f"Load average (1, 5, 15 min) before the criterion run: {load_before}; "
        f"before pogema: {load_mid}; after: {load_after}.",
        "Command: `nice -n 10 python3 scripts/pogema/speed.py --shared ../shared/pogema "
        "--out docs/results/pogema/speed`.",
        "",
    ]
    (out / "speed.md").write_text("\n".join(lines))
    print(f"wrote {out / 'speed.csv'} and {out / 'speed.md'}")


if __name__ == "__main__":
    main()
