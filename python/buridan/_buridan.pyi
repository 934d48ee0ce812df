"""Type stubs of the native module ``buridan._buridan`` (PyO3, built from
``python/src/``). Actions: 0 stay, 1 up, 2 right, 3 down, 4 left."""

import os
from typing import Any, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

__version__: str
NUM_ACTIONS: int

Cell = tuple[int, int]
MapLike = Union[str, os.PathLike[str], "Map"]

class BuridanError(Exception):
    """Base class of every error raised by the buridan package."""

class MapError(BuridanError):
    """A map or scenario could not be loaded. Parse errors read
    ``file:line: problem`` and carry ``file``, ``line`` and ``problem``;
    unreadable files carry ``path``; unknown ids carry ``name``."""

    file: str
    line: int
    problem: str
    path: str
    name: str

class EnvError(BuridanError):
    """The env was configured or driven incorrectly (bad agent counts,
    actions outside 0..5, wrong action shapes, stepping a finished episode)."""

class PlannerError(BuridanError):
    """Unknown planner/controller name, or a planner that cannot plan under
    the rule set."""

class SolveError(BuridanError):
    """A planner found no plan (time, memory or node limit; no solution; a
    bad instance)."""

class PolicyError(BuridanError):
    """A policy checkpoint could not be loaded, built or run."""

def reference_models() -> list[tuple[str, str]]:
    """The bundled reference models as ``(id, description)`` pairs."""

def planner_names() -> list[str]:
    """Planner names :func:`plan` accepts (join several with ``+``)."""

class Map:
    """A grid layout: ``Map("rm-2.1")`` (a bundled reference model),
    ``Map("path/to.map")`` (MovingAI, with the ``.scen`` beside it) or
    ``Map("maze/19x19/seed=0")`` (a generated map, named by its spec:
    ``maze``, ``random`` or ``warehouse``; ``learner maps`` lists the keys)."""

    def __init__(self, id_or_path: Union[str, os.PathLike[str]]) -> None: ...
    @staticmethod
    def from_text(map_text: str, scen_text: Optional[str] = None, name: str = "text") -> Map:
        """Parses MovingAI text; errors name ``<name>.map``/``<name>.scen`` and the line."""
    @property
    def name(self) -> str: ...
    @property
    def height(self) -> int: ...
    @property
    def width(self) -> int: ...
    @property
    def walls(self) -> npt.NDArray[np.bool_]:
        """``(height, width)`` bool array (a copy)."""
    @property
    def free_cells(self) -> list[Cell]: ...
    @property
    def scenario(self) -> Optional[tuple[list[Cell], list[Cell]]]:
        """The fixed ``(starts, goals)``, or ``None``."""
    def distances_to(self, row: int, col: int) -> npt.NDArray[np.uint16]:
        """Shortest-path steps from every cell to ``(row, col)``; 65535 = unreachable."""

class GridEnv:
    """One grid environment; episode ``e`` is a pure function of (map,
    agents, seed, e)."""

    def __init__(
        self,
        map: MapLike,
        agents: int = 4,
        *,
        starts: str = "random",
        seed: int = 0,
        t_max: Optional[int] = None,
        rules: str = "thesis",
        sensor_range: int = 2,
        features: Sequence[str] = ...,
        lifelong: bool = False,
        episode: int = 0,
    ) -> None: ...
    def reset(self, episode: int) -> None:
        """Starts episode ``episode``."""
    def step(self, actions: Any) -> tuple[npt.NDArray[np.float32], bool, bool, int]:
        """``(rewards (agents,), terminated, truncated, blocked_moves)``."""
    def obs(self) -> npt.NDArray[np.float32]:
        """Local observations ``(agents, obs_dim)`` (a new array)."""
    def masks(self) -> npt.NDArray[np.uint8]:
        """Action masks ``(agents, 5)``, 1 = legal."""
    def central_obs(self) -> npt.NDArray[np.float32]:
        """The CTE observation: ``1 + 2n`` one-hot planes, flat, then (with
        recipe features) every agent's local observation."""
    def joint_mask(self) -> npt.NDArray[np.uint8]:
        """The agents' masks in order, ``(5n,)``."""
    def positions(self) -> list[Cell]: ...
    def goals(self) -> list[Cell]: ...
    def at_goal(self, agent: int) -> bool: ...
    def stats(self) -> dict[str, Any]:
        """The episode's statistics (``reward``, ``length``, ``success``, …)."""
    def sum_of_costs(self) -> int: ...
    def makespan(self) -> int: ...
    @property
    def agents(self) -> int: ...
    @property
    def t(self) -> int: ...
    @property
    def episode(self) -> int: ...
    @property
    def is_over(self) -> bool: ...
    @property
    def obs_dim(self) -> int: ...
    @property
    def t_max(self) -> int: ...
    @property
    def rules(self) -> str: ...
    @property
    def seed(self) -> int: ...
    @property
    def map(self) -> Map: ...

class VecEnv:
    """``num_envs`` envs with auto-reset; env ``e`` plays episodes ``e, e+N,
    …``. Array properties are read-only views of the Rust buffers,
    overwritten by every ``step`` (no copies)."""

    def __init__(
        self,
        map: MapLike,
        agents: int = 4,
        num_envs: int = 1,
        *,
        starts: str = "random",
        seed: int = 0,
        t_max: Optional[int] = None,
        rules: str = "thesis",
        sensor_range: int = 2,
        features: Sequence[str] = ...,
        obs: str = "local",
        threads: int = 1,
    ) -> None: ...
    def step(self, actions: Any) -> None:
        """``(num_envs, agents)`` or flat actions; uint8 arrays are read in place."""
    @property
    def obs(self) -> npt.NDArray[np.float32]:
        """``(num_envs, rows_per_env, obs_dim)``."""
    @property
    def final_obs(self) -> npt.NDArray[np.float32]: ...
    @property
    def masks(self) -> npt.NDArray[np.uint8]:
        """``(num_envs, rows_per_env, mask_dim)``."""
    @property
    def rewards(self) -> npt.NDArray[np.float32]:
        """``(num_envs, agents)``."""
    @property
    def terminated(self) -> npt.NDArray[np.uint8]:
        """``(num_envs,)``."""
    @property
    def truncated(self) -> npt.NDArray[np.uint8]:
        """``(num_envs,)``."""
    def drain_episodes(self) -> list[dict[str, Any]]:
        """Statistics of the episodes finished since the last call."""
    def positions(self) -> npt.NDArray[np.int64]:
        """``(num_envs, agents, 2)`` (a copy)."""
    def goals(self) -> npt.NDArray[np.int64]: ...
    def episodes(self) -> npt.NDArray[np.uint64]: ...
    @property
    def num_envs(self) -> int: ...
    @property
    def agents(self) -> int: ...
    @property
    def obs_dim(self) -> int: ...
    @property
    def mask_dim(self) -> int: ...
    @property
    def rows_per_env(self) -> int: ...
    @property
    def kind(self) -> str: ...
    @property
    def t_max(self) -> int: ...
    @property
    def map(self) -> Map: ...

class Plan:
    """One timed path per agent, with the planner's statistics."""

    @property
    def paths(self) -> list[list[Cell]]: ...
    @property
    def makespan(self) -> int: ...
    @property
    def sum_of_costs(self) -> int: ...
    @property
    def agents(self) -> int: ...
    @property
    def planner(self) -> str: ...
    @property
    def starts(self) -> list[Cell]: ...
    @property
    def goals(self) -> list[Cell]: ...
    @property
    def stats(self) -> dict[str, float]:
        """``expanded``, ``generated``, ``low_level_expanded``, ``wall_seconds``."""
    def actions(self) -> npt.NDArray[np.uint8]:
        """``(makespan, agents)`` env actions executing the plan."""
    def validate(self) -> None:
        """Raises :class:`BuridanError` with the plan's first conflict."""
    def replay(self, t_max: Optional[int] = None) -> dict[str, Any]:
        """Replays in a :class:`GridEnv`: ``steps``, ``success``,
        ``terminated_at``, ``truncated``, ``blocked_moves``, ``exact``,
        ``final_positions``."""
    def __len__(self) -> int: ...

def plan(
    map: MapLike,
    planner: str = "lacam",
    *,
    agents: Optional[int] = None,
    starts: Optional[Sequence[Cell]] = None,
    goals: Optional[Sequence[Cell]] = None,
    rules: str = "thesis",
    time_limit: float = 60.0,
    memory_limit_mib: int = 2048,
    max_nodes: Optional[int] = None,
    max_makespan: Optional[int] = None,
) -> Plan:
    """Plans on ``map`` (default: its fixed scenario, first ``agents``
    agents). Raises :class:`PlannerError` or :class:`SolveError`."""

class EvalReport:
    """What :func:`evaluate` returns."""

    @property
    def summary(self) -> dict[str, Any]:
        """The fields of ``learner eval --json``."""
    @property
    def records(self) -> list[dict[str, Any]]:
        """One dict per episode (the CSV rows of ``learner eval``)."""
    @property
    def visits(self) -> npt.NDArray[np.uint64]:
        """``(height, width)`` visit counts."""
    def summary_json(self) -> str: ...

def evaluate(
    map: MapLike,
    controller: str,
    *,
    agents: int = 4,
    episodes: int = 100,
    seed: int = 42,
    starts: str = "random",
    t_max: Optional[int] = None,
    rules: str = "thesis",
    time_limit: float = 60.0,
    memory_limit_mib: int = 2048,
    jobs: int = 1,
    sample: bool = False,
    delay: float = 0.0,
) -> EvalReport:
    """``learner eval`` on episodes ``0..episodes``: a planner name,
    ``"random"``, ``"checkpoint:DIR"``, ``"shield:checkpoint:DIR"``,
    ``"rescue:CONTROLLER"``, …; ``delay``: the probability that a robot
    fails to carry out its move in a step (``learner eval --delay``)."""

class Policy:
    """A trained policy for inference (``learner train`` checkpoints)."""

    @staticmethod
    def load(path: Union[str, os.PathLike[str]], *, seed: int = 0) -> Policy:
        """A checkpoint directory or a run directory (``checkpoints/final``,
        else the newest ``checkpoints/update-*``)."""
    @staticmethod
    def new(
        mode: str = "ctde",
        agents: int = 2,
        obs_dim: Optional[int] = None,
        *,
        hidden: Optional[Sequence[int]] = None,
        lstm_cells: Optional[int] = None,
        sensor_range: int = 2,
        features: Sequence[str] = ...,
        rules: str = "thesis",
        seed: int = 0,
    ) -> Policy: ...
    def save(self, dir: Union[str, os.PathLike[str]]) -> None:
        """Writes ``spec.json`` and ``model.safetensors``."""
    def act(
        self, obs: Any, masks: Any, *, greedy: bool = True
    ) -> tuple[npt.NDArray[np.uint8], npt.NDArray[np.float32], npt.NDArray[np.float32]]:
        """``(actions (rows, heads), logp (rows,), logits (rows, heads*5))``."""
    def act_env(self, env: GridEnv, *, greedy: bool = True) -> npt.NDArray[np.uint8]:
        """One action per agent of ``env``."""
    def observe(self, actions: Any, rewards: Any, done: Any) -> None: ...
    def reset_state(self) -> None: ...
    def env_kwargs(self) -> dict[str, Any]:
        """``sensor_range``, ``features``, ``rules`` for the env constructors."""
    @property
    def spec_dict(self) -> dict[str, Any]: ...
    @property
    def mode(self) -> str: ...
    @property
    def agents(self) -> int: ...
    @property
    def obs_dim(self) -> int: ...
    @property
    def heads(self) -> int: ...
    @property
    def recurrent(self) -> bool: ...
    @property
    def num_params(self) -> int: ...
    @property
    def path(self) -> Optional[str]: ...
