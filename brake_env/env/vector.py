"""The native vector version of BrakeWear-v0 (``gym.make_vec("BrakeWear-v0", num_envs=N)``).

Each sub-environment is a :class:`PadService`, exactly as in the single env, with its own
random stream seeded like :class:`gymnasium.vector.SyncVectorEnv` seeds its copies (seed + i),
so both give the same rollouts. What the native version saves is the per-env wrapper stack
and N copies of the atlas: every sub-environment shares one.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from numpy.typing import NDArray

from brake_env.env.atlases import default_atlas
from brake_env.env.brake_wear import REPLACE, BrakeWearEnv, observation_space
from brake_env.env.config import EnvConfig
from brake_env.env.lazy_truth import LazyTruth, StackedTruth
from brake_env.env.pads import PadService
from brake_env.model.atlas import Atlas


class BrakeWearVectorEnv(VectorEnv[NDArray[np.float32], NDArray[np.int64], NDArray[Any]]):
    """``num_envs`` independent BrakeWear-v0 vehicles stepped together.

    Autoreset is Gymnasium's default ``NEXT_STEP``: the step after a truncation resets that
    sub-environment (its action is ignored, reward 0). Arguments as :class:`BrakeWearEnv`.
    """

    metadata: dict[str, Any] = {  # noqa: RUF012 - gymnasium's convention
        "render_modes": [],
        "autoreset_mode": AutoresetMode.NEXT_STEP,
    }

    def __init__(
        self,
        num_envs: int = 1,
        config: EnvConfig | None = None,
        atlas: Atlas | str | os.PathLike[str] | None = None,
        **kwargs: Any,
    ) -> None:
        if not isinstance(num_envs, int) or num_envs < 1:
            raise ValueError(f"BrakeWear-v0: num_envs must be an int >= 1, got {num_envs!r}")
        self.config = EnvConfig.from_kwargs(config, **kwargs)
        if atlas is None:
            atlas = default_atlas(self.config.preset)
        elif not isinstance(atlas, Atlas):
            atlas = Atlas.load(atlas)
        self.atlas = atlas
        self.num_envs = num_envs
        self._box = observation_space(self.config)
        self.single_observation_space = self._box
        self.single_action_space = spaces.Discrete(2)
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.render_mode = None
        self._services = [PadService(atlas, self.config) for _ in range(num_envs)]
        self._rngs = [seeding.np_random()[0] for _ in range(num_envs)]
        self._autoreset = np.zeros(num_envs, dtype=bool)
        self._started = False
        self.spec = None

    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[np.float32], dict[str, Any]]:
        if seed is None:
            seeds: list[int | None] = [None] * self.num_envs
        elif isinstance(seed, int):
            seeds = [seed + i for i in range(self.num_envs)]
        else:
            seeds = list(seed)
            if len(seeds) != self.num_envs:
                raise ValueError(f"got {len(seeds)} seeds for {self.num_envs} environments")
        infos: dict[str, Any] = {}
        for i, s in enumerate(seeds):
            if s is not None:
                self._rngs[i], _ = seeding.np_random(s)
            infos = self._add_info(infos, self._services[i].start(self._rngs[i]), i)
        self._autoreset[:] = False
        self._started = True
        return self._observations(), infos

    def step(
        self, actions: NDArray[np.int64]
    ) -> tuple[NDArray[np.float32], NDArray[Any], NDArray[Any], NDArray[Any], dict[str, Any]]:
        if not self._started:
            raise RuntimeError("BrakeWear-v0: call reset() before step()")
        arr = np.asarray(actions) if isinstance(actions, np.ndarray | list | tuple) else None
        if (
            arr is None
            or arr.shape != (self.num_envs,)
            or arr.dtype.kind not in "iu"
            or not np.isin(arr, (0, 1)).all()
        ):
            raise ValueError(
                f"BrakeWear-v0: actions must be {self.num_envs} integers in {{0, 1}} (0 keep, 1"
                f" replace; an int array of shape ({self.num_envs},)), got {actions!r}"
            )
        actions = arr
        rewards = np.zeros(self.num_envs)
        truncs = np.zeros(self.num_envs, dtype=bool)
        infos: dict[str, Any] = {}
        for i, svc in enumerate(self._services):
            if self._autoreset[i]:
                info = svc.start(self._rngs[i])
            else:
                info = svc.step(bool(actions[i] == REPLACE))
                rewards[i] = BrakeWearEnv.reward(info)
                truncs[i] = svc.truncated
            infos = self._add_info(infos, info, i)
        self._autoreset = truncs.copy()
        return self._observations(), rewards, np.zeros(self.num_envs, dtype=bool), truncs, infos

    def _add_info(
        self, vector_infos: dict[str, Any], env_info: dict[str, Any], env_num: int
    ) -> dict[str, Any]:
        """Gymnasium's stacking, except that a pending truth stays pending
        (:class:`~brake_env.env.lazy_truth.StackedTruth`): stacking iterates it."""
        truth, stacked = env_info.get("truth"), vector_infos.get("truth")
        if isinstance(stacked, StackedTruth) or (isinstance(truth, LazyTruth) and truth.pending):
            if not isinstance(stacked, StackedTruth):
                stacked = vector_infos["truth"] = StackedTruth(self.num_envs, stacked)
            env_info = {**env_info, "truth": stacked.add(env_num, env_info["truth"])}
        return super()._add_info(vector_infos, env_info, env_num)

    def _observations(self) -> NDArray[np.float32]:
        obs = np.stack([svc.observation() for svc in self._services])
        return np.clip(obs, self._box.low, self._box.high, out=obs)
