"""The prices of the Lagrangian bound's linking constraints (:mod:`.lagrangian`).

**Prices** (per shift ``t``; :class:`Prices`). With ``c_h = costs.shortfall`` and
``c_m = costs.mild_shortfall``, for ``lam, mu >= 0``, ``mu <= c_m``, ``lam + mu <= c_h``
the shortfall cost ``f(n_h, n_m)`` is at least ``lam (N_h - n_h) + mu (N_h + N_m - n_h -
n_m)`` for all counts: a hot vehicle earns ``lam + mu``, a mild one ``mu`` (no production
at a window). Bays: the env allows ``visits <= max(bays - down, 0)``; the tightest linear
inequality that every (visits, down) of the env satisfies is ``visits + (bays / n) down
<= bays`` (the line through (bays, 0) and (0, n)), so a visit pays ``nu``, a shift down
``nu * bays / n``. Window crew: a fit at a window pays ``omega`` (at most
``window_slots`` fits). :func:`.lagrangian.bound` adds the prices' constant;
:mod:`.lagrangian_search` searches the prices.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.model import needs

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class Prices:
    """Prices of the linking constraints per shift, shape (episode_shifts,) each.

    Attributes:
        hot: ``lam``: the hot need's price (0 at windows).
        work: ``mu``: the working need's price (hot + mild; 0 at windows).
        bay: ``nu``: a bay's price between windows (0 at windows).
        crew: ``omega``: a window slot's price (0 between windows).
    """

    hot: F64
    work: F64
    bay: F64
    crew: F64

    @classmethod
    def zeros(cls, config: FleetConfig) -> Prices:
        z = np.zeros(config.episode_shifts)
        return cls(z, z.copy(), z.copy(), z.copy())

    def constant(self, config: FleetConfig) -> float:
        """The prices' constant, added to the vehicles' costs in the bound: the needs'
        prices times the needs (the vehicles earn them back by working), less the
        capacities' prices times the capacities (the vehicles pay them per use)."""
        c = config
        hot, work = needs(c, window=False)  # (a window's prices are 0)
        earned = self.hot * hot + self.work * work
        return float(earned.sum() - c.bays * self.bay.sum() - c.window_slots * self.crew.sum())

    def project(self, config: FleetConfig) -> Prices:
        """The nearest prices in the boxes of the module docstring (Euclidean, per shift)."""
        w = np.array([config.is_window(t) for t in range(config.episode_shifts)])
        lam, mu = project_needs(self.hot, self.work, config.costs.shortfall,
                                config.costs.mild_shortfall)  # fmt: skip
        pos = np.maximum
        return Prices(
            np.where(w, 0.0, lam), np.where(w, 0.0, mu),
            np.where(w, 0.0, pos(self.bay, 0.0)), np.where(w, pos(self.crew, 0.0), 0.0),
        )  # fmt: skip


def project_needs(lam: F64, mu: F64, c_h: float, c_m: float) -> tuple[F64, F64]:
    """Euclidean projection of each (lam, mu) onto {lam >= 0, 0 <= mu <= c_m, lam + mu <=
    c_h} (c_m <= c_h assumed; else c_m is taken as c_h)."""
    c_m = min(c_m, c_h)
    corners = np.array([[0.0, 0.0], [c_h, 0.0], [c_h - c_m, c_m], [0.0, c_m]])
    p = np.stack([lam, mu], axis=-1)
    inside = (p[:, 0] >= 0) & (p[:, 1] >= 0) & (p[:, 1] <= c_m) & (p.sum(axis=1) <= c_h)
    best, best_d = p.copy(), np.full(len(p), np.inf)
    for a, b in zip(corners, np.roll(corners, -1, axis=0), strict=True):
        e = b - a
        s = np.clip(((p - a) @ e) / max(float(e @ e), 1e-300), 0.0, 1.0)
        q = a + s[:, None] * e
        d = ((p - q) ** 2).sum(axis=1)
        better = d < best_d
        best[better], best_d[better] = q[better], d[better]
    out = np.where(inside[:, None], p, best)
    return out[:, 0], out[:, 1]


__all__ = ["Prices", "project_needs"]
