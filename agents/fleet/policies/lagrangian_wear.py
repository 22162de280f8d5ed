"""The wear clock of the Lagrangian bound's per-vehicle model (:mod:`.lagrangian`), built so
that the model's pad never wears faster than the env's: the new pads' life distribution, a
mild shift's wear by the pad's layer, and the slack that covers the realised wear's spread.

**Mild wear by layer.** On the hot-RUL clock (units of ``1 / units`` hot shift) a mild shift
in atlas layer ``j`` uses ``units * r_j`` units, ``r_j`` the mild route's expected wear per
event over the hot route's there (0.212 on a new pad, 0.150 on the last layer: it falls as
the pad thins). At a state ``h`` the layer depends on K too (the remaining work is ``K * h``
events' worth), deepest for the least K. So a cut ``k_cut`` splits the pads: one with
``K >= k_cut`` at state ``h`` is charged ``floor(units * r)``, ``r`` the least ratio of the
layers down to the deepest a pad of K ``k_cut`` reaches in a mild shift from ``h - 1`` (a
pad of more K is shallower: never more than its own use), kept so that ``h - use(h)`` never
falls as ``h`` grows (a pad with more life is never left with less); a pad with
``K < k_cut`` (``P(K < k_cut)``, 0.13% at the default cut of 3 sd) enters the model with its
life times ``boost = floor(units * r_max) / (units * r_min)`` (1.33), so that any sequence
of shifts it survives (at least ``r_min`` a mild shift) the model's pad survives too. Both
are relaxations for every ``k_cut``; the cut only moves how tight the bound is.

**Wear's spread.** The env's pad wears a random amount per shift (400 events of random
conditions); the model's wears its expectation. A pad whose realised wear runs behind its
expectation could outlive the model's pad. :func:`pads_ahead` simulates new pads on the
env's own pad code (:class:`~brake_env.env.fleet.pads.FleetPads`, the hot route to failure,
K from the config's regime) and takes the most each is ever ahead of its expected path [hot
shifts]; :func:`realised_slack` is its ``coverage`` quantile: a share ``coverage`` of pads
(estimated on ``pads`` simulated ones) never outruns that slack, and for them the model's
pad dominates the env's on every path. The mild route's spread (0.14 hot shifts' sd over
300 mild shifts against the hot route's 0.21 over 100 hot ones) is smaller and covered by
the same slack (``benchmarks/analysis/fleet_bound_relaxation.py``).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.integrate import quad
from scipy.optimize import brentq
from scipy.stats import norm

from agents.fleet.policies.checks import real, whole
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.pads import FleetPads
from brake_env.env.fleet.routes import HOT, MILD, ROUTE_INDEX, route_mean, route_wear_model
from brake_env.model.atlas import Atlas
from brake_env.model.wear import WearModel

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]


def mild_ratios(atlas: Atlas) -> F64:
    """Each layer's mild wear per event over the hot route's [-]."""
    return np.asarray(route_mean(atlas, MILD) / route_mean(atlas, HOT), dtype=np.float64)


def mild_use(
    wear: WearModel, ratios: F64, units: int, H: int, k_cut: float, unit_events: float
) -> I64:
    """Units a mild shift uses from each state 0..H for pads of K >= ``k_cut`` (module
    docstring): at most the expected use of any such pad at hot RUL ``h - 1`` or more."""
    least_above = np.minimum.accumulate(ratios)  # least r of layer j and those above it
    x = np.arange(H + 1, dtype=np.float64) - 1.0
    deepest = np.maximum(x - units * float(ratios.max()), 0.0)  # RUL at the shift's end
    layer = wear.layer_at_work(wear.life_work - k_cut * deepest * unit_events)
    use = np.floor(units * least_above[layer] + 1e-9).astype(np.int64)
    for h in range(1, H + 1):  # h - use(h) non-decreasing: one unit more life, never less
        use[h] = min(use[h], use[h - 1] + 1)
    return use


def k_components(config: FleetConfig) -> list[tuple[float, float]]:
    """(share, mean) of each normal law in a new pad's K under the config's regime (the
    env's :meth:`~brake_env.env.config.PadRegime.draw`: ``id``, or an OOD pad, slow or
    fast with even odds); each is truncated at 0 (a draw <= 0 is drawn again)."""
    return config.pad_regime.components()


def k_cdf(config: FleetConfig, k: F64 | float) -> F64:
    """P(a new pad's K <= k) under the config's regime (:func:`k_components`)."""
    out = np.zeros(np.shape(k))
    for share, mean in k_components(config):
        below0 = float(norm.cdf(0.0, mean, config.k_std))
        if below0 < 1e-15:  # the id regime's ~1e-23: the plain normal, as it always was
            out = out + share * norm.cdf(k, mean, config.k_std)
        else:
            out = out + share * np.maximum(norm.cdf(k, mean, config.k_std) - below0, 0.0) / (
                1.0 - below0
            )
    return np.asarray(out, dtype=np.float64)


def k_floor(config: FleetConfig, share: float) -> float:
    """The K below which a share ``share`` of new pads lies (0 for ``share`` 0)."""
    if share <= 0.0:
        return 0.0
    hi = config.k_mean
    while float(k_cdf(config, hi)) < share:
        hi *= 2.0
    return float(brentq(lambda k: float(k_cdf(config, k)) - share, 0.0, hi, xtol=1e-30))


def new_pad_prob(
    wear: WearModel, config: FleetConfig, unit_events: float, H: int, k_cut: float = 0.0,
    boost: float = 1.0,
) -> F64:  # fmt: skip
    """P(a new pad's state is h), h = 0..H, under the config's law of K (:func:`k_cdf`):
    the state is ``ceil(life(K) / unit_events)`` (times ``boost`` for ``K < k_cut``),
    capped at H."""
    j = np.arange(H + 1, dtype=np.float64)
    L = wear.life_work / unit_events  # life in units = L / K
    F = lambda k: k_cdf(config, k)  # noqa: E731
    prob = np.zeros(H + 1)
    with np.errstate(divide="ignore"):
        for lo, hi, scale in ((k_cut, np.inf, 1.0), (0.0, k_cut, boost)):
            if hi <= lo:
                continue
            # state j <=> scale * L / j <= K < scale * L / (j - 1), within [lo, hi)
            top = np.minimum(scale * L / np.maximum(j - 1, 0), hi)
            bottom = np.maximum(scale * L / j, lo)
            prob[1:] += np.maximum(F(top[1:]) - F(bottom[1:]), 0.0)
            prob[H] += max(float(F(min(scale * L / H, hi))) - float(F(lo)), 0.0)  # beyond the cap
    return prob / prob.sum()  # (drops P(K <= 0) ~ 1e-23 in the id regime: no pad has it)


def new_pad_tail(
    wear: WearModel, config: FleetConfig, unit_events: float, cap: int, floor: float
) -> float:
    """At least the expected units of a new pad's state beyond ``cap`` (its state
    ``ceil(L / K)`` in units, K taken as ``floor`` where it is less):
    ``E[(L / K - cap)+] + P(L / K > cap)``, the ceiling's unit or less added to each pad
    beyond the cap. The per-vehicle program, capped at ``cap``, credits it at each fit
    (:class:`~.lagrangian.BoundModel`'s ``new_tail``)."""
    if floor <= 0:
        raise ValueError(f"new_pad_tail: floor must be > 0 (without one a slow pad's expected"
                         f" life may have no finite mean), got {floor}")  # fmt: skip
    L = wear.life_work / unit_events
    top = L / cap  # K below it: a state beyond the cap
    if floor >= top:
        return 0.0
    total = 0.0
    for share, mean in k_components(config):
        below0 = float(norm.cdf(0.0, mean, config.k_std))

        # over u = log K the integrand (L / K - cap) pdf(K) dK is (L - cap K) pdf(K) du: smooth
        def body(u: float, m: float = mean, b: float = below0) -> float:
            k = float(np.exp(u))
            return (L - cap * k) * float(norm.pdf(k, m, config.k_std)) / (1.0 - b)

        part, _ = quad(body, np.log(floor), np.log(top), limit=200, epsabs=0.0, epsrel=1e-10)
        total += share * part
    at_floor = float(k_cdf(config, floor)) * (L / floor - cap)
    return total + at_floor + float(k_cdf(config, top))  # at_floor: those taken as K = floor


def pads_ahead(atlas: Atlas, config: FleetConfig, pads: int = 256, seed: int = 0) -> F64:
    """The most each of ``pads`` new pads, run on the hot route to failure, is ever ahead of
    its expected wear path [hot shifts] (module docstring)."""
    pads = whole("pads_ahead", "pads", pads, 1)
    wear, eps = route_wear_model(atlas, HOT), config.events_per_shift
    sim = FleetPads(atlas, pads, config.noise, max(4 * eps, 4096))
    rng = np.random.default_rng(seed)
    k = config.wear.draw(rng, "id", pads)
    labels = ["id"] * pads
    if config.regime != "id":  # the regime's law (the id draw above kept as it was)
        for v in range(pads):
            k[v], labels[v] = config.pad_regime.draw(rng)
    for v in range(pads):
        sim.install(v, float(k[v]), labels[v], int(rng.integers(2**63)))
    life = wear.life(k)  # expected events to failure
    ahead = np.full(pads, -np.inf)
    hot = np.full(pads, ROUTE_INDEX["hot"])
    # a pad is in an episode at most its shifts: a slower one's later lead is never used
    for _ in range(config.episode_shifts):
        if sim.done.all():
            break
        sim.advance(np.where(sim.done, 0, eps), hot, measure=False)
        vol = np.clip(sim.vol, wear.lower_edges[-1], 1.0)
        left = np.where(sim.done, 0.0, wear.rul(vol, k))  # expected RUL from the real volume
        ahead = np.maximum(ahead, (sim.pos + left - life) / eps)  # events braked + left - life
    return ahead


def realised_slack(
    atlas: Atlas, config: FleetConfig, coverage: float = 0.99, pads: int = 256, seed: int = 0
) -> float:
    """The ``coverage`` quantile of :func:`pads_ahead` [hot shifts]: the slack that a share
    ``coverage`` of pads never outruns."""
    coverage = real("realised_slack", "coverage", coverage, 0.0)
    if coverage >= 1.0:
        raise ValueError(f"realised_slack: coverage must be in [0, 1), got {coverage}")
    return float(np.quantile(pads_ahead(atlas, config, pads, seed), coverage))


__all__ = [
    "k_cdf", "k_components", "k_floor", "mild_ratios", "mild_use", "new_pad_prob",
    "new_pad_tail", "pads_ahead", "realised_slack",
]  # fmt: skip
