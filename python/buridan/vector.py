"""A Gymnasium-style batched vector env over :class:`buridan.VecEnv`.

``num_envs`` copies of a multi-agent grid world stepped as one batch in
Rust, with auto-reset in the same step (Gymnasium's ``SAME_STEP`` mode).
Observations, masks, rewards and done flags are NumPy views of the Rust
buffers: ``step`` returns the same array objects every time, overwritten in
place, and no per-step copy is made (copy what you keep).

Shapes (``N`` envs, ``n`` agents, ``d`` floats per observation):

- observation ``{"observation": float32 (N, n, d), "action_mask": uint8 (N, n, 5)}``
- action ``(N, n)`` integers in 0..5 (any integer dtype; ``uint8`` is read in place)
- reward ``float32 (N, n)`` per agent; terminated / truncated ``bool (N,)``

``infos`` carries, when some episode ended, ``"final_obs"`` (the last
observations, same layout as the observation; rows of other envs stale),
``"_final_obs"`` (which envs ended) and ``"episodes"`` (per finished episode
a dict: ``episode``, ``reward``, ``length``, ``success``, ``agents_at_goal``,
``blocked_moves``, deadlock counts).
"""

from __future__ import annotations

from typing import Any, Optional, Sequence

import numpy as np
import gymnasium as gym
from gymnasium import spaces
from gymnasium.vector.utils import batch_space

from ._buridan import VecEnv

__all__ = ["VectorEnv"]

try:  # Gymnasium >= 1.1
    from gymnasium.vector import AutoresetMode

    _SAME_STEP: Any = AutoresetMode.SAME_STEP
except ImportError:  # pragma: no cover - Gymnasium 1.0
    _SAME_STEP = "same-step"


class VectorEnv(gym.vector.VectorEnv):
    """``num_envs`` Buridan grid worlds as one Gymnasium vector env.

    Env ``e`` plays episodes ``e, e + N, e + 2N, …`` of the seed's
    sequence; ``reset()`` restarts the batch at episodes ``0..N-1`` (of a
    new ``seed``, if given). ``threads > 1`` steps the envs on a Rust thread
    pool. Other parameters as :class:`buridan.ParallelEnv`.
    """

    metadata = {"autoreset_mode": _SAME_STEP, "render_modes": []}

    def __init__(
        self,
        map: Any = "rm-2.1",
        agents: int = 4,
        num_envs: int = 16,
        *,
        starts: str = "random",
        seed: int = 0,
        t_max: Optional[int] = None,
        rules: str = "thesis",
        sensor_range: int = 2,
        features: Sequence[str] = (),
        threads: int = 1,
    ) -> None:
        self._args = (map, agents, num_envs)
        self._kwargs = dict(
            starts=starts,
            t_max=t_max,
            rules=rules,
            sensor_range=sensor_range,
            features=list(features),
            threads=threads,
        )
        self._seed = seed
        self._make(seed)
        v = self._venv
        self.num_envs = num_envs
        self.agents = agents
        self.single_observation_space = spaces.Dict(
            {
                "observation": spaces.Box(-1.0, 1.0, (agents, v.obs_dim), np.float32),
                "action_mask": spaces.Box(0, 1, (agents, v.mask_dim), np.uint8),
            }
        )
        self.single_action_space = spaces.MultiDiscrete(np.full(agents, 5, dtype=np.int64))
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)

    def _make(self, seed: int) -> None:
        self._venv = VecEnv(*self._args, seed=seed, **self._kwargs)
        v = self._venv
        # Views of the Rust buffers, made once: every step overwrites them.
        self._obs = {"observation": v.obs, "action_mask": v.masks}
        self._final = {"observation": v.final_obs, "action_mask": v.masks}
        self._rewards = v.rewards
        self._terminated = v.terminated.view(np.bool_)
        self._truncated = v.truncated.view(np.bool_)

    @property
    def unwrapped_vec_env(self) -> VecEnv:
        """The underlying :class:`buridan.VecEnv`."""
        return self._venv

    def reset(self, *, seed: Optional[int] = None, options: Optional[dict] = None):
        if seed is not None:
            self._seed = int(seed)
        self._make(self._seed)
        return self._obs, {}

    def step(self, actions):
        self._venv.step(actions)
        infos: dict = {}
        done = self._terminated | self._truncated
        if done.any():
            infos["final_obs"] = self._final
            infos["_final_obs"] = done
            infos["episodes"] = self._venv.drain_episodes()
        return self._obs, self._rewards, self._terminated, self._truncated, infos

    def close_extras(self, **kwargs) -> None:
        pass
