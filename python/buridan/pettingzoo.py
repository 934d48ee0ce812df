"""The grid env as a PettingZoo :class:`pettingzoo.ParallelEnv`.

Every agent observes a dict, as the dissertation's env exposes it::

    {"observation": float32 (obs_dim,), "action_mask": int8 (5,)}

``observation`` is the local window (one-hot over 5 cell codes) plus the
normalised position and goal delta (129 floats for sensor range 2; layout in
``env/src/obs.rs``); ``action_mask`` marks legal actions (stay is always
legal; a move iff the neighbour is free). Illegal actions are allowed and
simply blocked, as in the Rust env. All agents end together (termination
when every agent stands on its goal, truncation at ``t_max``), after which
:attr:`agents` is empty.
"""

from __future__ import annotations

from typing import Any, Dict, Optional, Sequence

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv as _PzParallelEnv

from ._buridan import GridEnv, Map

__all__ = ["ParallelEnv", "parallel_env"]



class ParallelEnv(_PzParallelEnv):
    """A Buridan grid world (``rm-1.1`` … ``rm-3.x`` or any MovingAI map).

    Parameters
    ----------
    map:
        Reference model id (``"rm-2.1"``), path to a ``.map`` file, or a
        :class:`buridan.Map`.
    agents:
        Number of agents.
    starts:
        ``"random"`` (drawn per episode from ``seed``) or ``"fixed"`` (the
        map's ``.scen`` scenario).
    seed:
        Seed of the episode generator; ``reset(seed=s)`` replaces it.
    t_max:
        Truncation step count (``None``: 100 under thesis rules, 128 under
        pogema rules).
    rules:
        ``"thesis"`` (sequential moves in index order, the dissertation's) or
        ``"pogema"`` (POGEMA's simultaneous moves).
    sensor_range, features:
        Observation window radius and extra feature groups (``"path"``,
        ``"priority"``, ``"pressure"``, ``"intent"``, ``"order"``), as a trained policy expects
        (``Policy.env_kwargs()``).
    render_mode:
        ``None`` or ``"ansi"``.

    Episodes are a pure function of (map, agents, seed, episode index):
    ``reset()`` plays episodes 0, 1, 2, … in turn; ``reset(options={"episode":
    e})`` replays episode ``e``.
    """

    metadata = {"name": "buridan_v0", "render_modes": ["ansi"], "is_parallelizable": True}

    def __init__(
        self,
        map: "str | Map" = "rm-1.1",
        agents: int = 2,
        *,
        starts: str = "random",
        seed: int = 0,
        t_max: Optional[int] = None,
        rules: str = "thesis",
        sensor_range: int = 2,
        features: Sequence[str] = (),
        render_mode: Optional[str] = None,
    ) -> None:
        if render_mode not in (None, "ansi"):
            raise ValueError(f"render_mode must be None or 'ansi', got {render_mode!r}")
        self.render_mode = render_mode
        self._kwargs = dict(
            starts=starts,
            t_max=t_max,
            rules=rules,
            sensor_range=sensor_range,
            features=list(features),
        )
        self._map = map
        self._env = GridEnv(map, agents, seed=seed, **self._kwargs)
        self._seed = seed
        self._next_episode = 0
        self.possible_agents = [f"agent_{i}" for i in range(agents)]
        self.agents = []
        d = self._env.obs_dim
        obs_space = spaces.Dict(
            {
                "observation": spaces.Box(-1.0, 1.0, (d,), np.float32),
                "action_mask": spaces.Box(0, 1, (5,), np.int8),
            }
        )
        self.observation_spaces = {a: obs_space for a in self.possible_agents}
        self.action_spaces = {a: spaces.Discrete(5) for a in self.possible_agents}
        m = self._env.map
        self.state_space = spaces.Box(
            0.0, 1.0, ((1 + 2 * agents) * m.height * m.width,), np.float32
        )

    # -- PettingZoo API -------------------------------------------------------

    def observation_space(self, agent: str) -> spaces.Space:
        return self.observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Space:
        return self.action_spaces[agent]

    def reset(self, seed: Optional[int] = None, options: Optional[dict] = None):
        """Starts the next episode (or episode ``options["episode"]``); a
        ``seed`` restarts the episode sequence of that seed at episode 0."""
        if seed is not None and seed != self._seed:
            self._env = GridEnv(self._map, len(self.possible_agents), seed=seed, **self._kwargs)
            self._seed = seed
            self._next_episode = 0
        elif seed is not None:
            self._next_episode = 0
        episode = self._next_episode
        if options and "episode" in options:
            episode = int(options["episode"])
        self._env.reset(episode)
        self._next_episode = episode + 1
        self.agents = self.possible_agents[:]
        return self._observe(), {a: {} for a in self.agents}

    def step(self, actions: Dict[str, Any]):
        """Steps every agent; an agent missing from ``actions`` stays."""
        if not self.agents:
            raise RuntimeError("the episode is over: call reset before stepping again")
        unknown = set(actions) - set(self.possible_agents)
        if unknown:
            raise KeyError(f"unknown agents {sorted(unknown)}; agents are {self.possible_agents}")
        joint = [int(actions.get(a, 0)) for a in self.possible_agents]
        rewards, terminated, truncated, blocked = self._env.step(joint)
        obs = self._observe()
        agents = self.agents
        rew = {a: float(r) for a, r in zip(self.possible_agents, rewards)}
        term = {a: bool(terminated) for a in agents}
        trunc = {a: bool(truncated) for a in agents}
        infos = {a: {"blocked_moves": blocked} for a in agents}
        if terminated or truncated:
            stats = self._env.stats()
            for a in agents:
                infos[a]["episode"] = stats
            self.agents = []
        return obs, rew, term, trunc, infos

    def observe(self, agent: str) -> Dict[str, np.ndarray]:
        i = self.possible_agents.index(agent)
        return {
            "observation": self._env.obs()[i],
            "action_mask": self._env.masks()[i].astype(np.int8),
        }

    def state(self) -> np.ndarray:
        """The central observation: ``1 + 2n`` one-hot planes (walls, each
        agent, each goal) of ``height x width``, flat; with recipe features
        on, every agent's local observation follows, in agent order."""
        return self._env.central_obs()

    def render(self) -> Optional[str]:
        if self.render_mode is None:
            return None
        m = self._env.map
        walls = m.walls
        grid = [["@" if walls[r, c] else "." for c in range(m.width)] for r in range(m.height)]
        for i, (r, c) in enumerate(self._env.goals()):
            grid[r][c] = chr(ord("a") + i % 26)
        for i, (r, c) in enumerate(self._env.positions()):
            grid[r][c] = chr(ord("A") + i % 26)
        return "\n".join("".join(row) for row in grid)

    def close(self) -> None:
        pass

    # -- extras ---------------------------------------------------------------

    @property
    def unwrapped_env(self) -> GridEnv:
        """The underlying :class:`buridan.GridEnv`."""
        return self._env

    @property
    def episode(self) -> int:
        """The index of the current episode."""
        return self._env.episode

    def _observe(self) -> Dict[str, Dict[str, np.ndarray]]:
        obs = self._env.obs()
        masks = self._env.masks().astype(np.int8)
        return {
            a: {"observation": obs[i], "action_mask": masks[i]}
            for i, a in enumerate(self.possible_agents)
            if a in self.agents
        }


def parallel_env(**kwargs) -> ParallelEnv:
    """PettingZoo-style constructor: ``buridan.parallel_env(map="rm-2.1", agents=4)``."""
    return ParallelEnv(**kwargs)
