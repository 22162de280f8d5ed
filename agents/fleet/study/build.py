"""What a fleet-study unit builds from the settings: the physics the fleet wears on
(:func:`truth_atlas`), the env a policy acts on (:func:`rul_env`), the rules' layout, a tuned
heuristic from its parameters, and episode costs as unit results and back.

The env runs with ``truth=False`` (nothing simulated ahead). The oracle's RUL is the
closed-form expected RUL on the hot route from the pad's true volume and K
(:class:`~brake_env.env.fleet.wrappers.ExpectedRULObservation`), which the simulated-ahead
oracle predictor matches up to the noise of the wear to come, at ~20x the cost.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from agents.fleet.evaluation.costs import EpisodeCost
from agents.fleet.evaluation.tuning import SPACES
from agents.fleet.policies.view import FleetLayout
from agents.fleet.settings import FIXED_INTERVAL, FleetStudyConfig
from agents.fleet.study.interval import AgeRULObservation
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.family import make_env
from brake_env.env.fleet.route_rul import ROUTE_NAMES
from brake_env.env.fleet.wrappers import ExpectedRULObservation, FleetRULObservation
from brake_env.model.atlas import Atlas, AtlasSpec, cached_atlas
from brake_env.model.effects import canonical_effects
from brake_env.prognostics.protocol import Predictor
from brake_env.prognostics.registry import ORACLE


@dataclass(frozen=True, eq=False)
class Fitted:
    """A predictor as its user has it: fitted, and the atlas it was made on, which also
    carries its RUL onto the routes (the nominal one when its user does not know the
    effects the fleet wears with).

    Attributes:
        predictor: The fitted predictor.
        atlas: The physics it was made on.
    """

    predictor: Predictor
    atlas: Atlas


def truth_atlas(
    config: FleetStudyConfig, atlas: Atlas, cache_dir: str | Path | None = None
) -> Atlas:
    """The atlas the fleet's pads wear on: ``atlas`` itself, or with ``config.effects`` its
    physics with the effects added (its own kept), from the atlas cache (built and cached
    under its own hash on a miss; ``cache_dir`` default as
    :func:`~brake_env.model.atlas.cached_atlas`'s).

    Raises:
        ValueError: An effect the plug-in does not know or an atlas cannot hold, named.
    """
    if not config.effects:
        return atlas
    return cached_atlas(truth_spec(config, atlas), cache_dir)


def truth_spec(config: FleetStudyConfig, atlas: Atlas) -> AtlasSpec:
    """The spec of :func:`truth_atlas`: ``atlas``'s with ``config.effects`` added."""
    effects = canonical_effects([*atlas.spec.effects, *config.effects], atlas.spec.model)
    return replace(atlas.spec, effects=effects)


def rul_env(
    config: FleetStudyConfig, atlas: Atlas, predictor: str, fitted: Fitted | None,
    fields: tuple[str, ...] = ("rul_mean",), routes: tuple[str, ...] = ROUTE_NAMES,
) -> Any:  # fmt: skip
    """The fleet env on ``atlas`` (the truth) with ``predictor``'s RUL appended (``fields``
    on each of ``routes`` per vehicle, in shifts; carried onto the routes with the fitted
    predictor's own atlas; the fixed interval's from the pad's age alone)."""
    env = make_env(config.fleet, atlas)
    if predictor == ORACLE:
        return ExpectedRULObservation(env, fields, routes)
    if predictor == FIXED_INTERVAL:
        return AgeRULObservation(env, fields, routes)
    assert fitted is not None, f"predictor {predictor!r} needs a fitted predictor"
    return FleetRULObservation(env, fitted.predictor, fields=fields, routes=routes,
                               atlas=fitted.atlas)  # fmt: skip


def layout(config: FleetStudyConfig) -> FleetLayout:
    return FleetLayout.of(config.fleet)


def episodes_dict(eps: list[EpisodeCost]) -> dict[str, Any]:
    """Episode costs as a unit result (arrays; :func:`episodes_of` reads them back)."""
    terms, counts = list(eps[0].terms), sorted({k for e in eps for k in e.counts})
    return {
        "seed": np.array([e.seed for e in eps]),
        "vehicles": eps[0].vehicles,
        "shifts": np.array([e.shifts for e in eps]),
        "pad_price": eps[0].pad_price,
        "life_value": np.array([e.life_value for e in eps]),
        "terms": {t: np.array([e.terms[t] for e in eps]) for t in terms},
        "counts": {c: np.array([e.counts.get(c, 0.0) for e in eps], dtype=float) for c in counts},
    }


def episodes_of(d: dict[str, Any]) -> list[EpisodeCost]:
    """:func:`episodes_dict` read back."""
    n = len(d["seed"])
    left = d.get("life_value", np.zeros(n))
    return [
        EpisodeCost(int(d["seed"][i]), int(d["vehicles"]), int(d["shifts"][i]),
                    {t: float(v[i]) for t, v in d["terms"].items()},
                    {c: float(v[i]) for c, v in d["counts"].items()}, float(d["pad_price"]),
                    float(left[i]))
        for i in range(n)
    ]  # fmt: skip


def rebuild_rule(
    config: FleetStudyConfig, heuristic: str, params: dict[str, Any],
    lay: FleetLayout | None = None,
) -> Any:  # fmt: skip
    """A tuned heuristic from its parameters (as :func:`heuristic_unit` saved them), reading
    ``lay`` (default: the study's layout, the RUL mean alone)."""
    return rule_of(config.fleet, heuristic, params, lay or layout(config))


def rule_of(fleet: FleetConfig, heuristic: str, params: dict[str, Any], lay: FleetLayout) -> Any:
    """The rule of family ``heuristic`` with tuned ``params`` on ``fleet``, reading ``lay``:
    the one place a tuned rule is rebuilt (studies, shipped baselines, ``plan``)."""
    import optuna  # the fleet extra, imported where used (as in tuning.tune)

    return SPACES[heuristic](optuna.trial.FixedTrial(params), lay, fleet.window_period)


def single_thread(fn: Any, *args: Any) -> Any:
    """``fn(*args)`` with torch on one thread: the same numbers in this process and on Ray,
    and no waits for threads on busy cores (tiny networks)."""
    import torch

    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        return fn(*args)
    finally:
        torch.set_num_threads(threads)
