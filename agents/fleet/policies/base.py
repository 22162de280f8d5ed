"""SB3's ``predict``, written once for the fleet's policies: each says what it does for one
observation (:meth:`FleetPolicy.action`); a batch (observations on a leading axis, as a
vectorised env gives them) is decided row by row. The recurrent ``state`` is passed through
and ``episode_start`` and ``deterministic`` are ignored: every fleet policy here is
deterministic and keeps what it needs between shifts itself."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

I64 = NDArray[np.int64]


class FleetPolicy:
    """A fleet policy with SB3's ``predict``; subclasses give :meth:`action`."""

    def predict(
        self,
        observation: NDArray[Any],
        state: tuple[NDArray[Any], ...] | None = None,
        episode_start: NDArray[np.bool_] | None = None,
        deterministic: bool = True,
    ) -> tuple[NDArray[Any], tuple[NDArray[Any], ...] | None]:
        obs = np.asarray(observation)
        if obs.ndim == 2:
            return np.stack([self.action(o) for o in obs]), state
        return self.action(obs), state

    def action(self, observation: NDArray[Any]) -> I64:
        """The action (each vehicle's duty, then the spares to order) for one observation."""
        raise NotImplementedError(f"{type(self).__name__} gives no action")
