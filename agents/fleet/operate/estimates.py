"""What a saved model says of each pad in service, and the fleet's state built from it.

Every estimate is in the predictor's own unit, events of the envelope's uniform mix (the
base duty the predictors are fitted on). A pad's volume is the predictor's where it gives
one, else the expected base-mix path's at the share of life it states used
(:func:`brake_env.prognostics.duty.volume_estimate`); its K is the one that makes the base
mix's clock give the stated RUL from that volume, ``(life work - work at V) / RUL``, which
for the twin is its own K (the clocks are its physics). The RUL's uncertainty is read as a
lognormal through the 90% interval (:func:`rul_quantiles`): the predictors state an
interval, not a distribution, and a lognormal is the least assuming law of a positive
life whose interval is wider above than below.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from scipy.stats import norm

from brake_env.cli.common import read_atlas
from brake_env.data.schema import read_event_log
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.route_rul import duty_clocks
from brake_env.env.fleet.state import FleetState
from brake_env.model.atlas import Atlas
from brake_env.model.wear import WearModel
from brake_env.prognostics.duty import volume_estimate
from brake_env.prognostics.events import RULEstimate
from brake_env.prognostics.fleet import predict_runs
from brake_env.prognostics.persist import check_atlas, load_predictor, model_atlas, read_header
from brake_env.prognostics.planner_units import LEVEL, last_times, lognormal, p_fail_before
from brake_env.prognostics.protocol import iter_runs

F64 = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class VehicleEstimates:
    """Each vehicle's pad as a predictor sees it, in base-mix events.

    Attributes:
        vehicles: Names (the log's ``run_id``), in fleet order.
        age: Events each pad has braked since installation.
        mean, lower, upper: Its RUL and 90% interval.
        volume: Its volume fraction (the predictor's, or the expected path's).
        wear_coeff: The K that gives ``mean`` from ``volume`` on the base clock.
        as_of: ``time_s`` of each pad's last event (None where the log has none).
        predictor: The predictor's name.
    """

    vehicles: tuple[str, ...]
    age: F64
    mean: F64
    lower: F64
    upper: F64
    volume: F64
    wear_coeff: F64
    as_of: tuple[float | None, ...]
    predictor: str

    @property
    def n(self) -> int:
        return len(self.vehicles)


def of_estimate(
    est: RULEstimate, age: F64, base: WearModel, names: Sequence[str], **kw: object
) -> VehicleEstimates:
    """Estimates from a predictor's :class:`RULEstimate` (one row per pad) and the pads'
    ages, on the base mix's clock ``base``."""
    mean = np.maximum(np.asarray(est.rul_mean, dtype=np.float64), 1.0)
    lower = mean if est.rul_lower is None else np.asarray(est.rul_lower, dtype=np.float64)
    upper = mean if est.rul_upper is None else np.asarray(est.rul_upper, dtype=np.float64)
    bad = np.flatnonzero(~np.isfinite(mean) | ~np.isfinite(lower) | ~np.isfinite(upper))
    if bad.size:
        raise ValueError(f"the model gave no finite RUL for pad {names[int(bad[0])]!r}")
    vol = volume_estimate(est, age, base)
    k = (base.life_work - base.work_at_volume(vol)) / mean
    as_of = kw.pop("as_of", (None,) * len(names))
    return VehicleEstimates(
        tuple(names), np.asarray(age, dtype=np.float64), mean,
        np.clip(lower, 1.0, mean), np.maximum(upper, mean), vol, k,
        tuple(as_of),  # type: ignore[arg-type]
        str(kw.pop("predictor", "?")),
    )  # fmt: skip


def from_log(
    model_dir: str | Path, log_path: str | Path, atlas_path: str | None, cache_dir: str | None
) -> tuple[VehicleEstimates, Atlas]:
    """Each pad of the log (one ``run_id`` per vehicle, in order of first appearance) run
    through the saved model; the model's atlas (checked against ``atlas_path`` if given)."""
    header = read_header(model_dir)
    if atlas_path:
        atlas = read_atlas(atlas_path)
        check_atlas(header, atlas.content_hash, model_dir)
    else:
        atlas = model_atlas(header, cache_dir)
    log = read_event_log(log_path)
    runs = list(iter_runs(log))
    if not runs:
        raise ValueError(f"--log {log_path}: no pads")
    pred = load_predictor(model_dir, atlas)
    ests = predict_runs(pred, [ev for _, ev in runs])

    def at_end(f: str) -> F64 | None:
        if getattr(ests[0], f) is None:
            return None
        return np.array([float(getattr(e, f)[-1]) for e in ests])

    mean = at_end("rul_mean")
    assert mean is not None  # every predictor gives its RUL
    last = RULEstimate(
        mean,
        at_end("rul_lower"),
        at_end("rul_upper"),
        volume_frac=at_end("volume_frac"),
        wear_coeff=at_end("wear_coeff"),
    )
    age = np.array([float(ev.event[-1]) + 1.0 for _, ev in runs])
    stamps = _last_times(log)
    names = [str(r) for r, _ in runs]
    base = duty_clocks(atlas).base
    return of_estimate(last, age, base, names, as_of=[stamps.get(n) for n in names],
                       predictor=pred.name), atlas  # fmt: skip


def _last_times(log: pd.DataFrame) -> dict[str, float]:
    t = last_times(log)
    return {str(k): float(v) for k, v in t.items() if np.isfinite(v)}


def rul_quantiles(est: VehicleEstimates, u: F64) -> F64:
    """RUL at probability ``u`` (vehicles, ...) of each pad's lognormal through its interval
    (its median the interval's geometric centre)."""
    mu, sigma = lognormal(est.lower, est.upper, LEVEL)
    return np.exp(mu[:, None] + sigma[:, None] * norm.ppf(np.asarray(u)))


def p_fail_within(est: VehicleEstimates, events: F64) -> F64:
    """Probability that each pad fails within ``events`` base-mix events (the lognormal
    :func:`~brake_env.prognostics.planner_units.p_fail_before` reads ``predict``'s with)."""
    return p_fail_before(est.lower, est.upper, events, LEVEL)


def state_of(
    est: VehicleEstimates, config: FleetConfig, shift: int, shop: dict[str, object]
) -> FleetState:
    """The fleet's state at ``shift``: each pad at its estimated volume and K (a pad is
    where its predictor says), the shop as ``shop`` gives it (``stock``, ``transit``,
    ``down``)."""
    n = config.n_vehicles
    if est.n != n:
        raise ValueError(f"the log has {est.n} pads in service and the fleet {n} vehicles:"
                         " give one run_id per vehicle")  # fmt: skip
    down = np.asarray(shop.get("down", np.zeros(n, dtype=np.int64)), dtype=np.int64)
    return FleetState(
        shift=shift, wear_coeff=est.wear_coeff.copy(), regime=("id",) * n,
        pad_age=np.round(est.age).astype(np.int64), volume_frac=est.volume.copy(),
        stock=int(shop.get("stock", config.initial_stock)),  # type: ignore[call-overload]
        transit=np.asarray(shop.get("transit", np.zeros(0)), dtype=np.int64), down=down,
        failed_down=np.zeros(n, bool), waiting=np.zeros(n, bool),
    )  # fmt: skip


def sampled_truth(
    state: FleetState, est: VehicleEstimates, base: WearModel, rng: np.random.Generator
) -> FleetState:
    """One possible truth: each pad's base-mix RUL drawn from its lognormal, at the
    estimated volume (the K that gives it), within what the atlas resolves."""
    rul = rul_quantiles(est, rng.random(est.n)[:, None])[:, 0]
    k = (base.life_work - base.work_at_volume(est.volume)) / np.maximum(rul, 1.0)
    k = np.clip(k, 0.2 * est.wear_coeff.min(), 5.0 * est.wear_coeff.max())
    return FleetState(**{**state.__dict__, "wear_coeff": k})
