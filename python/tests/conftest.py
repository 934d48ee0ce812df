"""Shared fixtures: paths into the checkout (the tests run from it)."""

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
TRACE = REPO / "env" / "tests" / "data" / "reference_trace.txt"
# A real `learner train` checkpoint (PPO-CTDE on rm-2.1, 4 agents), committed
# with its greedy evaluation (fixtures/ppo-ctde-rm-2.1/; the run is described in
# docs/results/ppo-ctde-rm-2.1/RESULTS.md).
TRAINED = REPO / "fixtures" / "ppo-ctde-rm-2.1"


def parse_trace(path: Path = TRACE):
    """The reference trace as a list of dicts, in the format
    `env/tests/reference_trace.rs` reads (see the file's header)."""
    lines = [
        ln.strip()
        for ln in path.read_text().splitlines()
        if ln.strip() and not ln.strip().startswith("#")
    ]
    traces, i = [], 0
    cell = lambda rc: tuple(int(x) for x in rc.split(","))  # noqa: E731
    while i < len(lines):
        head = lines[i].split()
        assert head[0] == "trace", lines[i]
        t = {"map": head[1]}
        for kv in head[2:]:
            k, v = kv.split("=")
            t[k] = v if k == "starts" else int(v)
        t["start_cells"] = [cell(c) for c in lines[i + 1].removeprefix("starts ").split()]
        t["goal_cells"] = [cell(c) for c in lines[i + 2].removeprefix("goals ").split()]
        i += 3
        t["steps"] = []
        while not lines[i].startswith("end reward "):
            f = [x.strip() for x in lines[i].split("|")]
            assert len(f) == 6, lines[i]
            t["steps"].append(
                {
                    "t": int(f[0]),
                    "actions": [int(a) for a in f[1].split()],
                    "positions": [cell(c) for c in f[2].split()],
                    "rewards": [float(r) for r in f[3].split()],
                    "blocked": int(f[4]),
                    "status": f[5],
                }
            )
            i += 1
        t["end_reward"] = float(lines[i].removeprefix("end reward "))
        i += 1
        traces.append(t)
    return traces


@pytest.fixture(scope="session")
def traces():
    return parse_trace()
