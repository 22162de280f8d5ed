"""A Student-t prior on a pad's wear rate, updated with normal readings in closed form.

The prior is the predictive of a new pad's rate given the training pads: a Student-t of
``dof`` degrees of freedom, location ``mean`` and scale ``scale``. A Student-t is a scale
mixture of normals, ``N(mean, scale^2 / w)`` with ``w ~ Gamma(dof / 2, rate dof / 2)``;
at ``nodes`` equal-probability values of ``w`` each component is conjugate to a normal
reading, so the posterior is a mixture of normals with weights from each component's
evidence for the reading. The heavy tails let a reading far from the training pads (a pad
that wears much faster or slower) win over the prior sooner than a normal prior would.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from baselines._censoring import Evidence, fit_normal

F64 = NDArray[np.float64]
_CHUNK = 4096  # rows per pass: rows x components stay in cache


@dataclass(frozen=True, eq=False)
class RatePrior:
    """Student-t prior on a rate (module docstring).

    Attributes:
        mean, scale: Location and scale of the prior [unit of the rate].
        dof: Degrees of freedom [-].
        nodes: Normal components of the mixture [-].
    """

    mean: float
    scale: float
    dof: float
    nodes: int = 32
    precisions: F64 = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if not (self.scale > 0 and self.dof > 0 and self.nodes >= 1):
            raise ValueError(f"RatePrior: scale and dof must be > 0, nodes >= 1, got {self}")
        from scipy import stats  # only a fitted or loaded predictor needs it

        q = (np.arange(self.nodes) + 0.5) / self.nodes
        w = stats.gamma.ppf(q, self.dof / 2.0, scale=2.0 / self.dof)
        object.__setattr__(self, "precisions", w / self.scale**2)

    @classmethod
    def from_evidence(cls, ev: Evidence, n_known: int, nodes: int = 32) -> RatePrior:
        """The predictive of a new pad: location and scale from the normal fit of the
        training rates (a survival likelihood when pads were removed early, see
        :func:`fit_normal`), ``n_known - 1`` dof; a scale below 0.1% of the mean (pads
        all alike) is raised to it."""
        if n_known < 2:
            raise ValueError(f"RatePrior: needs two known rates, got {n_known}")
        mean, sd = fit_normal(ev)
        n = n_known
        scale = max(sd * math.sqrt((n + 1) / (n - 1)), 1e-3 * abs(mean))  # ddof-1 sd
        return cls(mean, scale, float(n - 1), nodes)

    def posterior(self, p: F64, pm: F64) -> tuple[F64, F64]:
        """Mean and standard deviation of the rate after a normal reading of precision
        ``p`` and mean ``pm / p``, per row; ``p = 0`` (no reading) leaves the prior."""
        r, sd = np.empty(len(p)), np.empty(len(p))
        for a in range(0, len(p), _CHUNK):
            sl = slice(a, a + _CHUNK)
            r[sl], sd[sl] = self._mixture(p[sl, None], pm[sl, None])
        return r, sd

    def _mixture(self, p: F64, pm: F64) -> tuple[F64, F64]:
        pk = self.precisions[None, :]
        post_p = p + pk
        mu = (pk * self.mean + pm) / post_p
        # Log evidence of each component for the reading, N(pm/p; mean, 1/pk + 1/p), up
        # to a term common to all components.
        resid = pm - p * self.mean
        misfit = np.divide(resid**2 * pk, p * post_p, out=np.zeros_like(post_p), where=p > 0)
        logw = 0.5 * (np.log(pk / post_p) - misfit)
        w = np.exp(logw - logw.max(axis=1, keepdims=True))
        w /= w.sum(axis=1, keepdims=True)
        r = (w * mu).sum(axis=1)
        var = (w * (1.0 / post_p + mu * mu)).sum(axis=1) - r * r
        return r, np.sqrt(np.maximum(var, 0.0))
