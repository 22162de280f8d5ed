"""The bound split by term: the terms add up to the bound on toy and real models at any
prices, and an episode's terms add up to its net cost."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from agents.fleet.evaluation.costs import run_episodes
from agents.fleet.evaluation.gap_terms import TERMS, bound_terms, episode_terms
from agents.fleet.policies.lagrangian import BoundModel, Prices, bound, solve, start_counts
from agents.fleet.policies.lagrangian_search import occupation
from agents.fleet.policies.rules import FleetRule, FleetRuleParams
from agents.fleet.policies.view import FleetLayout
from brake_env.env.fleet.config import SMALL_FLEET, FleetConfig
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.wrappers import ExpectedRULObservation
from tests.agents.fleet.policies.test_lagrangian import random_prices, toy


@pytest.mark.parametrize("orders", [0.0, 7.0])
@pytest.mark.parametrize(("n", "T", "h0"), [(2, 6, (1, 3)), (3, 5, (0, 1, 5))])
def test_the_terms_add_up_to_the_bound_at_any_prices(n, T, h0, orders):
    m = dataclasses.replace(toy(n, T), order_share=orders, credit=3.0)
    start = start_counts(m, np.array(h0))
    rng = np.random.default_rng(1)
    for prices in [Prices.zeros(m.config), *(random_prices(m, rng) for _ in range(4))]:
        prog = solve(m, prices)
        terms = bound_terms(m, prog, prices, start)
        per = n * T
        assert list(terms) == list(TERMS)
        assert sum(terms.values()) == pytest.approx(bound(m, prog, prices, start) / per, abs=1e-9)
        occ = occupation(m, prog, start)
        assert terms["damage"] == pytest.approx(occ.failures.sum() * m.config.costs.damage / per)
        assert occ.end.sum() == pytest.approx(n)  # every vehicle is somewhere at the end
        if not np.any(prices.hot) and not np.any(prices.work) and not np.any(prices.bay) and \
                not np.any(prices.crew):  # fmt: skip
            assert terms["shortfall"] == 0.0


def test_a_spent_pad_s_terms_by_hand():
    # one vehicle, its pad spent (h = 0 < 2 units a hot shift), a hot need at every shift
    # but the window (shift 2), priced at the shortfall cost: shift 0 it is fitted on a shop
    # visit (fit 1000 + visit 1500, the need unmet: 2000) rather than fail (damage 5000);
    # it drives shifts 1 and 3; at the window the new pad of 1.5 hot shifts (probability
    # 0.3) has 1 unit left and is fitted again, the one of 2.5 is kept
    m = toy(1, 4, hot_need=1, mild_need=0, bays=1, breakdown_rate=0.0)
    c = m.config
    prices = Prices(np.full(4, c.costs.shortfall), np.zeros(4), np.zeros(4), np.zeros(4))
    prices = prices.project(c)
    start = start_counts(m, np.array([0]))
    terms = bound_terms(m, solve(m, prices), prices, start)
    fit = c.costs.pad + c.costs.labour
    assert terms["fits"] == pytest.approx((1 + 0.3) * fit / 4)
    assert terms["shop_visit"] == pytest.approx(c.costs.shop_visit / 4)
    assert terms["shortfall"] == pytest.approx(c.costs.shortfall / 4)
    assert terms["damage"] == terms["downtime"] == terms["orders"] == terms["credit"] == 0.0


def test_the_real_bound_with_credit_and_orders_adds_up(atlas):
    cfg = FleetConfig(**SMALL_FLEET, episode_shifts=60)
    env = BrakeWearFleetEnv(cfg, atlas=atlas)
    m = BoundModel.build(cfg, atlas, units=10, credit=True, orders=True)
    env.reset(seed=0)
    tr = env.truth()
    start = start_counts(m, m.state(tr["volume_frac"], tr["wear_coeff"]))
    rng = np.random.default_rng(0)
    for prices in (Prices.zeros(cfg), random_prices(m, rng)):
        prog = solve(m, prices)
        terms = bound_terms(m, prog, prices, start)
        whole = bound(m, prog, prices, start) / (cfg.n_vehicles * cfg.episode_shifts)
        assert sum(terms.values()) == pytest.approx(whole, rel=1e-9)
        assert terms["credit"] < 0 and terms["fits"] >= 0 and terms["orders"] >= -cfg.initial_stock


def test_an_episode_s_terms_add_up_to_its_net_cost(atlas):
    cfg = FleetConfig(**SMALL_FLEET, episode_shifts=40)
    env = ExpectedRULObservation(BrakeWearFleetEnv(cfg, atlas=atlas))
    (ep,) = run_episodes(env, FleetRule(FleetLayout.of(cfg), FleetRuleParams()), [3])
    terms = episode_terms(ep)
    assert list(terms) == list(TERMS)
    assert sum(terms.values()) == pytest.approx(ep.net, rel=1e-12)
    assert terms["credit"] == pytest.approx(-ep.life_value / (ep.vehicles * ep.shifts))
