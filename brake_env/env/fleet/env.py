"""BrakeWearFleet-v0: a mine's fleet, its maintenance windows, workshop, spares and duties."""

from __future__ import annotations

import os
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from brake_env.env.fleet import rules
from brake_env.env.fleet import spaces as fs
from brake_env.env.fleet.config import COST_TERMS, ENV_ID, FleetConfig
from brake_env.env.fleet.fleet_file import read_fleet
from brake_env.env.fleet.model import breaks
from brake_env.env.fleet.pads import FleetPads, ShiftEvents
from brake_env.env.fleet.render import FleetFrame, ansi
from brake_env.env.fleet.routes import UNIFORM, route_indices, route_wear_model
from brake_env.env.fleet.shop import Plan, Workshop
from brake_env.env.fleet.state import FleetState, read_state, restore
from brake_env.env.shared import check_render_mode, env_atlas
from brake_env.model.atlas import Atlas


class BrakeWearFleetEnv(gym.Env[NDArray[np.float32], NDArray[np.int64]]):
    """
    ## Description

    A fleet of ``n_vehicles`` load-haul-dump trucks in a mine. Each has its own brake pads,
    streamed like BrakeWear-v0's (the same physics, atlas, wear regimes, and bit for bit the
    same events for the same streams). One step is one shift. Each shift the dispatcher
    sends every vehicle to the **hot** route (a loaded steep ramp: 8-15 km/h, 48-54 t,
    6-10 deg), the **mild** one (level drifts: 4-10 km/h, 42-48 t, 0-3 deg), parks it, or
    sends it to the workshop for new pads; and reorders spare pads. How much faster a pad
    wears on the ramp, and how it accelerates as the pad thins, comes from the coupled
    physics (the atlas), not from a factor. Pads are cheap to change in the scheduled
    window (every ``window_period`` shifts), dearer in an unscheduled shop visit (a fixed
    visit cost, a bay, the vehicle's shift), and a brake failure is dearest (damage,
    shifts of downtime). The workshop has ``bays`` bays, spares arrive ``lead_time``
    shifts after they are ordered, ``hot_need`` vehicles are needed on the ramp and
    ``mild_need`` more in the drifts every working shift, and the window's crew fits at
    most ``window_slots`` pad sets. A per-pad RUL threshold ignores all of this; a policy
    has to plan replacements and duties across the horizon to the next window.

    ## Action Space

    ``MultiDiscrete([4] * n_vehicles + [max_order + 1])``: per vehicle 0 hot route, 1 mild
    route, 2 park, 3 service (replace its pads); last, the spare pads to order this shift.
    :meth:`action_masks` gives the flat mask sb3-contrib's MaskablePPO expects. Requests
    beyond the bays or the stock are **deferred**, duties a vehicle cannot take are
    **refused**, by the rule of :mod:`brake_env.env.fleet.shop`; both are listed in
    ``info`` and counted in ``info["counts"]`` and ``info["costs"]["deferred"]``. An action
    is an integer array (any numpy integer dtype) or a list of ints; floats, bools, NaN,
    strings or values out of range raise one ``ValueError`` naming the vehicle and value.

    ## Observation Space

    ``Box(10 * n_vehicles + 5,)`` float32: per vehicle (in vehicle order), then the fleet
    (:func:`~brake_env.env.fleet.spaces.split_observation` separates them).

    | Num          | Observation (per vehicle v)          | Min     | Max      | Unit   |
    |--------------|--------------------------------------|---------|----------|--------|
    | 10v + 0..5   | shift mean of speed_kmh, mass_kg,    | sensor  | sensor   | schema |
    |              | slope_rad, energy_j, temp_c,         | ranges  | ranges   | units  |
    |              | stop_dist_m (0 if it braked none)    |         |          |        |
    | 10v + 6      | temp_c_max: hottest event's reading  | -273.15 | 3000     | deg C  |
    | 10v + 7      | events braked in the shift           | 0       | e/shift  | events |
    | 10v + 8      | pad_age: events since installation   | 0       | 1e7      | events |
    | 10v + 9      | down_shifts: shifts left in the shop | 0       | 1e4      | shifts |
    | 10N + 0      | shift (index of the coming shift)    | 0       | episode  | shifts |
    | 10N + 1      | shifts_to_window (0: it is a window) | 0       | W - 1    | shifts |
    | 10N + 2      | stock of spare pads                  | 0       | bound    | pads   |
    | 10N + 3      | pads on order (in transit)           | 0       | bound    | pads   |
    | 10N + 4      | free bays for visits                 | 0       | bays     | bays   |

    ## Transition Dynamics

    A step serves the actions (windows, shop fits and visits in the stated order; others
    deferred or refused), installs the new pads, brakes ``events_per_shift`` events of
    every vehicle on duty on its route (one pass through the atlas for the fleet), fails
    the pads that reach their end of life with events to brake (the envelope's critical
    volume, as in BrakeWear-v0: :mod:`brake_env.env.fleet.routes`), sends failed vehicles
    down for ``failure_repair_shifts`` (a spare fitted at once if there is one, else when
    one arrives), breaks down working vehicles for other reasons with probability
    ``breakdown_rate``, places the order, and opens the next shift (arrivals).

    ## Reward

    Minus the shift's cost: the sum of ``info["costs"]``, whose keys are the fields of
    :class:`~brake_env.env.fleet.config.FleetCosts` (HighwayEnv style): ``pad`` (pads
    ordered), ``order``, ``labour`` (every fit), ``shop_visit``, ``holding``, ``damage``,
    ``downtime``, ``shortfall`` (hot route), ``mild_shortfall``, ``deferred``.

    ## Starting State

    Every vehicle has a pad that has already braked a uniform fraction in
    ``[0, initial_age_max)`` of its expected life on the envelope's uniform mix, at the
    volume the expected wear path gives (its streams start there); ``initial_stock``
    spares, none on order, nobody down; shift 0. ``reset(options={"state": s})`` starts
    from a :class:`~brake_env.env.fleet.state.FleetState` instead (:meth:`state` reads one).

    ## Episode End

    Never terminated (failures are repaired and the mine goes on). Truncated after
    ``episode_shifts`` shifts. ``gym.make`` also adds a TimeLimit of the registered
    ``max_episode_steps`` (730, the default ``episode_shifts``): with more shifts, pass
    ``max_episode_steps`` as well (``gym.make(id, episode_shifts=1000,
    max_episode_steps=1000)``), or the episode is cut at 730; fewer need nothing.

    ## Info

    ``costs`` (terms by name), ``counts`` (fits by kind, visits, failures, breakdowns,
    deferred, refused, ordered, arrived, on_hot, on_mild, shortfall, mild_shortfall),
    ``deferred`` ([(vehicle, reason)]),
    ``refused`` ([(vehicle, action, reason)]), ``vehicles`` (per-vehicle arrays: ``route``
    -1/0/1, ``events``, ``replaced``, ``failed``, ``broke_down``), ``window`` and
    ``truth`` (true volume, K, layer and regime of every pad; with ``truth=True`` also
    ``rul_hot``, events to failure on the hot route). Truth is for analysis, never for a
    policy; :meth:`true_rul` and :meth:`shift_events` give more on demand.

    ## Arguments

    ```python
    import gymnasium as gym
    import brake_env
    env = gym.make("BrakeWearFleet-v0", n_vehicles=4, hot_need=2, mild_need=1, window_slots=1)
    ```

    Every field of :class:`~brake_env.env.fleet.config.FleetConfig` is a keyword (``costs``
    and ``noise`` also as dicts), plus ``config``, ``atlas`` and ``render_mode`` (None,
    ``"ansi"`` or ``"rgb_array"``). Unknown or out-of-range arguments raise ``ValueError``.

    ## Version History

    * v0: initial version.
    """

    metadata = {"render_modes": ["ansi", "rgb_array"], "render_fps": 4}  # noqa: RUF012

    def __init__(
        self,
        config: FleetConfig | None = None,
        atlas: Atlas | str | os.PathLike[str] | None = None,
        render_mode: str | None = None,
        fleet: str | os.PathLike[str] | None = None,
        **kwargs: Any,
    ) -> None:
        if fleet is not None:  # a fleet file or a shipped fleet's name, kwargs on top
            if config is not None:
                raise ValueError(f"{ENV_ID}: give config or fleet, not both")
            config = read_fleet(fleet).config
        self.config = FleetConfig.from_kwargs(config, **kwargs)
        check_render_mode(ENV_ID, render_mode, self.metadata["render_modes"])
        self.render_mode = render_mode
        self.atlas = env_atlas(atlas, self.config.preset)
        self._actions = fs.action_space(self.config)
        self.action_space = self._actions
        self._box = fs.observation_space(self.config)
        self.observation_space = self._box  # type: ignore[assignment]  # Box of float32
        self._capacity = max(4 * self.config.events_per_shift, 4096)
        self.pads: FleetPads | None = None
        self._last_info: dict[str, Any] = {}
        self._events: ShiftEvents | None = None
        self._start_summary: NDArray[np.float64] | None = None
        self._frame = FleetFrame(self) if render_mode == "rgb_array" else None

    # ------------------------------------------------------------------ episode
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[np.float32], dict[str, Any]]:
        super().reset(seed=seed)
        c = self.config
        # Own streams for each vehicle's pads, the first pads' ages and the breakdowns, so
        # that no draw shifts another: vehicle v's n-th pad (K, regime, streams) and the
        # breakdown draws are the same whatever the policy (common random numbers).
        root = np.random.SeedSequence(int(self.np_random.integers(2**63)))
        age_seed, break_seed, *pad_seeds = root.spawn(2 + c.n_vehicles)
        self._pad_rngs = [np.random.default_rng(s) for s in pad_seeds]
        self._age_rng = np.random.default_rng(age_seed)
        self._break_rng = np.random.default_rng(break_seed)
        self.pads = FleetPads(self.atlas, c.n_vehicles, c.noise, self._capacity)
        for v in range(c.n_vehicles):
            self._install(v)
        self._age_first_pads()
        self.shop = Workshop(c)
        self.shift = 0
        self._events, self._start_summary = None, None
        if options is not None and "state" in options:
            restore(self, options["state"])
            self._start_summary = options["state"].summary
        self._last_info = self._info(
            dict.fromkeys(COST_TERMS, 0.0), {}, None, Plan.idle(c.n_vehicles)
        )
        if self._frame is not None:
            self._frame.start()
        return self._observation(), self._last_info

    def step(
        self, action: NDArray[np.int64]
    ) -> tuple[NDArray[np.float32], SupportsFloat, bool, bool, dict[str, Any]]:
        if self.pads is None:
            raise RuntimeError(f"{ENV_ID}: call reset() first")
        if self.shift >= self.config.episode_shifts:
            raise RuntimeError(f"{ENV_ID}: the episode is over; call reset()")
        duty, quantity = fs.parse_action(self.config, action)
        c, shop, pads = self.config, self.shop, self.pads
        window = c.is_window(self.shift)
        down_failed = int(((shop.down > 0) & shop.failed_down).sum())  # out this shift
        plan = shop.plan(duty, window, pads.pos)
        for v in np.flatnonzero(plan.replaced):
            self._install(int(v))
        n_events = np.where(plan.route >= 0, c.events_per_shift, 0)
        ev = pads.advance(n_events, np.maximum(plan.route, 0))
        fitted = shop.fail(ev.failed)
        for v in np.flatnonzero(fitted):
            self._install(int(v))
        broke = breaks(c, plan.route >= 0, ev.failed, self._break_rng.random(c.n_vehicles))
        shop.break_down(broke)
        shop.order(quantity)
        shop.end_shift(ev.failed | broke)
        held = shop.stock  # spares held through the shift (holding cost)
        self.shift += 1
        arrived = shop.receive()
        waited = shop.fit_waiting()
        for v in np.flatnonzero(waited):
            self._install(int(v))
        counts = self._counts(
            plan, ev, fitted | waited, broke, quantity=quantity, arrived=arrived, window=window
        )
        counts["downtime"], counts["stock"] = down_failed, held
        costs = self._costs(counts)
        self._events = ev
        info = self._info(costs, counts, ev, plan, broke)
        self._last_info = info
        if self._frame is not None:
            self._frame.record(info)
        reward = -float(sum(costs.values()))
        truncated = self.shift >= c.episode_shifts
        return self._observation(), reward, False, truncated, info

    def action_masks(self) -> NDArray[np.bool_]:
        """Flat bool mask of length ``sum(action_space.nvec)`` for sb3-contrib's
        MaskablePPO (the rule of :func:`brake_env.env.fleet.rules.action_mask`)."""
        if self.pads is None:
            raise RuntimeError(f"{ENV_ID}: call reset() first")
        c, shop = self.config, self.shop
        window = c.is_window(self.shift)
        return rules.action_mask(shop.down > 0, window, shop.stock, shop.free_bays(), c.max_order)

    # ------------------------------------------------------------------ truth
    def true_rul(self, route: str | int = "hot") -> NDArray[np.int64]:
        """Each installed pad's true RUL: the events it still completes were its vehicle to
        brake ``route`` (``hot``, ``mild`` or ``uniform``; or per vehicle an array of
        route indices) from now on; simulated ahead on a copy of its streams, so the
        episode is not changed. For the oracle and evaluation, never for a policy."""
        if self.pads is None:
            raise RuntimeError(f"{ENV_ID}: call reset() first")
        r = route_indices(route, self.config.n_vehicles, f"{ENV_ID}: true_rul")
        return self.pads.events_to_failure(r)

    def truth(self) -> dict[str, NDArray[Any]]:
        """True state of every pad: ``volume_frac``, ``wear_coeff`` (K), ``layer`` (atlas
        layer), ``pad_age`` and ``regime``. With :func:`route_wear_model` (expected wear per
        event per layer of each route) it is what a perfect-information reference needs."""
        p = self.pads
        if p is None:
            raise RuntimeError(f"{ENV_ID}: call reset() first")
        return {
            "volume_frac": p.vol.copy(),
            "wear_coeff": p.k.copy(),
            "layer": p.layer.copy(),
            "pad_age": p.pos.copy(),
            "regime": p.label.copy(),
        }

    def state(self) -> FleetState:
        """The fleet now, with the episode's streams (``reset(options={"state": ...})``)."""
        return read_state(self)

    def shift_events(self) -> ShiftEvents | None:
        """The last shift's events of every vehicle (None after reset)."""
        return self._events

    # ------------------------------------------------------------------ render
    def render(self) -> str | NDArray[np.uint8] | None:
        if self._frame is not None:
            return self._frame.frame()
        if self.render_mode == "ansi" and self._last_info:
            return ansi(self, self._last_info)
        return None

    # ------------------------------------------------------------------ internals
    def _install(self, v: int) -> None:
        assert self.pads is not None
        rng = self._pad_rngs[v]
        k, label = self.config.pad_regime.draw(rng)
        self.pads.install(v, k, label, int(rng.integers(2**63)))

    def _age_first_pads(self) -> None:
        """Each first pad has braked a random share of its expected life on the uniform mix,
        and is where the expected wear path puts it (the history before the episode is
        not observed; streaming it would cost ~1 s a reset)."""
        assert self.pads is not None
        c, pads = self.config, self.pads
        clock = route_wear_model(self.atlas, UNIFORM)
        age = self._age_rng.random(c.n_vehicles) * c.initial_age_max * clock.life(pads.k)
        age = age.astype(np.int64)
        pads.start_at(age, clock.volume_at_work(pads.k * age))

    def _counts(
        self, plan: Plan, ev: ShiftEvents, fitted: NDArray[np.bool_], broke: NDArray[np.bool_],
        *, quantity: int, arrived: int, window: bool,
    ) -> dict[str, int]:  # fmt: skip
        on_hot, on_mild = int((plan.route == 0).sum()), int((plan.route == 1).sum())
        short_hot, short_mild = rules.shortfall(self.config, on_hot, on_mild, window)
        return {
            "window_fits": int(plan.window_fit.sum()), "shop_fits": int(plan.shop_fit.sum()),
            "visits": int(plan.visit.sum()), "corrective_fits": int(fitted.sum()),
            "failures": int(ev.failed.sum()), "breakdowns": int(broke.sum()),
            "deferred": len(plan.deferred), "refused": len(plan.refused),
            "ordered": quantity, "arrived": arrived, "on_hot": on_hot, "on_mild": on_mild,
            "shortfall": short_hot, "mild_shortfall": short_mild,
            "stock": self.shop.stock, "events": int(ev.n_done.sum()),
        }  # fmt: skip

    def _costs(self, n: dict[str, int]) -> dict[str, float]:
        w = self.config.costs
        fits = n["window_fits"] + n["shop_fits"] + n["visits"] + n["corrective_fits"]
        return {
            "pad": w.pad * n["ordered"],
            "order": w.order * (n["ordered"] > 0),
            "labour": w.labour * fits,
            "shop_visit": w.shop_visit * n["visits"],
            "holding": w.holding * n["stock"],
            "damage": w.damage * n["failures"],
            "downtime": w.downtime * n["downtime"],
            "shortfall": w.shortfall * n["shortfall"],
            "mild_shortfall": w.mild_shortfall * n["mild_shortfall"],
            "deferred": w.deferred * n["deferred"],
        }

    def _info(
        self, costs: dict[str, float], counts: dict[str, int], ev: ShiftEvents | None,
        plan: Plan, broke: NDArray[np.bool_] | None = None,
    ) -> dict[str, Any]:  # fmt: skip
        n = self.config.n_vehicles
        truth: dict[str, Any] = self.truth()
        if self.config.truth:
            truth["rul_hot"] = self.true_rul("hot")
        none = np.zeros(n, dtype=bool)
        return {
            "shift": self.shift,
            "window": self.config.is_window(self.shift - 1) if ev is not None else False,
            "costs": costs,
            "counts": counts,
            "deferred": plan.deferred,
            "refused": plan.refused,
            "vehicles": {
                "route": plan.route.copy(),
                "events": np.zeros(n, dtype=np.int64) if ev is None else ev.n_done.copy(),
                "replaced": plan.replaced.copy(),
                "failed": none if ev is None else ev.failed.copy(),
                "broke_down": none if broke is None else broke.copy(),
                "serial": self.pads.serial.copy() if self.pads is not None else none,
            },
            "truth": truth,
        }

    def _observation(self) -> NDArray[np.float32]:
        assert self.pads is not None
        summary = fs.shift_summary(self._events, self.config.n_vehicles)
        if self._events is None and self._start_summary is not None:
            summary = self._start_summary
        return fs.fleet_observation(
            self.config, summary, self.pads.pos, self.shop, self.shift, self._box
        )
