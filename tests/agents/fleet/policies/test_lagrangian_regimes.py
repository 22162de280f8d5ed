"""The Lagrangian bound outside the ``id`` wear regime: the law of a new pad's K (the env's
draw), the states beyond the cap (credited exactly by a linear value), the expected units
beyond it (against the exact sum of a model whose cap holds every pad)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.stats import kstest

from agents.fleet.evaluation.gap_terms import bound_terms
from agents.fleet.policies.lagrangian import FLOOR_SHARE, BoundModel, Prices, bound, solve
from agents.fleet.policies.lagrangian_wear import k_cdf, k_floor, new_pad_prob, new_pad_tail
from agents.fleet.policies.planning import PlanningModel
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.episode_cost import credit_life
from brake_env.env.fleet.routes import HOT, route_wear_model


def test_k_law_is_the_env_s_draw():
    cfg = FleetConfig(regime="mixed", ood_share=0.5)
    rng = np.random.default_rng(3)
    k = np.array([cfg.pad_regime.draw(rng)[0] for _ in range(20_000)])
    assert kstest(k, lambda x: k_cdf(cfg, x)).statistic < 0.012
    # a wrong share of OOD pads is seen by the same test
    wrong = dataclasses.replace(cfg, ood_share=0.3)
    assert kstest(k, lambda x: k_cdf(wrong, x)).statistic > 0.03
    assert float(k_cdf(cfg, 0.0)) == pytest.approx(0.0, abs=1e-20)
    q = k_floor(cfg, FLOOR_SHARE)
    assert 0 < q < cfg.wear.mean("ood-slow")
    assert float(k_cdf(cfg, q)) == pytest.approx(FLOOR_SHARE, rel=1e-6)


def folded(prob: np.ndarray, cap: int) -> tuple[np.ndarray, float]:
    """A new-pad law cut at ``cap``: the mass beyond it at ``cap``, and its units beyond."""
    j = np.arange(prob.size)
    small = prob[: cap + 1].copy()
    small[cap] += prob[cap + 1 :].sum()
    return small, float(prob[cap + 1 :] @ (j[cap + 1 :] - cap))


@pytest.mark.parametrize("breakdown_rate", [0.0, 0.25])
def test_states_beyond_the_cap_are_credited_exactly(breakdown_rate):
    """A cap at the episode's hot units and the units beyond it credited give the same
    values and bound as a cap that holds every pad."""
    T, units = 6, 2
    cfg = FleetConfig(n_vehicles=3, episode_shifts=T, hot_need=1, mild_need=1, window_slots=1,
                      bays=1, window_period=3, breakdown_rate=breakdown_rate,
                      failure_repair_shifts=2)  # fmt: skip
    rng = np.random.default_rng(0)
    prob = rng.random(31) * (np.arange(31) >= 3)
    prob /= prob.sum()
    big = BoundModel(cfg, units=units, mild_units=1, new_prob=prob, credit=7.0)
    cap = T * units
    small_prob, tail = folded(prob, cap)
    small = dataclasses.replace(big, new_prob=small_prob, new_tail=tail)
    z = np.zeros(T)
    prices = Prices(rng.random(T) * 50, rng.random(T) * 20, rng.random(T) * 30, z).project(cfg)
    vb, vs = solve(big, prices).values, solve(small, prices).values
    np.testing.assert_allclose(vs[:, : cap + 1], vb[:, : cap + 1], rtol=0, atol=1e-9)
    start_big = np.zeros(31)
    start_big[[5, 20, 29]] = 1.0  # two pads beyond the cap
    start_small = np.zeros(cap + 1)
    start_small[5], start_small[cap] = 1.0, 2.0
    excess = (20 - cap) + (29 - cap)
    got = bound(small, solve(small, prices), prices, start_small, excess)
    assert got == pytest.approx(bound(big, solve(big, prices), prices, start_big), abs=1e-9)
    # split by the bill's groups, the credit beyond the cap is in the credit's
    terms = bound_terms(small, solve(small, prices), prices, start_small, excess)
    assert sum(terms.values()) * cfg.n_vehicles * T == pytest.approx(got, abs=1e-9)
    # without the credit beyond the cap, the capped model is dearer: not a bound
    plain = dataclasses.replace(small, new_tail=0.0)
    assert bound(plain, solve(plain, prices), prices, start_small) > got + 1.0


def test_expected_units_beyond_the_cap_cover_the_exact_sum(atlas):
    cfg = FleetConfig(regime="mixed", ood_share=0.5, ood_shift_sigma=3.0, episode_shifts=100)
    wear = route_wear_model(atlas, HOT)
    unit_events = cfg.events_per_shift  # one unit a hot shift
    cap, H = cfg.episode_shifts, 4000  # about no pad lives 4000 shifts (K 6.4 sd below)
    prob = new_pad_prob(wear, cfg, unit_events, H)
    assert prob[H] < 1e-9
    exact = folded(prob, cap)[1]
    beyond = float(prob[cap + 1 :].sum())
    got = new_pad_tail(wear, cfg, unit_events, cap, 1e-12)  # K > 0 by 7 sd: a floor of ~0
    assert exact <= got <= exact + beyond + 1e-9
    assert exact > 1.0  # slow pads do outlive the episode
    # a floor takes the slowest pads' life as the floor's: less credit, never more
    assert new_pad_tail(wear, cfg, unit_events, cap, 1e-7) < got
    with pytest.raises(ValueError, match="floor must be > 0"):
        new_pad_tail(wear, cfg, unit_events, cap, 0.0)


def test_the_mixed_model_credits_slow_pads_and_the_id_model_is_unchanged(atlas):
    mixed = FleetConfig(regime="mixed", ood_share=0.5, episode_shifts=365)
    m = BoundModel.build(mixed, atlas, credit=True)
    assert mixed.episode_shifts * m.units <= m.H  # no pad beyond the cap fails in an episode
    assert m.new_tail > 0 and m.new_prob[-1] > 0.05  # slow pads beyond the cap
    assert m.k_floor == pytest.approx(k_floor(mixed, FLOOR_SHARE))
    assert BoundModel.build(mixed, atlas).new_tail == 0.0  # no credit, nothing beyond to price
    with pytest.raises(ValueError, match="'id' regime only"):
        BoundModel.build(mixed, atlas, credit=True, layers=True)
    i = BoundModel.build(FleetConfig(), atlas, credit=True)
    assert i.new_tail == 0.0 and i.k_floor == 0.0
    k = np.full(4, FleetConfig().k_mean)
    assert i.excess(np.ones(4), k) == 0.0
    assert m.excess(np.ones(4), np.full(4, mixed.wear.mean("ood-slow") / 2)) > 0


def test_the_bound_and_the_rollout_price_the_life_left_as_the_env_s_net(atlas):
    """The bound's terminal credit per unit and the rollout's per hot shift are the net's
    price (:func:`credit_life`), in ``id`` and in ``mixed`` (BrakeWearFleet-v2)."""
    wear = route_wear_model(atlas, HOT)
    for c in (FleetConfig(), FleetConfig(regime="mixed", episode_shifts=365)):
        fit = c.costs.pad + c.costs.labour
        m = BoundModel.build(c, atlas, credit=True)
        per_event = fit / credit_life(c, wear)
        assert m.credit == pytest.approx(per_event * c.events_per_shift / m.units, rel=1e-12)
        p = PlanningModel.build(c, atlas)
        assert p.fit_cost / p.mean_life == pytest.approx(per_event * c.events_per_shift,
                                                         rel=1e-9)  # fmt: skip
