"""The Lagrangian bound (agents.fleet.policies.lagrangian, lagrangian_search) and the
price-directed policy (priced): the relaxation's inequality, the bound against brute force
with the real coupling and against the exact 2-vehicle reference, the search."""

from __future__ import annotations

import dataclasses
import functools
import itertools
import math

import numpy as np
import pytest

from agents.fleet.evaluation.costs import run_episodes
from agents.fleet.policies import reference
from agents.fleet.policies.lagrangian import (
    BoundModel,
    Prices,
    bound,
    project_needs,
    solve,
    start_counts,
)
from agents.fleet.policies.lagrangian_search import search
from agents.fleet.policies.priced import PricedPolicy
from brake_env.env.fleet.config import SMALL_FLEET, FleetConfig, FleetCosts
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.rules import shortfall_cost
from brake_env.env.fleet.shop import HOT, MILD, PARK, SERVICE


@pytest.mark.parametrize(("hot_need", "mild_need", "n"), [(1, 1, 2), (2, 1, 4), (6, 4, 12)])
def test_shortfall_is_above_its_priced_relaxation(hot_need, mild_need, n):
    cfg = FleetConfig(n_vehicles=n, hot_need=hot_need, mild_need=mild_need)
    c_h, c_m = cfg.costs.shortfall, cfg.costs.mild_shortfall
    grid = np.linspace(-0.5, 1.5, 9)
    lam, mu = (x.ravel() for x in np.meshgrid(grid * c_h, grid * c_m))
    lam, mu = project_needs(lam, mu, c_h, c_m)
    # the projection lands in the box, and the box's corners are among the prices
    assert np.all((lam >= 0) & (mu >= 0) & (mu <= c_m + 1e-9) & (lam + mu <= c_h + 1e-9))
    lam = np.concatenate([lam, [0.0, c_h, c_h - c_m, 0.0]])
    mu = np.concatenate([mu, [0.0, 0.0, c_m, c_m]])
    N_h, N_w = cfg.hot_need, cfg.hot_need + cfg.mild_need
    for on_hot in range(n + 1):
        for on_mild in range(n + 1 - on_hot):
            f = shortfall_cost(cfg, on_hot, on_mild, window=False)
            priced = lam * (N_h - on_hot) + mu * (N_w - on_hot - on_mild)
            assert np.all(f >= priced - 1e-9), (on_hot, on_mild)


def toy(n: int, T: int, **kwargs) -> BoundModel:
    """Two new-pad lives (1.5 and 2.5 hot shifts), 2 units a hot shift, 1 a mild one."""
    kw = {"hot_need": 1, "mild_need": 1, "window_slots": 1, "bays": 1, "window_period": 3,
          "breakdown_rate": 0.25, "failure_repair_shifts": 2, **kwargs}  # fmt: skip
    cfg = FleetConfig(n_vehicles=n, episode_shifts=T, **kw)
    return BoundModel(cfg, units=2, mild_units=1, new_prob=np.array([0, 0, 0, 0.3, 0, 0.7]))


def joint_outcomes(per: list[list[tuple[float, tuple, float]]]) -> list[tuple[float, tuple, float]]:
    """Each vehicle's (probability, next (h, d), cost) combined: every joint outcome's."""
    return [
        (math.prod(o[0] for o in combo), tuple(o[1] for o in combo), sum(o[2] for o in combo))
        for combo in itertools.product(*per)
    ]


def brute_force(m: BoundModel, h0: tuple[int, ...], stock: int | None = None) -> float:
    """The exact joint optimum on the same per-vehicle model with the real coupling (the
    shortfall cost, the bays after the vehicles down, the window's slots), by recursion
    over (t, every vehicle's (h, d)); written apart from the module. With ``stock`` the
    spares are real too: a service takes a pad from stock, and each shift may order up to
    ``max_order`` pads at ``order`` (arriving at once, no holding cost: an easier problem
    than the env's, whose lead time and holding only add cost; failures' pads are free)."""
    c = m.config
    p, R, F = c.breakdown_rate, c.breakdown_repair_shifts, c.failure_repair_shifts
    new = [(float(w), j) for j, w in enumerate(m.new_prob) if w > 0]

    @functools.cache
    def moves(t: int, h: int, d: int, a: int, window: bool) -> list[tuple[float, tuple, float]]:
        nd = max(d - 1, 0)
        if a == PARK:
            return [(1.0, (h, nd), 0.0)]
        if a == SERVICE:
            visit = 0.0 if (window or d > 0) else c.costs.shop_visit
            return [(w, (j, nd), m.fit_cost + visit) for w, j in new]
        used = m.units if a == HOT else m.mild_units
        if h < used:  # fails: a new pad, down F shifts, downtime within the episode
            out = min(F, c.episode_shifts - 1 - t)
            fail = c.costs.damage + m.fit_cost + c.costs.downtime * out
            return [(w, (j, F), fail) for w, j in new]
        return [(1 - p, (h - used, 0), 0.0), (p, (h - used, R), 0.0)]

    orders = [0] if stock is None else list(range(c.max_order + 1))
    shortfall = functools.cache(functools.partial(shortfall_cost, c))  # (on hot, on mild, window)

    @functools.cache
    def value(t: int, state: tuple, pads: int) -> float:
        if t == c.episode_shifts:  # the pad life left, credited (BoundModel.credit)
            return -m.credit * sum(h for h, _ in state)
        window = c.is_window(t)
        down = sum(d > 0 for _, d in state)
        best = np.inf
        options = [(PARK, SERVICE) if (window or d > 0) else (HOT, MILD, PARK, SERVICE)
                   for _, d in state]  # fmt: skip
        for joint in itertools.product(*options):
            fits = joint.count(SERVICE)
            visits = sum(a == SERVICE and d == 0 for a, (_, d) in zip(joint, state, strict=True))
            if (window and fits > c.window_slots) or (
                not window and visits > max(c.bays - down, 0)
            ):
                continue
            per = [moves(t, h, d, a, window) for a, (h, d) in zip(joint, state, strict=True)]
            outcomes = joint_outcomes(per)  # the same whatever is ordered
            for q in orders:
                if stock is not None and fits > pads + q:
                    continue
                total = shortfall(joint.count(HOT), joint.count(MILD), window)
                total += c.costs.order if q else 0.0
                left = pads + q - fits if stock is not None else 0
                for prob, nxt, cost in outcomes:
                    total += prob * (cost + value(t + 1, nxt, left))
                best = min(best, total)
        return best

    return value(0, tuple((h, 0) for h in h0), 0 if stock is None else stock)


def random_prices(m: BoundModel, rng: np.random.Generator) -> Prices:
    T, c = m.config.episode_shifts, m.config.costs
    raw = Prices(*(rng.uniform(0, s, T) for s in (c.shortfall, c.mild_shortfall, 800, 800)))
    return raw.project(m.config)


@pytest.mark.parametrize(
    ("n", "T", "h0", "kwargs"),
    [
        (2, 6, (1, 3), {}),
        (2, 6, (0, 5), {"bays": 0, "mild_need": 0}),
        (3, 4, (1, 2, 5), {"hot_need": 2, "bays": 1}),
        (3, 4, (0, 1, 3), {"hot_need": 1, "mild_need": 1, "window_period": 2}),
    ],
)
def test_bound_is_below_the_brute_force_optimum(n, T, h0, kwargs):
    m = toy(n, T, **kwargs)
    exact = brute_force(m, h0)
    start = start_counts(m, np.array(h0))
    rng = np.random.default_rng(0)
    bounds = []
    for prices in [Prices.zeros(m.config), *(random_prices(m, rng) for _ in range(6))]:
        bounds.append(bound(m, solve(m, prices), prices, start))
    assert max(bounds) <= exact + 1e-6, (bounds, exact)
    best = search(m, start, iterations=30)
    assert best.bound <= exact + 1e-6
    assert best.bound >= best.zero_bound


@pytest.mark.parametrize(("n", "T", "h0"), [(2, 6, (1, 3)), (3, 4, (0, 1, 3))])
def test_the_credited_bound_is_below_the_credited_optimum(n, T, h0):
    """With a terminal credit for the pad life left (the study's bound, on the net cost),
    the bound stays below the exact optimum of the credited problem; the credit lowers
    both, and the bound's program values the last shift's pads at minus the credit."""
    plain = toy(n, T)
    m = dataclasses.replace(plain, credit=150.0)
    exact, exact_plain = brute_force(m, h0), brute_force(plain, h0)
    assert exact < exact_plain
    start = start_counts(m, np.array(h0))
    best = search(m, start, iterations=30)
    assert best.bound <= exact + 1e-6
    np.testing.assert_allclose(solve(m, Prices.zeros(m.config)).values[T][:, 0],
                               -150.0 * np.arange(m.H + 1))  # fmt: skip


@pytest.mark.parametrize(("n", "T", "h0"), [(2, 6, (1, 3)), (3, 4, (0, 1, 3))])
def test_the_orders_share_stays_below_the_optimum_with_real_spares_and_tightens(n, T, h0):
    """With ``orders`` (a service pays order / max_order, the initial stock's share given
    back) the bound stays below the exact optimum of the problem whose services take real
    spares that orders bring, and above the bound without it: services beyond the initial
    stock pay their least share of an order."""
    plain = toy(n, T, initial_stock=1, max_order=2)
    c = plain.config
    m = dataclasses.replace(plain, order_share=c.costs.order / c.max_order)
    exact = brute_force(plain, h0, stock=c.initial_stock)
    assert exact > brute_force(plain, h0)  # the spares cost something here
    start = start_counts(m, np.array(h0))
    best = search(m, start, iterations=30)
    assert best.bound <= exact + 1e-6
    assert best.bound > search(plain, start, iterations=30).bound + 1.0


def test_build_charges_the_orders_share_only_when_asked(atlas):
    cfg = FleetConfig(episode_shifts=10)
    assert BoundModel.build(cfg, atlas, units=2).order_share == 0.0
    m = BoundModel.build(cfg, atlas, units=2, orders=True)
    assert m.order_share == cfg.costs.order / cfg.max_order == 12.5
    prices = Prices.zeros(cfg)
    plain = dataclasses.replace(m, order_share=0.0)
    start = start_counts(m, np.array([m.H] * cfg.n_vehicles))  # no pad wears out in 10 shifts
    # nobody is serviced: the bound only gives back the initial stock's share
    gap = bound(plain, solve(plain, prices), prices, start) - bound(
        m, solve(m, prices), prices, start
    )
    assert gap == pytest.approx(12.5 * cfg.initial_stock)


def test_the_credit_is_priced_as_the_policies_net_cost_and_never_capped():
    from brake_env.env.fleet.episode_cost import life_value

    cfg = FleetConfig(episode_shifts=30)
    env = BrakeWearFleetEnv(cfg)
    m = BoundModel.build(cfg, env.atlas, units=4, credit=True)
    assert BoundModel.build(cfg, env.atlas, units=4).credit == 0.0
    assert m.H * cfg.events_per_shift / m.units > float(m.wear.life(0.4 * cfg.k_mean))
    env.reset(seed=0)
    tr = env.truth()
    h = m.state(tr["volume_frac"], tr["wear_coeff"])  # rounded up: at least the life
    assert m.credit * h.sum() >= life_value(env) > m.credit * (h - 1).sum()


def test_the_single_vehicle_bound_is_its_exact_optimum_when_nothing_links():
    """One vehicle, no needs, bays or crew limit that bind: no price is needed and the
    relaxed program is the exact optimum."""
    m = toy(1, 6, hot_need=1, mild_need=0, bays=1, window_slots=1)
    for h in range(m.H + 1):
        lam = Prices.zeros(m.config)
        assert bound(m, solve(m, lam), lam, start_counts(m, np.array([h]))) <= (
            brute_force(m, (h,)) + 1e-6
        )


def test_search_is_deterministic_and_never_below_zero_prices():
    m = toy(3, 8, hot_need=2)
    start = start_counts(m, np.array([[1, 3, 5], [0, 2, 5]]))
    a, b = search(m, start, iterations=15), search(m, start, iterations=15)
    assert a.bound == b.bound
    np.testing.assert_array_equal(a.prices.hot, b.prices.hot)
    np.testing.assert_array_equal(a.history, b.history)
    assert a.history[0] == a.zero_bound
    assert a.bound >= a.zero_bound and a.bound == a.history.max()
    assert a.iterations == 16


def test_model_build_clock(atlas):
    cfg = FleetConfig(episode_shifts=40)
    m = BoundModel.build(cfg, atlas, units=20)
    assert m.H == 40 * 20 and m.new_prob.sum() == pytest.approx(1.0)
    assert 2 <= m.mild_units <= 4  # r_min ~ 0.15 of a hot shift
    # a new pad's expected life on the hot route is ~158 shifts: beyond this horizon
    assert m.new_prob[-1] == pytest.approx(1.0)
    # rounding up: the model's RUL is never below the expected RUL
    env = BrakeWearFleetEnv(cfg, atlas=atlas)
    env.reset(seed=0)
    tr = env.truth()
    x = m.wear.rul(tr["volume_frac"], tr["wear_coeff"]) * 20 / cfg.events_per_shift
    assert np.all(m.state(tr["volume_frac"], tr["wear_coeff"]) >= np.minimum(x, m.H) - 1e-6)


@pytest.fixture(scope="module")
def small_case(atlas):
    # K 2.5x the default's: pads last ~63 hot shifts, so a short episode has fits to plan
    cfg = FleetConfig(**SMALL_FLEET, episode_shifts=80, k_mean=5e-6, k_std=5e-7)
    env = BrakeWearFleetEnv(cfg, atlas=atlas)
    model = BoundModel.build(cfg, atlas, units=10)
    states, ref_states = [], []
    ref = reference.ReferenceModel.build(cfg, atlas, n_k=16)
    for seed in (0, 1, 2):
        env.reset(seed=seed)
        tr = env.truth()
        states.append(model.state(tr["volume_frac"], tr["wear_coeff"]))
        ref_states.append(ref.state(tr["volume_frac"], tr["wear_coeff"]))
    return model, ref, np.array(states), np.array(ref_states)


def test_bound_is_below_the_exact_reference_on_the_small_fleet(small_case):
    model, ref, states, ref_states = small_case
    sol = reference.solve(ref)
    result = search(model, start_counts(model, states), iterations=40)
    for s, rs in zip(states, ref_states, strict=True):
        b = bound(model, result.program, result.prices, start_counts(model, s))
        predicted = sol.predicted(ref, rs)
        assert b <= predicted, (b, predicted)
        print(f"bound {b:.1f} reference {predicted:.1f} ({1 - b / predicted:.1%} below)")


def test_priced_policy_respects_the_masks(atlas):
    cfg = FleetConfig(n_vehicles=4, hot_need=2, mild_need=1, window_slots=1, bays=1,
                      episode_shifts=40, costs=FleetCosts())  # fmt: skip
    env = BrakeWearFleetEnv(cfg, atlas=atlas)
    model = BoundModel.build(cfg, atlas, units=10)
    states = []
    for seed in (0, 1):
        env.reset(seed=seed)
        tr = env.truth()
        states.append(model.state(tr["volume_frac"], tr["wear_coeff"]))
    result = search(model, start_counts(model, np.array(states)), iterations=10)
    policy = PricedPolicy(env, model, result.prices, result.program)
    eps = run_episodes(env, policy, [0, 1], check_masks=True)
    costs = np.array([e.per_vehicle_shift for e in eps])
    assert np.all(np.isfinite(costs)) and np.all(costs >= 0)


def test_priced_policy_services_and_duties(atlas):
    # default fleet (window period 14, 3 slots, 2 bays, needs 6 hot + 4 mild), 20 units
    cfg = FleetConfig(episode_shifts=60)
    env = BrakeWearFleetEnv(cfg, atlas=atlas)
    model = BoundModel.build(cfg, atlas, units=20)
    zero = Prices.zeros(cfg)
    policy = PricedPolicy(env, model, zero, solve(model, zero), margin=0.0, shop_limit=5.0)
    life = np.array([1.5, 3, 4, 6, 8, 10, 20, 20, 20, 20, 20, 20])  # hot shifts
    h = (life * model.units).astype(np.int64)
    down = np.zeros(12, dtype=np.int64)
    # at a window (shift 13): below 13 shifts of life, least first, within the 3 slots
    duty = policy.decide(13, h, down, stock=4, bays=2)
    assert list(np.flatnonzero(duty == SERVICE)) == [0, 1, 2]
    assert np.all(duty[3:] == PARK)
    # between windows: only the must-do (1.5 < must = 2) takes a visit; a vehicle down in
    # the shop below shop_limit is served without a bay; the worn pads are off the ramp
    down[2] = 1
    duty = policy.decide(3, h, down, stock=4, bays=1)
    assert list(np.flatnonzero(duty == SERVICE)) == [0, 2]
    assert (duty == HOT).sum() == cfg.hot_need and (duty == MILD).sum() == cfg.mild_need
    # no spares: nothing served, the must-do pad parks
    duty = policy.decide(3, h, np.zeros(12, dtype=np.int64), stock=0, bays=2)
    assert not np.any(duty == SERVICE) and duty[0] == PARK
    with pytest.raises(ValueError, match="damping"):
        PricedPolicy(env, model, zero, solve(model, zero), damping=2.0)


def test_slack_gives_every_pad_more_life(atlas):
    cfg = FleetConfig(episode_shifts=40)
    m0, m1 = (BoundModel.build(cfg, atlas, units=10, slack_shifts=s) for s in (0.0, 1.0))
    v, k = np.array([0.9, 0.5]), np.array([2e-6, 2.2e-6])
    np.testing.assert_array_equal(m1.state(v, k), np.minimum(m0.state(v, k) + 10, m1.H))
    assert m1.new_prob.sum() == pytest.approx(1.0) and m1.new_prob[:10].sum() == 0.0
