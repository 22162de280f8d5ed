"""An agent's observation normalisation (VecNormalize's statistics), kept with the agent
(:mod:`agents.learning.persist`) and beside SB3's ``model.zip``."""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from stable_baselines3.common.vec_env import VecNormalize


@dataclass(frozen=True, eq=False)
class ObsNormalization:
    """VecNormalize's observation statistics: ``clip((obs - mean) / sqrt(var + epsilon))``.

    Attributes:
        mean, var: Running mean and variance of each observation feature.
        clip_obs: Bound of the normalised observation [-].
        epsilon: Added to the variance [-].
        enabled: False when training did not normalise observations (then it is the identity).
    """

    mean: NDArray[np.float64]
    var: NDArray[np.float64]
    clip_obs: float = 10.0
    epsilon: float = 1e-8
    enabled: bool = True

    @classmethod
    def from_vec_normalize(cls, venv: VecNormalize) -> ObsNormalization:
        from stable_baselines3.common.running_mean_std import RunningMeanStd

        rms = venv.obs_rms
        if not isinstance(rms, RunningMeanStd):
            raise ValueError("save_agent: only a Box observation's VecNormalize is supported")
        return cls(
            np.array(rms.mean, np.float64),
            np.array(rms.var, np.float64),
            float(venv.clip_obs),
            float(venv.epsilon),
            bool(venv.norm_obs),
        )

    @classmethod
    def identity(cls, n: int) -> ObsNormalization:
        return cls(np.zeros(n), np.ones(n), enabled=False)

    def normalize(self, obs: NDArray[Any]) -> NDArray[np.float32]:
        """Observations as the agent saw them in training."""
        if not self.enabled:
            return np.asarray(obs, dtype=np.float32)
        z = (np.asarray(obs) - self.mean) / np.sqrt(self.var + self.epsilon)
        return np.clip(z, -self.clip_obs, self.clip_obs).astype(np.float32)

    def save(self, path: str | os.PathLike[str]) -> None:
        """The statistics alone as ``.npz`` (numbers only), beside SB3's ``model.zip``."""
        np.savez(path, mean=self.mean, var=self.var, clip_obs=self.clip_obs,
                 epsilon=self.epsilon, enabled=self.enabled)  # fmt: skip

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> ObsNormalization:
        """The statistics :meth:`save` wrote."""
        with np.load(path, allow_pickle=False) as z:
            return cls(
                z["mean"], z["var"], float(z["clip_obs"]), float(z["epsilon"]), bool(z["enabled"])
            )
