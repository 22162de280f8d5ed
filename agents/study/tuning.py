"""Tuning the rule families of the cost study on the tuning pads: every candidate threshold
and fixed-interval age, the cheapest of each family at each cost ratio."""

from __future__ import annotations

import math

import numpy as np

from agents.policies.rules import FIXED_INTERVAL, PolicyId
from agents.study import outcomes as oc
from agents.study.config import StudyConfig
from agents.study.pads import PadSet
from agents.study.results import Tuning
from brake_env.model.atlas import Atlas
from brake_env.model.wear import WearModel


def id_life(config: StudyConfig, atlas: Atlas) -> float:
    """Expected life of an ID pad [events], the unit of the fixed interval's candidates."""
    return float(WearModel.from_atlas(atlas).life(config.wear.k_mean))


def tune(config: StudyConfig, pads: PadSet, id_life: float) -> Tuning:
    """Every candidate of every tuned family on the tuning pads, and the cheapest of each
    family at each cost ratio. Of candidates that cost the same (no tuning pad tells them
    apart) "never" is chosen, so a family that cannot beat replace-on-failure falls back
    to it, else the most cautious (the highest threshold, the youngest age): held-out pads
    may tell them apart by a failure. Too few tuning pads tune nothing
    (:attr:`StudyConfig.min_tune_pads`).

    Args:
        config: The candidates and the cost ratios.
        pads: The tuning pads.
        id_life: Expected life of an ID pad [events]: the unit of the candidate ages.
    """
    d = config.decision_interval
    # Candidate order: never first, then from the most cautious; argmin takes the first.
    cautious = sorted((h * d for h in config.thresholds if h > 0), reverse=True)
    grid = np.array([0.0, *cautious])
    ages = np.array([math.inf, *sorted(a * id_life for a in config.ages if math.isfinite(a))])
    families: dict[PolicyId, tuple[np.ndarray, oc.Outcomes]] = {}
    for name in config.predictors:
        est = pads.estimates[name]
        families[PolicyId("threshold", name)] = (
            grid,
            oc.threshold_outcomes(pads, est["rul_mean"], grid),
        )
        if "rul_lower" in est:
            families[PolicyId("lower-threshold", name)] = (
                grid,
                oc.threshold_outcomes(pads, est["rul_lower"], grid),
            )
    families[FIXED_INTERVAL] = (ages, oc.fixed_interval_outcomes(pads, ages))
    curves = {
        r: {
            fam: oc.cost_per_1000(pads, out, config.weights(r))
            for fam, (_, out) in families.items()
        }
        for r in config.ratios()
    }
    best = {
        r: {fam: float(families[fam][0][int(np.argmin(c))]) for fam, c in by_fam.items()}
        for r, by_fam in curves.items()
    }
    enough = len(pads) >= config.min_tune_pads
    params = {fam: grid for fam, (grid, _) in families.items()}
    return Tuning(len(pads), enough, params, curves, best)
