"""An RLlib :class:`~ray.rllib.env.multi_agent_env.MultiAgentEnv` over
:class:`buridan.ParallelEnv` (optional: needs ``pip install "ray[rllib]"``).

::

    from ray.tune.registry import register_env
    from buridan.rllib import BuridanMultiAgentEnv
    register_env("buridan", lambda cfg: BuridanMultiAgentEnv(cfg))
    # config.environment("buridan", env_config={"map": "rm-2.1", "agents": 4})

Observations are the ParallelEnv's dicts (``observation``, ``action_mask``),
which RLlib's action-masking modules read; ``"__all__"`` ends the episode
for everybody at once.
"""

from __future__ import annotations

from typing import Any, Optional

try:
    from ray.rllib.env.multi_agent_env import MultiAgentEnv
except ImportError as err:  # pragma: no cover - exercised without ray
    raise ImportError(
        "buridan.rllib needs Ray RLlib, which is optional: pip install 'ray[rllib]'"
    ) from err

from .pettingzoo import ParallelEnv

__all__ = ["BuridanMultiAgentEnv"]


class BuridanMultiAgentEnv(MultiAgentEnv):
    """``env_config`` holds :class:`buridan.ParallelEnv`'s keyword arguments
    (``map``, ``agents``, ``starts``, ``seed``, ``t_max``, ``rules``, …)."""

    def __init__(self, config: Optional[dict] = None) -> None:
        super().__init__()
        self.par_env = ParallelEnv(**dict(config or {}))
        self.possible_agents = list(self.par_env.possible_agents)
        self.agents = []
        self.observation_spaces = dict(self.par_env.observation_spaces)
        self.action_spaces = dict(self.par_env.action_spaces)
        # Older RLlib reads the single (shared) spaces.
        first = self.possible_agents[0]
        self.observation_space = self.observation_spaces[first]
        self.action_space = self.action_spaces[first]

    def reset(self, *, seed: Optional[int] = None, options: Optional[dict] = None):
        obs, infos = self.par_env.reset(seed=seed, options=options)
        self.agents = list(self.par_env.agents)
        return obs, infos

    def step(self, action_dict: dict[str, Any]):
        obs, rew, term, trunc, infos = self.par_env.step(action_dict)
        done = not self.par_env.agents
        term["__all__"] = done and any(term.values())
        trunc["__all__"] = done and not term["__all__"] and any(trunc.values())
        self.agents = list(self.par_env.agents)
        return obs, rew, term, trunc, infos
