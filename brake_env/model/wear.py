"""What the twin needs from the atlas, precomputed once: closed-form wear and temperature.

Under the uniform operating distribution the mean wear per event in layer ``j`` is
``K * w_j / V_pad`` with ``w_j = atlas.expected("wear_per_k_m3")[j]``, so the events needed
to wear through layer ``j`` are ``span_j * V_pad / (K * w_j)`` (as in
``brake_env.model.simulator.expected_life``). Their cumulative sum is a *work* coordinate
``u = K * n`` (events times K) at which each layer ends; it does not depend on K. Hence
the paper's two inverse problems are closed-form:

- identification (paper 2.4.1): the K that wears a fresh pad down to ``V`` in ``n`` events
  is ``work(1 -> V) / n``;
- prognosis (paper 2.4.2): the events from ``V`` to failure at ``K`` are
  ``work(V -> failure) / K``.

:class:`TemperatureTable` interpolates the atlas's mean event temperature at a batch of
measured operating conditions for *every* layer at once (one gather per event), together
with its derivative in slope, which the twin needs because the slope sensor is noisy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from brake_env.model.atlas import Atlas

F64 = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class WearModel:
    """Closed-form expected wear path of a pad through the atlas.

    Attributes:
        volumes: Volume fraction at the top of each layer, 1.0 first [-].
        lower_edges: Volume fraction at the bottom of each layer; the last is failure [-].
        work_edges: Work ``K * events`` [-] from a fresh pad to the bottom of each layer.
        life_var_work: Variance of the work at failure that comes from the random operating
            conditions, per unit of ``1 / K`` [-]: ``Var(events to failure) = life_var_work
            / K``.
    """

    volumes: F64
    lower_edges: F64
    work_edges: F64
    life_var_work: float

    @classmethod
    def from_atlas(cls, atlas: Atlas) -> WearModel:
        pad_v = atlas.spec.model.brake.pad_volume_m3
        w = atlas.expected("wear_per_k_m3")
        span = atlas.volumes - atlas.lower_edges
        work_per_layer = span * pad_v / w
        # Spread of the per-event wear in each layer (node values, trapezoid weights): the
        # events spent in a layer vary by ~ sqrt(n_j) * cv_j around their mean n_j.
        w2 = _uniform_mean(atlas.fields["wear_per_k_m3"] ** 2)
        cv2 = np.maximum(w2 / w**2 - 1.0, 0.0)
        return cls(
            volumes=atlas.volumes.copy(),
            lower_edges=atlas.lower_edges.copy(),
            work_edges=np.cumsum(work_per_layer),
            life_var_work=float((work_per_layer * cv2).sum()),
        )

    @property
    def life_work(self) -> float:
        """Work from a fresh pad to failure: expected life in events is ``life_work / K``."""
        return float(self.work_edges[-1])

    @property
    def n_layers(self) -> int:
        return int(self.volumes.size)

    def life(self, k: ArrayLike) -> F64:
        """Expected events from a fresh pad to failure at coefficient ``k``."""
        return self.life_work / np.asarray(k, dtype=np.float64)

    def life_std(self, k: ArrayLike) -> F64:
        """Standard deviation of the events to failure from the random operating conditions."""
        return np.sqrt(self.life_var_work / np.asarray(k, dtype=np.float64))

    def layer_at_work(self, u: ArrayLike) -> NDArray[np.intp]:
        """Active layer after work ``u``: layers whose bottom was reached are done."""
        j = np.searchsorted(self.work_edges, np.asarray(u, dtype=np.float64), side="right")
        return np.minimum(j, self.n_layers - 1)

    def volume_at_work(self, u: ArrayLike) -> F64:
        """Volume fraction after work ``u`` (piecewise linear; clipped at failure)."""
        xs = np.concatenate([[0.0], self.work_edges])
        ys = np.concatenate([[1.0], self.lower_edges])
        return np.interp(np.asarray(u, dtype=np.float64), xs, ys)

    def work_at_volume(self, v: ArrayLike) -> F64:
        """Work to wear a fresh pad down to volume ``v`` (inverse of :meth:`volume_at_work`)."""
        v = np.asarray(v, dtype=np.float64)
        if v.size and (np.any(~np.isfinite(v)) or v.max() > 1.0 or v.min() < self.lower_edges[-1]):
            raise ValueError(
                f"volume must be in [{self.lower_edges[-1]:.4f}, 1] (failure to fresh),"
                f" got range [{np.min(v):g}, {np.max(v):g}]"
            )
        xs = np.concatenate([[1.0], self.lower_edges])[::-1]
        ys = np.concatenate([[0.0], self.work_edges])[::-1]
        return np.interp(v, xs, ys)

    def identify_k(self, volume_frac: ArrayLike, n_events: ArrayLike) -> F64:
        """Closed-form identification: K that wears a fresh pad to ``volume_frac`` in
        ``n_events`` events (the paper's argmin over K of ``|N_sim - dN|``)."""
        n = np.asarray(n_events, dtype=np.float64)
        if np.any(n <= 0):
            raise ValueError("identify_k needs n_events > 0")
        return self.work_at_volume(volume_frac) / n

    def rul(self, volume_frac: ArrayLike, k: ArrayLike) -> F64:
        """Closed-form prognosis: expected events from ``volume_frac`` to failure at ``k``."""
        k = np.asarray(k, dtype=np.float64)
        if np.any(k <= 0):
            raise ValueError("rul needs k > 0")
        return (self.life_work - self.work_at_volume(volume_frac)) / k


def _uniform_mean(field: F64) -> F64:
    """Trapezoid-weighted mean over the grid axes of a (layers, ns, nm, nt) array."""
    ws = [_trapezoid(n) for n in field.shape[1:]]
    return np.einsum("lijk,i,j,k->l", field, *ws)


def _trapezoid(n: int) -> F64:
    w = np.ones(n)
    w[[0, -1]] = 0.5
    return w / w.sum()


class TemperatureTable:
    """Atlas mean event temperature and its slope derivative at measured conditions, for
    every layer at once.

    The fields are regrouped as (cells, 8 corners, layers), so one gather per event fetches
    the 8 corner vectors over all layers; trilinear weights then combine them. Conditions
    outside the grid are clipped to it (a noisy slope sensor reads below 0 or above the
    maximum now and then).
    """

    def __init__(self, atlas: Atlas) -> None:
        t = np.moveaxis(atlas.fields["temp_mean_c"], 0, -1)  # (ns, nm, nt, L)
        ns, nm, nt, n_l = t.shape
        corners = [
            t[ds : ns - 1 + ds, dm : nm - 1 + dm, dt : nt - 1 + dt]
            for ds in (0, 1)
            for dm in (0, 1)
            for dt in (0, 1)
        ]
        self._corners = np.ascontiguousarray(np.stack(corners, axis=3).reshape(-1, 8, n_l))
        self._axes = (atlas.speed_mps, atlas.mass_kg, atlas.slope_rad)
        self._shape = (nm - 1, nt - 1)
        self._dslope = float(atlas.slope_rad[1] - atlas.slope_rad[0])

    def _locate(self, s: F64, m: F64, th: F64) -> tuple[NDArray[np.intp], F64, F64, F64]:
        idx, frac = [], []
        for x, axis in zip((s, m, th), self._axes, strict=True):
            n = axis.size
            u = np.clip((x - axis[0]) * ((n - 1) / (axis[-1] - axis[0])), 0.0, n - 1)
            i = np.minimum(u.astype(np.intp), n - 2)
            idx.append(i)
            frac.append(u - i)
        cm, ct = self._shape
        return (idx[0] * cm + idx[1]) * ct + idx[2], frac[0], frac[1], frac[2]

    def all_layers(self, speed_mps: F64, mass_kg: F64, slope_rad: F64) -> tuple[F64, F64]:
        """(temperature [deg C], d temperature / d slope [K/rad]), each (events, layers)."""
        cell, fs, fm, ft = self._locate(speed_mps, mass_kg, slope_rad)
        g = self._corners[cell]  # (n, 8, L); corner order (speed, mass, slope) bits
        fs, fm, ft = fs[:, None], fm[:, None], ft[:, None]
        lo = g[:, 0::2]  # slope low corners (n, 4, L), order (s, m)
        hi = g[:, 1::2]
        c = lo + ft[:, None] * (hi - lo)  # along slope
        dc = (hi - lo) / self._dslope
        temp = _bilerp(c, fs, fm)
        dtemp = _bilerp(dc, fs, fm)
        return temp, dtemp

    def at_layers(
        self, speed_mps: F64, mass_kg: F64, slope_rad: F64, layer: NDArray[np.intp]
    ) -> tuple[F64, F64]:
        """(temperature, d temperature / d slope) of each event at its own layer."""
        cell, fs, fm, ft = self._locate(speed_mps, mass_kg, slope_rad)
        g = self._corners[cell, :, layer]  # (n, 8)
        lo, hi = g[:, 0::2], g[:, 1::2]
        c = lo + ft[:, None] * (hi - lo)
        dc = (hi - lo) / self._dslope
        return _bilerp(c, fs, fm), _bilerp(dc, fs, fm)


def _bilerp(c: F64, fs: F64, fm: F64) -> F64:
    """Combine 4 corner values (axis 1, order (s0m0, s0m1, s1m0, s1m1)) bilinearly."""
    a = c[:, 0] + fm * (c[:, 1] - c[:, 0])
    b = c[:, 2] + fm * (c[:, 3] - c[:, 2])
    return a + fs * (b - a)
