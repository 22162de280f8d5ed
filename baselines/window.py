"""A data-driven baseline a practitioner would build: a health index from rolling-window
features, extrapolated to a life (docs/results/prognostics.md).

The paper's MLP (paper 2.2) reads one event at a time; a single event says little about
the pad, because its temperature is dominated by the operating conditions and the sensor
noise. The paper itself suggests smoothing over recent events. This model does, in the
classic two stages of data-driven prognostics (health index, then degradation model with a
Bayesian update of the rate, as in Gebraeel et al., IIE Trans. 37, 2005):

1. **Health index.** Each event's six measured channels are standardised and expanded into
   a quadratic basis (plus a few cubic temperature terms). The index ``h`` of an event is a
   ridge regression of the fraction of life used, ``(event + 1) / life``, on the means of
   that basis over the pad's recent events (:mod:`baselines._rolling`: a window of
   ``window_frac`` of the mean training life, moving by an eighth of it), fitted on the
   training runs that ended at failure. The wear state sets how hot a brake runs for
   given conditions, and the life fraction follows from the wear state whatever the wear
   rate, so the index carries over to pads that wear faster or slower than the training
   ones. The event index is not a feature.
2. **Life.** The index of a window is a noisy reading of ``r * m``, where ``m`` is the
   mean ``event + 1`` of its events and ``r = 1 / life`` the pad's wear rate. A
   Student-t prior on ``r`` from the training lives (ending at failure, or removed before,
   through a survival likelihood: :mod:`baselines._censoring`) is updated with that
   reading; the prior is a scale mixture of normals, so the posterior is a closed-form
   mixture. The estimate is ``1 / E[r] - (event + 1)`` with a 90% interval from the
   posterior's spread.

The event index counts from installation, so a log that starts mid-life gets the estimate
of the whole log once a window of events has been logged (before, a shorter window, read
as the noisier reading it is). Events with a missing channel are left out of the windows;
a pad without readings gets the prior. Deterministic: no random numbers are drawn.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from baselines._censoring import Evidence
from baselines._rate_prior import RatePrior
from baselines._rolling import RollingSums
from baselines._runs import training_runs
from brake_env._validate import check_positive, check_state, from_dict
from brake_env.prognostics.fleet import SlotFleet
from brake_env.prognostics.protocol import MEASURED, EventBatch, Predictor, RULEstimate

F64 = NDArray[np.float64]
STATE_VERSION = 1
QUANTUM = 2.0**-30  # resolution of an event's index in the exact integer window sums
_A_MAX = 64.0  # an event's index beyond this is a broken reading, not wear
_Z90 = 1.6448536269514722  # standard normal 95% quantile: a central 90% interval


@dataclass(frozen=True)
class WindowConfig:
    """Windows, regression and prior of the rolling-window baseline.

    Attributes:
        window_frac: Events in a full window, as a fraction of the mean training life [-].
        n_blocks: Blocks per window; the window moves by a block at a time [-].
        ridge: Ridge penalty on the standardised window features, per window [-].
        train_windows: Training windows per block of each run used in the regression [-].
        prior_nodes: Normal components of the Student-t prior on the wear rate [-].
        max_life_ratio: Longest life considered, in mean training lives [-].
    """

    window_frac: float = 0.035
    n_blocks: int = 8
    ridge: float = 1e-6
    train_windows: int = 25
    prior_nodes: int = 32
    max_life_ratio: float = 50.0

    def __post_init__(self) -> None:
        for name in ("n_blocks", "train_windows", "prior_nodes"):
            n = getattr(self, name)
            if isinstance(n, bool) or not isinstance(n, int) or n < 1:
                raise ValueError(f"WindowConfig.{name} must be an int >= 1, got {n!r}")
        check_positive(self, "window_frac", "ridge", "max_life_ratio")
        if self.max_life_ratio <= 1:
            raise ValueError(f"WindowConfig.max_life_ratio must be > 1, got {self.max_life_ratio}")


def _terms(z: F64) -> Iterator[F64]:
    """The basis columns of standardised channels (events x 6, MEASURED order): the
    channels, their pairwise products and squares, and cubic temperature terms."""
    cols = [z[:, i] for i in range(z.shape[1])]
    yield from cols
    for i in range(len(cols)):
        for j in range(i, len(cols)):
            yield cols[i] * cols[j]
    t = cols[MEASURED.index("temp_c")]
    for c in cols:
        yield t * t * c


def basis(z: F64) -> F64:
    """Per-event features (events x terms) from standardised channels, see ``_terms``."""
    return np.stack(list(_terms(z)), axis=1)


class WindowPredictor(Predictor):
    """Health index from rolling-window features, then a Bayesian wear rate (module doc).

    Args:
        config: Windows, regression and prior.

    Attributes:
        block_events: Events per block of the windows, set by ``fit`` [-].
        z_mean, z_std: Standardisation of the channels, from the training events.
        coef, intercept: The health index of one event, ``intercept + basis(z) @ coef``;
            a window's index is the mean over its events.
        index_sd: Standard deviation of a full window's index about the truth [-].
        ref_count: Mean events of the full training windows ``index_sd`` refers to [-].
        event_sd: Scatter of one event's index about its neighbours' [-].
        prior: Student-t prior on the wear rate ``1 / life`` [1/events].
    """

    name = "window"
    interval_level = 0.9

    def __init__(self, config: WindowConfig | None = None) -> None:
        super().__init__()
        self.config = config or WindowConfig()
        self.block_events = 0
        self.z_mean: F64 | None = None
        self.z_std: F64 | None = None
        self.coef: F64 | None = None
        self.intercept = 0.0
        self.index_sd = 0.0
        self.ref_count = 0.0
        self.event_sd = 0.0
        self.prior: RatePrior | None = None
        self._fleet: WindowFleet | None = None

    # ---------------------------------------------------------------- fitting
    def _fit(self, train_log: pd.DataFrame) -> None:
        runs = training_runs(train_log)
        known = ~runs.censored
        if known.sum() < 2:
            raise ValueError(
                f"window: {int(known.sum())} training run(s) end at failure; the health index"
                " needs at least two (runs removed before failure"
                f" {runs.describe(runs.censored)} only bound their life)"
            )
        mean_life = float(runs.life[known].mean())
        self.block_events = max(
            1, round(self.config.window_frac * mean_life / self.config.n_blocks)
        )
        x = train_log[list(MEASURED)].to_numpy(dtype=np.float64)
        empty = [c for c, col in zip(MEASURED, x.T, strict=True) if np.isnan(col).all()]
        if empty:
            raise ValueError(f"window: channel(s) {empty} have no reading in the training log")
        self.z_mean = np.nanmean(x, axis=0)
        sd = np.nanstd(x, axis=0)
        self.z_std = np.where(sd > 0, sd, 1.0)
        codes = pd.factorize(train_log["run_id"], sort=False)[0]
        order = np.argsort(codes, kind="stable")
        bounds = np.searchsorted(codes[order], np.arange(len(runs.names) + 1))
        event = train_log["event"].to_numpy(dtype=np.int64)
        pieces = [
            (x[rows], event[rows], runs.life[i])
            for i in np.flatnonzero(known)
            for rows in [order[bounds[i] : bounds[i + 1]]]
        ]
        windows = [self._training_windows(*piece) for piece in pieces]
        feats, target, counts = (np.concatenate(c) for c in zip(*windows, strict=True))
        if len(target) <= feats.shape[1]:
            raise ValueError(
                f"window: {len(target)} full windows in the runs that end at failure, the"
                f" health index needs more than {feats.shape[1]} (longer runs, or more)"
            )
        self._regress(feats, target, counts)
        self.event_sd = self._event_sd([p[0] for p in pieces])
        rates = Evidence(
            exact=1.0 / runs.life[known],
            upper=1.0 / (runs.last_event[~known].astype(np.float64) + 1.0),
        )
        self.prior = RatePrior.from_evidence(rates, int(known.sum()), self.config.prior_nodes)
        self._fleet = None

    def _training_windows(self, x: F64, event: NDArray[np.int64], life: float) -> tuple[F64, ...]:
        """Mean basis, life fraction and events of the nearly full windows of one run,
        ``train_windows`` per block."""
        cfg, b = self.config, self.block_events
        phi, valid = self._basis(x)
        cols = np.column_stack([phi, (event + 1.0) * valid, valid])
        cum = np.vstack([np.zeros((1, cols.shape[1])), np.cumsum(cols, axis=0)])
        block = event // b
        rows = np.arange(0, len(event), max(1, b // cfg.train_windows))
        first = np.searchsorted(block, block[rows] - cfg.n_blocks + 1, side="left")
        sums = cum[rows + 1] - cum[first]
        count = sums[:, -1]
        full = count > (cfg.n_blocks - 1) * b
        sums, count = sums[full], count[full]
        return sums[:, :-2] / count[:, None], sums[:, -2] / count / life, count

    def _regress(self, feats: F64, target: F64, count: F64) -> None:
        """Ridge regression of the life fraction on standardised window features, folded
        back into per-event coefficients (a window's index is the mean of its events')."""
        mu, sd = feats.mean(axis=0), feats.std(axis=0)
        sd = np.where(sd > 0, sd, 1.0)
        a = np.column_stack([np.ones(len(feats)), (feats - mu) / sd])
        pen = self.config.ridge * len(a) * np.eye(a.shape[1])
        pen[0, 0] = 0.0
        beta = np.linalg.solve(a.T @ a + pen, a.T @ target)
        self.coef = beta[1:] / sd
        self.intercept = float(beta[0] - (beta[1:] * mu / sd).sum())
        self.index_sd = float(np.std(target - a @ beta))
        self.ref_count = float(count.mean())

    def _event_sd(self, xs: list[F64]) -> float:
        """Scatter of one event's index about its neighbours' (the part of a window's
        error that averages out): from successive events, ``Var(a_i - a_i-1) / 2``."""
        sq, n = 0.0, 0
        for x in xs:
            a, valid = self._index(x)
            a = a[valid > 0]
            sq += float(np.sum(np.diff(a) ** 2))
            n += max(len(a) - 1, 0)
        return math.sqrt(sq / (2 * n)) if n else 0.0

    def _reading_var(self, count: F64) -> F64:
        """Variance of a window's index about the truth, for windows of ``count`` events:
        the regression's error that does not average out, plus the events' scatter."""
        var_sys = max(self.index_sd**2 - self.event_sd**2 / self.ref_count, 0.0)
        return var_sys + self.event_sd**2 / np.maximum(count, 1.0)

    # ---------------------------------------------------------------- prediction
    def _standard(self, x: F64) -> tuple[F64, F64]:
        """Standardised channels (0 where any is missing) and each event's 0/1 valid flag."""
        assert self.z_mean is not None and self.z_std is not None
        z = (x - self.z_mean) / self.z_std
        valid = np.asarray(~np.isnan(z).any(axis=1), dtype=bool)
        return np.where(valid[:, None], z, 0.0), valid.astype(np.float64)

    def _basis(self, x: F64) -> tuple[F64, F64]:
        """Basis rows (0 where a channel is missing) and the 0/1 valid flag of each event."""
        z, valid = self._standard(x)
        return basis(z) * valid[:, None], valid

    def _index(self, x: F64) -> tuple[F64, F64]:
        """Each event's health index and valid flag. Summed term by term in a fixed order
        (no BLAS), so an event's value does not depend on the events beside it."""
        assert self.coef is not None
        z, valid = self._standard(x)
        a = np.full(len(z), self.intercept)
        for c, term in zip(self.coef, _terms(z), strict=True):
            a += c * term
        return a, valid

    def event_values(self, events: EventBatch) -> NDArray[np.int64]:
        """What the windows sum per event, as exact integers: the event's index in units
        of ``QUANTUM``, ``event + 1`` and 1, each 0 for an event with a missing channel."""
        if self.coef is None:
            raise RuntimeError("window: call fit() or set_state() before update()")
        x = np.column_stack([getattr(events, c) for c in MEASURED]).astype(np.float64)
        a, valid = self._index(x)
        ok = valid.astype(np.int64)
        out = np.empty((len(x), 3), dtype=np.int64)
        out[:, 0] = np.rint(np.clip(a, -_A_MAX, _A_MAX) / QUANTUM).astype(np.int64) * ok
        out[:, 1] = (events.event + 1) * ok
        out[:, 2] = ok
        return out

    def estimate(self, sums: NDArray[np.int64], event: NDArray[np.int64]) -> RULEstimate:
        """RUL from window sums (:meth:`event_values` summed) after events ``event``."""
        count = sums[:, 2].astype(np.float64)
        safe = np.maximum(count, 1.0)
        h = sums[:, 0] * QUANTUM / safe
        m = sums[:, 1] / safe
        # Reading h ~ N(r m, var(count)): precision P on r, and P times its mean.
        scale = np.where(count > 0, 1.0 / self._reading_var(count), 0.0)
        p, pm = m * m * scale, m * h * scale
        assert self.prior is not None
        r, sd = self.prior.posterior(p, pm)
        r_min = self.prior.mean / self.config.max_life_ratio
        done = event.astype(np.float64) + 1.0

        def rul(rate: F64) -> F64:
            return np.maximum(1.0 / np.maximum(rate, r_min) - done, 0.0)

        return RULEstimate(
            rul_mean=rul(r), rul_lower=rul(r + _Z90 * sd), rul_upper=rul(r - _Z90 * sd)
        )

    def _reset(self) -> None:
        if self._fleet is not None:
            self._fleet.reset(0)

    def _update(self, events: EventBatch) -> RULEstimate:
        if self._fleet is None:  # one pad is a fleet of one: the same arithmetic
            self._fleet = WindowFleet(self, 1)
        pads = np.zeros(len(events), dtype=np.intp)
        return self._fleet.update(pads, events, np.ones(len(events), dtype=bool))

    def fleet(self, n_pads: int) -> WindowFleet:
        """Many pads at once: their window sums in arrays, one estimate pass."""
        return WindowFleet(self, n_pads)

    # ---------------------------------------------------------------- state
    def get_state(self) -> tuple[dict[str, Any], dict[str, NDArray[Any]]]:
        if self.coef is None or self.z_mean is None or self.z_std is None:
            raise RuntimeError("window: nothing to save, call fit() first")
        meta = {
            "state_version": STATE_VERSION,
            "channels": list(MEASURED),
            "config": asdict(self.config),
            "block_events": self.block_events,
            **{k: getattr(self, k) for k in _SCALARS},
            "prior": None
            if self.prior is None
            else {"mean": self.prior.mean, "scale": self.prior.scale, "dof": self.prior.dof},
        }
        return meta, {"z_mean": self.z_mean, "z_std": self.z_std, "coef": self.coef}

    def set_state(self, meta: Mapping[str, Any], arrays: Mapping[str, NDArray[Any]]) -> None:
        if meta.get("state_version") != STATE_VERSION or meta.get("channels") != list(MEASURED):
            raise ValueError(f"window: not a version-{STATE_VERSION} state of {list(MEASURED)}")
        check_state(
            "window",
            meta,
            arrays,
            meta_keys=("state_version", "channels", "config", "block_events", "prior", *_SCALARS),
            array_keys=("z_mean", "z_std", "coef"),
            finite=("z_mean", "z_std", "coef", "block_events", *_SCALARS),
        )
        pr = meta["prior"]
        if pr is not None:
            check_state("window prior", pr, {}, meta_keys=("mean", "scale", "dof"), finite=pr)
        if pr is None or not int(meta["block_events"]) >= 1:
            raise ValueError("window: the saved state has no prior or no block_events >= 1; refit")
        self.config = from_dict(WindowConfig, dict(meta["config"]))
        n_basis = basis(np.zeros((1, len(MEASURED)))).shape[1]
        coef = np.asarray(arrays["coef"], dtype=np.float64)
        if coef.shape != (n_basis,):
            raise ValueError(f"window: coef has shape {coef.shape}, expected ({n_basis},)")
        self.coef = coef
        self.z_mean = np.asarray(arrays["z_mean"], dtype=np.float64)
        self.z_std = np.asarray(arrays["z_std"], dtype=np.float64)
        self.block_events = int(meta["block_events"])
        for k in _SCALARS:
            setattr(self, k, float(meta[k]))
        pr = meta["prior"]
        self.prior = RatePrior(
            float(pr["mean"]), float(pr["scale"]), float(pr["dof"]), self.config.prior_nodes
        )
        self._fleet = None


_SCALARS = ("intercept", "index_sd", "ref_count", "event_sd")


class WindowFleet(SlotFleet):
    """The rolling-window baseline for many pads: exact integer window sums per slot."""

    def __init__(self, predictor: WindowPredictor, n_pads: int) -> None:
        super().__init__(predictor.name, n_pads)
        if predictor.coef is None:
            raise RuntimeError("window: call fit() or set_state() before making a fleet")
        self.predictor = predictor
        cfg = predictor.config
        self.sums = RollingSums(n_pads, 3, predictor.block_events, cfg.n_blocks)

    def _reset_slots(self, pads: NDArray[np.intp]) -> None:
        self.sums.reset(pads)

    def _update(
        self,
        pads: NDArray[np.intp],
        events: EventBatch,
        want: NDArray[np.bool_],
        starts: NDArray[np.intp],
        slots: NDArray[np.intp],
    ) -> RULEstimate:
        values = self.predictor.event_values(events)
        sums = self.sums.advance(events.event, values, starts, slots, want)
        return self.predictor.estimate(sums, events.event[want])


def make_window(atlas: object, seed: int = 0) -> WindowPredictor:
    """Registry factory (``brakewear.predictors``); the model draws no random numbers, so
    ``seed`` changes nothing."""
    return WindowPredictor()
