"""The wear clock: work <-> volume <-> life of a pad through the atlas layers (paper 2.4).

Under an operating distribution the mean wear per event in layer ``j`` is
``K * w_j / V_pad`` (for the uniform one, ``w_j = atlas.expected("wear_per_k_m3")[j]``),
so the events needed to wear through layer ``j`` are ``span_j * V_pad / (K * w_j)``. Their
cumulative sum is a *work* coordinate ``u = K * n`` (events times K) at which each layer
ends; it does not depend on K. This is the one home of that clock: the simulator sizes its
streams with it, the twin and the physics baseline predict with it, and sim2real builds it
from a log's own operating mix. The paper's two inverse problems are closed-form:

- identification (paper 2.4.1): the K that wears a fresh pad down to ``V`` in ``n`` events
  is ``work(1 -> V) / n``;
- prognosis (paper 2.4.2): the events from ``V`` to failure at ``K`` are
  ``work(V -> failure) / K``.
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
    def from_layer_wear(
        cls,
        tops: F64,
        bottoms: F64,
        wear_per_k_m3: F64,
        pad_volume_m3: float,
        cv2: F64 | None = None,
    ) -> WearModel:
        """The clock of layers ``tops[j] -> bottoms[j]`` worn at mean ``wear_per_k_m3[j]``
        per event per unit K, the squared coefficient of variation ``cv2[j]`` of that wear
        (0 if not given) setting the spread of the life."""
        tops, bottoms, wear = (
            np.asarray(x, dtype=np.float64) for x in (tops, bottoms, wear_per_k_m3)
        )
        _check_layers(tops, bottoms, wear, pad_volume_m3)
        work_per_layer = (tops - bottoms) * pad_volume_m3 / wear
        # The events spent in a layer vary by ~ sqrt(n_j) * cv_j around their mean n_j.
        var = 0.0 if cv2 is None else float((work_per_layer * cv2).sum())
        return cls(
            volumes=np.array(tops, dtype=np.float64),
            lower_edges=np.array(bottoms, dtype=np.float64),
            work_edges=np.cumsum(work_per_layer),
            life_var_work=var,
        )

    @classmethod
    def from_atlas(cls, atlas: Atlas) -> WearModel:
        """The clock under uniform operating conditions over the atlas's envelope."""
        w = atlas.expected("wear_per_k_m3")
        cv2 = np.maximum(atlas.expected("wear_per_k_m3", power=2) / w**2 - 1.0, 0.0)
        pad_v = atlas.spec.model.brake.pad_volume_m3
        return cls.from_layer_wear(atlas.volumes, atlas.lower_edges, w, pad_v, cv2)

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


def _check_layers(tops: F64, bottoms: F64, wear: F64, pad_volume_m3: float) -> None:
    """Layers must tile the volume downwards from 1, each worn at a positive rate."""
    if not (tops.ndim == 1 and tops.shape == bottoms.shape == wear.shape and tops.size):
        raise ValueError(
            "WearModel: tops, bottoms and wear_per_k_m3 must be 1-D arrays of one length,"
            f" got shapes {tops.shape}, {bottoms.shape}, {wear.shape}"
        )
    if tops[0] != 1.0 or np.any(bottoms >= tops) or np.any(tops[1:] != bottoms[:-1]):
        raise ValueError(
            "WearModel: layers must run down from volume 1.0, each top above its bottom and"
            " equal to the previous bottom"
        )
    if not (np.all(np.isfinite(wear)) and np.all(wear > 0)):
        raise ValueError("WearModel: wear_per_k_m3 must be finite and > 0 in every layer")
    if not pad_volume_m3 > 0:
        raise ValueError(f"WearModel: pad_volume_m3 must be > 0, got {pad_volume_m3}")
