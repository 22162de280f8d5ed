"""Configuration of BrakeWearFleet-v0: the fleet, its shifts, the workshop, spares and costs.

Frozen, validated dataclasses; ``FleetConfig.from_kwargs`` is how ``gym.make`` keyword
arguments arrive, so an unknown name or a value out of range raises one ``ValueError``
naming it. Every default says where it comes from. The defaults were fixed before any
policy was run on the env and are not tuned to make one policy win (DESIGN.md 10).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, Literal

from brake_env._validate import check_nonnegative, is_number, plain_numbers
from brake_env.env.config import PRESETS, REGIMES, RegimeFields
from brake_env.env.shared import check_choice, check_int_fields, check_types, config_from_kwargs
from brake_env.model.regime import WearRegime
from brake_env.model.streams import SensorNoise

ENV_ID = "BrakeWearFleet-v0"
# The default fleet (12 vehicles: 6 needed hot + 4 mild, 3 window slots, 2 bays) scaled by
# 1/6, each count rounded up to 1: every vehicle is needed and the window fits one pad set.
# The size the perfect-information reference (an exact program) is solved for.
SMALL_FLEET = {"n_vehicles": 2, "hot_need": 1, "mild_need": 1, "window_slots": 1, "bays": 1}


@dataclass(frozen=True)
class FleetCosts:
    """Cost weights, in currency units; the keys of ``info["costs"]`` (each term is its
    weight times the count of what it prices; the reward is minus their sum).

    The scale is BrakeWear-v0's (:class:`~brake_env.env.config.CostWeights`): a planned
    replacement costs 1,000 (here ``pad + labour``) and a failure about ten of them (here
    ``damage + failure_repair_shifts * downtime + pad + labour`` = 9,000, plus the lost
    production of the shifts the vehicle is out, if the fleet falls short).

    Attributes:
        pad: Price of one spare pad set, paid when it is ordered (BrakeWear-v0's planned
            replacement split 60 : 40 between parts and labour, an assumption) [-/pad].
        order: Fixed cost of placing a reorder (administration, freight), whatever its
            quantity (assumption: a tenth of a replacement) [-/order].
        labour: Fitting one pad set, wherever it is done [-/replacement].
        shop_visit: Fixed cost of an unscheduled shop visit, whatever is done there
            (towing or driving to the shop, bay set-up, inspection; assumption: 1.5
            planned replacements). Not paid at a scheduled window nor by a vehicle already
            in the shop [-/visit].
        holding: Carrying cost of a spare in stock per shift: 25% a year of the pad price
            (a common inventory carrying rate) over 730 shifts a year [-/pad/shift].
        damage: Secondary damage of a brake failure (disc, caliper, the incident);
            BrakeWear-v0's ``damage`` [-/failure].
        downtime: Each shift a failed vehicle is out for repair (recovery, investigation);
            BrakeWear-v0's 4,000 of downtime spread over ``failure_repair_shifts`` = 3 shifts
            and rounded down [-/vehicle-shift].
        shortfall: Lost production of each vehicle missing from the hot route's need in a
            shift (assumption: two planned replacements per vehicle-shift of ramp haulage)
            [-/vehicle-shift].
        mild_shortfall: Lost production of each vehicle missing from the mild route's need
            (drift mucking and development; assumption: half a ramp shift, since ore on the
            ramp is what the mine sells and development can catch up) [-/vehicle-shift].
        deferred: Each service request deferred for lack of a bay or a spare. Its real cost
            is the vehicle's lost shift (it waits at the shop, parked), which ``shortfall``
            already prices, so 0 by default; the count is always reported [-/request].
    """

    pad: float = 600.0
    order: float = 100.0
    labour: float = 400.0
    shop_visit: float = 1500.0
    holding: float = 0.2
    damage: float = 5000.0
    downtime: float = 1000.0
    shortfall: float = 2000.0
    mild_shortfall: float = 1000.0
    deferred: float = 0.0

    def __post_init__(self) -> None:
        plain_numbers(self)
        check_nonnegative(self, *(f.name for f in dataclasses.fields(self)))


COST_TERMS = tuple(f.name for f in dataclasses.fields(FleetCosts))

# name, lowest, highest: the integer fields of FleetConfig.
_INT_FIELDS = (
    ("n_vehicles", 1, 256),
    ("events_per_shift", 1, 10_000),
    ("episode_shifts", 1, 100_000),
    ("window_period", 1, 10_000),
    ("bays", 0, 256),
    ("hot_need", 0, 256),
    ("mild_need", 0, 256),
    ("window_slots", 0, 256),
    ("initial_stock", 0, 10_000),
    ("max_order", 0, 1_000),
    ("lead_time", 1, 1_000),
    ("failure_repair_shifts", 1, 1_000),
    ("breakdown_repair_shifts", 1, 1_000),
)


@dataclass(frozen=True)
class FleetConfig(RegimeFields):
    """Everything BrakeWearFleet-v0 can be configured with (the keyword arguments of
    ``gym.make``). Defaults and where they come from:

    Attributes:
        n_vehicles: Vehicles (load-haul-dump trucks) in the fleet. 12: a mid-size
            underground mine runs of the order of ten LHDs (assumption) [-].
        events_per_shift: Braking events of a working vehicle per shift. 400: a 12-hour
            shift of ~10 productive hours at ~40 stops an hour (assumption); on the hot
            route a pad then lasts ~160 shifts, on the mild one ~820 (at the mean K;
            route_wear_model) [-].
        episode_shifts: Shifts per episode; truncated after them. 730: a year on a
            2 x 12 h roster, a few pad lives on the hot route [-].
        window_period: A scheduled maintenance window every this many shifts (the fleet's
            weekly planned-maintenance shift on a 2 x 12 h roster: 14). The window is a
            shift of its own: nobody hauls, no production is needed, any vehicle may get
            pads (labour and the pad; no visit cost, no bay; at most ``window_slots``
            of them) [shifts].
        window_slots: Pad sets the window's crew can fit in its shift. 3: one brake crew,
            about 4 h a pad set on a 12 h shift (assumption). Requests beyond it are
            deferred (reason ``crew``), by the workshop's order [-].
        bays: Workshop bays for unscheduled work per shift: vehicles down (failure or
            other breakdown) occupy them first, the rest take service requests. 2: a small
            underground workshop (assumption) [-].
        hot_need: Vehicles needed on the hot route each working shift; each one short
            costs ``shortfall``. 6: half the fleet on ore haulage (assumption) [-].
        mild_need: Vehicles needed on the mild route (drift mucking, development) each
            working shift; vehicles on the hot route beyond ``hot_need`` count towards it
            (a ramp truck can muck a drift); each one short costs ``mild_shortfall``. 4:
            with ``hot_need`` 10 of 12 vehicles must work, an availability target of 83%,
            the range LHD fleets plan for (80-85%, assumption); a mine does not buy
            vehicles to park them, so the spare duty is the exception, not the rule [-].
        initial_stock: Spare pad sets in stock at the start [-]. 4.
        max_order: Largest reorder quantity of one shift (the action's upper value) [-].
            8.
        lead_time: Shifts from placing an order to its arrival (into stock at the start
            of that shift). 14: a week from the supplier (assumption) [shifts].
        failure_repair_shifts: Shifts a vehicle is out after a brake failure (recovery,
            corrective replacement, investigation). 3 (assumption) [shifts].
        breakdown_rate: Probability per working shift that a vehicle breaks down for a
            reason other than its brakes and goes to the shop; while there its pads can
            be changed for labour and the pad alone (the opportunity of the (n, N) rules).
            0.02: about one such stop every 50 shifts (assumption) [-/shift].
        breakdown_repair_shifts: Shifts out after such a breakdown [shifts]. 1.
        initial_age_max: Each vehicle's first pad has already braked a uniform fraction in
            [0, this) of its expected life on the envelope's uniform mix (a fleet in
            service, not all pads new at once), and is at the volume the expected wear
            path gives (its history before the episode is not observed); its streams
            start there. 0 starts every pad new [-]. 0.8.
        regime, ood_share, k_mean, k_std, ood_shift_sigma: Wear regime of new pads, as in
            :class:`~brake_env.env.config.EnvConfig` (the paper's K ~ N(2e-6, 2e-7^2)).
        costs: Cost weights (:class:`FleetCosts` or a dict of its fields).
        noise: Sensor noise of the event channels (the paper's, as in BrakeWear-v0).
        preset: Brake calibration of the default atlas, as in BrakeWear-v0.
        truth: Put each vehicle's true RUL (events to failure were it to run the hot route
            from now on, simulated ahead on a copy of its stream) in ``info["truth"]``
            and in the events' ``rul_events`` column every step. Off by default: nothing
            is simulated ahead; :meth:`BrakeWearFleetEnv.true_rul` gives it on demand.
    """

    n_vehicles: int = 12
    events_per_shift: int = 400
    episode_shifts: int = 730
    window_period: int = 14
    bays: int = 2
    hot_need: int = 6
    mild_need: int = 4
    window_slots: int = 3
    initial_stock: int = 4
    max_order: int = 8
    lead_time: int = 14
    failure_repair_shifts: int = 3
    breakdown_rate: float = 0.02
    breakdown_repair_shifts: int = 1
    initial_age_max: float = 0.8
    regime: Literal["id", "ood", "mixed"] = "id"
    ood_share: float = 0.5
    k_mean: float = WearRegime.k_mean
    k_std: float = WearRegime.k_std
    ood_shift_sigma: float = WearRegime.ood_shift_sigma
    costs: FleetCosts = field(default_factory=FleetCosts)
    noise: SensorNoise = field(default_factory=SensorNoise)
    preset: str = "hot-duty"
    truth: bool = False

    def __post_init__(self) -> None:
        plain_numbers(self)
        check_int_fields(ENV_ID, self, _INT_FIELDS)
        if self.hot_need + self.mild_need > self.n_vehicles:
            raise ValueError(
                f"{ENV_ID}: hot_need + mild_need ({self.hot_need} + {self.mild_need}) must be"
                f" <= n_vehicles ({self.n_vehicles}); a smaller fleet needs its own needs"
            )
        for name in ("breakdown_rate", "initial_age_max"):
            v = getattr(self, name)
            if not is_number(v) or not 0.0 <= v < 1.0:
                raise ValueError(f"{ENV_ID}: {name} must be a number in [0, 1), got {v!r}")
        check_choice(ENV_ID, "preset", self.preset, PRESETS)
        check_choice(ENV_ID, "regime", self.regime, REGIMES)
        check_types(ENV_ID, self, {"costs": FleetCosts, "noise": SensorNoise, "truth": bool})
        self.pad_regime  # validates the regime fields  # noqa: B018

    def is_window(self, shift: int) -> bool:
        """Whether shift ``shift`` (0-based) is a scheduled window: the last of each period."""
        return shift % self.window_period == self.window_period - 1

    def shifts_to_window(self, shift: int) -> int:
        """Shifts from ``shift`` to the next window (0 during a window)."""
        return (self.window_period - 1 - shift) % self.window_period

    @classmethod
    def from_kwargs(cls, base: FleetConfig | None = None, **kwargs: Any) -> FleetConfig:
        """``base`` (default config if None) with ``kwargs`` replaced, all validated."""
        nested = {"costs": FleetCosts, "noise": SensorNoise}
        return config_from_kwargs(ENV_ID, cls, base, kwargs, nested)
