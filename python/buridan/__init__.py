"""Buridan from Python: grid worlds of warehouse robots, classical MAPF
planners, the evaluation harness and trained policies, bound from the Rust
crates of the `Buridan` workspace.

Core (NumPy only)
    :class:`Map`, :class:`GridEnv`, :class:`VecEnv` (``buridan-env``),
    :func:`plan`, :class:`Plan`, :func:`planner_names` (``buridan-mapf``),
    :func:`evaluate`, :class:`EvalReport` (``buridan-eval``),
    :class:`Policy` (``buridan-policy``), and the exceptions
    :class:`BuridanError` > :class:`MapError`, :class:`EnvError`,
    :class:`PlannerError`, :class:`SolveError`, :class:`PolicyError`.

Adapters (imported on first use)
    :class:`ParallelEnv` (PettingZoo, ``buridan.pettingzoo``),
    :class:`VectorEnv` (Gymnasium, ``buridan.vector``),
    ``buridan.rllib.BuridanMultiAgentEnv`` (Ray RLlib, optional).

Actions: 0 stay, 1 up (row - 1), 2 right (col + 1), 3 down (row + 1),
4 left (col - 1).
"""

from ._buridan import (
    NUM_ACTIONS,
    BuridanError,
    EnvError,
    EvalReport,
    GridEnv,
    Map,
    MapError,
    Plan,
    PlannerError,
    Policy,
    PolicyError,
    SolveError,
    VecEnv,
    __version__,
    evaluate,
    plan,
    planner_names,
    reference_models,
)

__all__ = [
    "NUM_ACTIONS",
    "BuridanError",
    "EnvError",
    "EvalReport",
    "GridEnv",
    "Map",
    "MapError",
    "ParallelEnv",
    "Plan",
    "PlannerError",
    "Policy",
    "PolicyError",
    "SolveError",
    "VecEnv",
    "VectorEnv",
    "__version__",
    "evaluate",
    "parallel_env",
    "plan",
    "planner_names",
    "reference_models",
]


def __getattr__(name):
    # The adapters need PettingZoo / Gymnasium; import them only when asked.
    if name in ("ParallelEnv", "parallel_env"):
        from . import pettingzoo as _pz

        return getattr(_pz, name)
    if name == "VectorEnv":
        from .vector import VectorEnv

        return VectorEnv
    raise AttributeError(f"module 'buridan' has no attribute {name!r}")
