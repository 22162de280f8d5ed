"""The twin's difference-array filter and its fleet against the twin's original algorithm.

``FrozenTwin`` is the twin as it was before the fleet (every event's log-likelihood scattered
over the whole K grid, the posterior and its summary at every event), kept here verbatim so
that ``DigitalTwin.update`` and ``TwinFleet`` are held to it: equal to 1e-9 relative.
"""

from __future__ import annotations

import itertools
import json
import math
from statistics import NormalDist

import numpy as np
import pytest
from numpy.typing import NDArray

from brake_env.data.datasets import Dataset
from brake_env.model.atlas import Atlas
from brake_env.model.wear import WearModel
from brake_env.prognostics.fleet import ESTIMATE_FIELDS
from brake_env.prognostics.protocol import EventBatch, RULEstimate, iter_runs
from tests.twin.conftest import TEST_CONFIG
from twin import DigitalTwin, TwinCalibration, TwinConfig
from twin.fleet import TAKE_IN_ROWS

F64 = NDArray[np.float64]
RTOL = 1e-9


class FrozenTwin:
    """The original filter: a grid log-likelihood carried over the whole grid per event."""

    def __init__(self, atlas: Atlas, config: TwinConfig, cal: TwinCalibration) -> None:
        self.atlas, self.config, self.cal = atlas, config, cal
        self.wear = WearModel.from_atlas(atlas)
        self._z = NormalDist().inv_cdf(0.95)
        n = config.n_grid
        self._log_k0 = cal.k_log_mean - math.log(config.grid_factor)
        self._dlog = 2.0 * math.log(config.grid_factor) / (n - 1)
        log_k = self._log_k0 + self._dlog * np.arange(n)
        self.k_grid = np.exp(log_k)
        self._life = self.wear.life(self.k_grid)
        self._life_std = self.wear.life_std(self.k_grid)
        z = (log_k - cal.k_log_mean) / cal.k_log_scale
        nu = cal.prior_dof
        core = -0.5 * z**2 if math.isinf(nu) else -0.5 * (nu + 1.0) * np.log1p(z**2 / nu)
        p = np.exp(core - core.max())
        broad = np.exp(-0.5 * ((log_k - cal.k_log_mean) / config.outlier_log_std) ** 2)
        p = (
            1.0 - config.outlier_weight
        ) * p / p.sum() + config.outlier_weight * broad / broad.sum()
        self._log_prior = np.log(p)
        self._log_edges = np.log(self.wear.work_edges[:-1])
        self._loglik = np.zeros(n)

    def update(self, ev: EventBatch) -> RULEstimate:
        step = self.config.chunk_events
        parts = [self._chunk(ev[i : i + step]) for i in range(0, len(ev), step)]
        return RULEstimate(*[np.concatenate(c) for c in zip(*parts, strict=True)])

    def _chunk(self, ev: EventBatch) -> tuple[F64, ...]:
        ll = self._layer_loglik(ev)
        post, n_after, tail, over = self._grid_posterior(ev, ll)
        return self._prognosis(post, n_after, tail, over)

    def _layer_loglik(self, ev: EventBatch) -> F64:
        cal = self.cal
        s, m, th, temp = ev.speed_kmh / 3.6, ev.mass_kg, ev.slope_rad, ev.temp_c
        ok = np.isfinite(s) & np.isfinite(m) & np.isfinite(th) & np.isfinite(temp)
        if not ok.all():
            s, m, th, temp = (np.where(ok, x, 0.0) for x in (s, m, th, temp))
        t_atlas, dt_dslope = self.atlas.lookup.profile(s, m, th)
        var = cal.temp_sigma_c**2 + (dt_dslope * cal.slope_sigma_rad) ** 2
        r = (temp - cal.temp_bias_c)[:, None] - t_atlas
        ll = -0.5 * (r * r / var + np.log(var))
        ll -= ll.max(axis=1, keepdims=True)
        ll[~ok] = 0.0
        return ll

    def _grid_posterior(self, ev: EventBatch, ll: F64) -> tuple[F64, F64, int, F64]:
        n, n_k = len(ev), self.config.n_grid
        k_before = ev.event.astype(np.float64)
        with np.errstate(divide="ignore"):
            x = (self._log_edges[None, :] - np.log(k_before)[:, None] - self._log_k0) / self._dlog
        first = np.clip(np.ceil(x), 0, n_k).astype(np.intp)
        rows = np.arange(n, dtype=np.intp)[:, None] * (n_k + 1)
        jumps = np.bincount(
            (rows + first).ravel(),
            weights=(ll[:, 1:] - ll[:, :-1]).ravel(),
            minlength=n * (n_k + 1),
        ).astype(np.float64, copy=False)
        grid_ll = np.cumsum(jumps.reshape(n, n_k + 1)[:, :n_k], axis=1)
        grid_ll += ll[:, :1]
        grid_ll[0] += self._loglik
        acc = np.cumsum(grid_ll, axis=0)
        self._loglik = acc[-1].copy()
        post = acc
        post += self._log_prior
        n_after = k_before + 1.0
        last = float(n_after[-1])
        tail = int(np.searchsorted(-self._life, -(last + 8.0 * self._life_std.max())))
        over = np.maximum(n_after[:, None] - self._life[None, tail:], 0.0)
        if tail < n_k:
            post[:, tail:] -= 0.5 * (over / self._life_std[tail:]) ** 2
        return post, n_after, tail, over

    def _prognosis(self, post: F64, n_after: F64, tail: int, over: F64) -> tuple[F64, ...]:
        n_k = self.config.n_grid
        post -= post.max(axis=1, keepdims=True)
        w = np.exp(post, out=post)
        z = w.sum(axis=1)
        k_mean = (w @ self.k_grid) / z
        rul = (w @ self._life) / z - n_after
        if tail < n_k:
            rul += (w[:, tail:] * over).sum(axis=1) / z
        cdf = np.cumsum(w, axis=1)
        life_lo, life_med, life_hi = (
            self.wear.life(np.exp(self._log_quantile(cdf, w, z, p))) for p in (0.05, 0.5, 0.95)
        )
        if self.config.point_estimate == "median":
            rul = np.maximum(life_med - n_after, 0.0)
        spread = self._z * self.wear.life_std(k_mean)
        lower = np.maximum(life_hi - n_after - spread, 0.0)
        upper = np.maximum(life_lo - n_after, 0.0) + spread
        volume = self.wear.volume_at_work(k_mean * n_after)
        return rul, lower, upper, volume, k_mean

    def _log_quantile(self, cdf: F64, w: F64, z: F64, p: float) -> F64:
        n_k = cdf.shape[1]
        target = p * z
        i = np.minimum((cdf < target[:, None]).sum(axis=1), n_k - 1)
        rows = np.arange(len(i))
        w_i = w[rows, i]
        frac = np.clip((target - (cdf[rows, i] - w_i)) / np.maximum(w_i, 1e-300), 0.0, 1.0)
        return self._log_k0 + self._dlog * (i - 0.5 + frac)


def assert_same(got: RULEstimate, want: RULEstimate) -> None:
    for f in ESTIMATE_FIELDS:
        np.testing.assert_allclose(getattr(got, f), getattr(want, f), rtol=RTOL, atol=0, err_msg=f)


def _segments(dataset: Dataset) -> list[EventBatch]:
    """Pieces of pads the filter must get right: from installation, from mid-life (no
    evidence of the unlogged events) and a late start that reaches failure, where the
    survival term rules out the K whose life is over."""
    (_, a), (_, b) = list(iter_runs(dataset.logs["id"]))[:2]
    ((_, fast),) = iter_runs(dataset.logs["ood"])
    n = len(fast)
    return [a[:6000], b[40_000:46_000], fast[n - 7000 :]]


@pytest.mark.parametrize("point", ["mean", "median"])
def test_update_equals_the_original_algorithm(
    atlas: Atlas, dataset: Dataset, fitted: DigitalTwin, point: str
) -> None:
    assert fitted.calibration is not None
    cfg = TwinConfig(n_grid=TEST_CONFIG.n_grid, point_estimate=point, chunk_events=300)
    twin = DigitalTwin(atlas, cfg, calibration=fitted.calibration)
    rng = np.random.default_rng(0)
    for ev in _segments(dataset):
        want = FrozenTwin(atlas, cfg, fitted.calibration).update(ev)
        twin.reset()
        cuts = np.unique(np.r_[0, rng.integers(1, len(ev), 6), len(ev)])
        parts = [twin.update(ev[int(a) : int(b)]) for a, b in itertools.pairwise(cuts)]
        got = RULEstimate(
            *(np.concatenate([getattr(p, f) for p in parts]) for f in ESTIMATE_FIELDS)
        )
        assert_same(got, want)
    # The late segment reaches the end of its life: the survival term was in play.
    assert want.rul_mean[-1] < 0.01 * want.rul_mean[0]


def test_fleet_equals_single_pad_updates(
    atlas: Atlas, dataset: Dataset, fitted: DigitalTwin
) -> None:
    """Several pads interleaved, batches of random sizes, estimates at random rows."""
    segs = _segments(dataset)
    fleet = fitted.fleet(len(segs) + 1)  # slot 0 stays empty
    want = []
    for ev in segs:
        fitted.reset()
        want.append(fitted.update(ev))
    rng = np.random.default_rng(1)
    pos = [0] * len(segs)
    while any(p < len(s) for p, s in zip(pos, segs, strict=True)):
        pads, parts, rows = [], [], []
        for i in rng.permutation(len(segs)):
            if pos[i] >= len(segs[i]) or rng.random() < 0.3:
                continue  # this pad sits this call out
            n = int(rng.choice([1, 7, 300, 1500]))
            parts.append(segs[i][pos[i] : pos[i] + n])
            pads.append(np.full(len(parts[-1]), i + 1))
            rows.append(np.arange(pos[i], pos[i] + len(parts[-1])))
            pos[i] += len(parts[-1])
        if not parts:
            continue
        p = np.concatenate(pads)
        ev = _concat(parts)
        mode = rng.integers(3)
        ask = None if mode == 0 else (rng.random(len(p)) < (0.02 if mode == 1 else 0.9))
        est = fleet.update(p, ev, ask)
        mask = _last_of_runs(p) if ask is None else ask
        r = np.concatenate(rows)[mask]
        for i in range(len(segs)):
            sel = p[mask] == i + 1
            expect = RULEstimate(*(getattr(want[i], f)[r[sel]] for f in ESTIMATE_FIELDS))
            got = RULEstimate(*(getattr(est, f)[sel] for f in ESTIMATE_FIELDS))
            assert_same(got, expect)


def test_fleet_takes_in_a_cost_study_call(
    atlas: Atlas, dataset: Dataset, fitted: DigitalTwin
) -> None:
    """A cost study's call: every pad's whole segment at once, an estimate every 500 events,
    so each round's rows (every pad's next 500 events, more than a read-out chunk) are taken
    in on the whole grid in one block: the estimates of single-pad updates."""
    segs = _segments(dataset)
    fleet = fitted.fleet(len(segs))
    p = np.concatenate([np.full(len(s), i) for i, s in enumerate(segs)])
    ask = np.concatenate([np.arange(len(s)) % 500 == 499 for s in segs])
    assert fitted.config.chunk_events < len(segs) * 500 <= TAKE_IN_ROWS
    est = fleet.update(p, _concat(segs), ask)
    at = [np.flatnonzero(np.arange(len(s)) % 500 == 499) for s in segs]
    for i, ev in enumerate(segs):
        fitted.reset()
        one = fitted.update(ev)
        sel = p[ask] == i
        expect = RULEstimate(*(getattr(one, f)[at[i]] for f in ESTIMATE_FIELDS))
        assert_same(RULEstimate(*(getattr(est, f)[sel] for f in ESTIMATE_FIELDS)), expect)


def test_fleet_slot_reset_installs_a_new_pad(dataset: Dataset, fitted: DigitalTwin) -> None:
    (_, a), (_, b) = list(iter_runs(dataset.logs["id"]))[:2]
    fleet = fitted.fleet(2)
    fleet.update(np.zeros(3000, dtype=np.intp), a[:3000])
    fleet.reset([0])
    est = fleet.update(np.zeros(2000, dtype=np.intp), b[:2000], np.ones(2000, dtype=bool))
    fitted.reset()
    assert_same(est, fitted.update(b[:2000]))


def test_fleet_refuses_bad_calls(dataset: Dataset, fitted: DigitalTwin) -> None:
    _, a = next(iter_runs(dataset.logs["id"]))
    fleet = fitted.fleet(2)
    with pytest.raises(ValueError, match="n_pads must be >= 1"):
        fitted.fleet(0)
    with pytest.raises(ValueError, match=r"slots must be in \[0, 2\)"):
        fleet.update(np.array([2, 2]), a[:2])
    with pytest.raises(ValueError, match="3 slots for 2 events"):
        fleet.update(np.array([0, 0, 0]), a[:2])
    with pytest.raises(ValueError, match="contiguous"):
        fleet.update(np.array([0, 1, 0]), _concat([a[:1], a[:1], a[1:2]]))
    with pytest.raises(ValueError, match="summarise has 1 rows"):
        fleet.update(np.array([0, 0]), a[:2], np.array([True]))
    fleet.update(np.array([1, 1]), a[10:12])  # a pad may start mid-life
    with pytest.raises(ValueError, match="slot 1's batch starts at event 5, expected >= 12"):
        fleet.update(np.array([1]), a[5:6])  # a gap is allowed (tests/twin/test_gaps.py)
    with pytest.raises(RuntimeError, match="call fit"):
        DigitalTwin(fitted.atlas, TEST_CONFIG).fleet(2)


def test_state_round_trips_through_json(
    atlas: Atlas, dataset: Dataset, fitted: DigitalTwin
) -> None:
    meta, arrays = fitted.get_state()
    assert arrays == {}
    meta = json.loads(json.dumps(meta, allow_nan=False))
    other = DigitalTwin(atlas)  # the registry's default config: set_state restores it
    other.set_state(meta, {})
    assert other.config == fitted.config and other.calibration == fitted.calibration
    _, ev = next(iter_runs(dataset.logs["ood"]))
    fitted.reset()
    want = fitted.update(ev[:3000])
    for f in ESTIMATE_FIELDS:
        assert np.array_equal(getattr(other.update(ev[:3000]), f), getattr(want, f))
        other.reset()
    # A hand-set calibration keeps its Gaussian prior (inf degrees of freedom).
    gauss = TwinCalibration(k_log_mean=math.log(2e-6), k_log_scale=0.1)
    meta, _ = DigitalTwin(atlas, TEST_CONFIG, calibration=gauss).get_state()
    other.set_state(json.loads(json.dumps(meta, allow_nan=False)), {})
    assert other.calibration == gauss and math.isinf(other.calibration.prior_dof)
    with pytest.raises(ValueError, match=r"TwinConfig.*unknown \['n_grd'\]"):
        other.set_state({"config": {"n_grd": 10}, "calibration": None}, {})


def _concat(parts: list[EventBatch]) -> EventBatch:
    keys = ("event", "speed_kmh", "mass_kg", "slope_rad", "energy_j", "temp_c", "stop_dist_m")
    return EventBatch.from_arrays({k: np.concatenate([getattr(p, k) for p in parts]) for k in keys})


def _last_of_runs(p: NDArray[np.intp]) -> NDArray[np.bool_]:
    return np.r_[p[1:] != p[:-1], True]


def test_a_pad_past_every_likely_life_has_rul_zero_inside_its_interval(
    fitted: DigitalTwin,
) -> None:
    """When the posterior weighs only K whose life is over, the mean RUL is 0, not a
    rounding error below it (it came out -1.5e-11 with lower bound 0 in a fleet study, and
    the fleet wrapper refused the inverted interval), and the interval holds it."""
    g = fitted.fleet(1).grid
    rng = np.random.default_rng(0)
    m = 40  # the posterior on the 40 largest K (shortest lives); the others weigh 0
    post = np.full((200, g.log_prior.size), -1e4)
    post[:, -m:] = rng.normal(0.0, 2.0, (200, m))
    n_after = rng.uniform(g.life[-m], g.life[-m - 1], 200)  # past each of those lives
    rul, lower, upper, _, _ = g.summarise(post, 0, n_after)
    assert (rul >= 0.0).all() and (rul < 1e-6).all()  # 0 up to rounding, never below
    assert (lower <= rul).all() and (rul <= upper).all()


def test_the_interval_holds_the_mean_on_any_posterior(fitted: DigitalTwin) -> None:
    """The mean weighs the life table at the grid points, the interval interpolates K's
    quantiles inside the grid cells: on a posterior peaked between a few points (physics the
    pads do not follow: the nominal twin on heat-partition pads in a fleet study) the mean
    fell above the upper bound (297,588 against 293,920), and the fleet wrapper refused the
    interval. The interval is widened to hold the mean."""
    g = fitted.fleet(1).grid
    rng = np.random.default_rng(0)
    n = g.log_prior.size
    for _ in range(40):
        lo, width = int(rng.integers(0, n - 50)), int(rng.integers(2, 60))
        post = rng.normal(0.0, rng.uniform(0.1, 30.0), (50, width))
        n_after = rng.uniform(0.0, g.life[lo], 50)
        rul, lower, upper, _, _ = g.summarise(post.copy(), lo, n_after)
        assert (lower <= rul).all() and (rul <= upper).all()
