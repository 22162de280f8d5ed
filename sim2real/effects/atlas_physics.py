"""The library's effects inside an atlas: the ``brakewear.effects`` plug-in of
:mod:`brake_env.model.effects`.

- in-event effects change the event physics the atlas is built from (friction, heat, wear);
- sensor effects change the logged mean temperature, read from the atlas's own fields (the
  start temperature of the preset, the event's peak temperature and its duration), as the
  truth simulator reads them (:func:`sim2real.effects.truth.simulate_truth`);
- a between-events effect (Newton cooling) is refused: its start temperature depends on the
  previous event and the time since it, which a map over (layer, speed, mass, slope) cannot
  hold. The rolling-window model needs no physics and is the predictor to use on such logs.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from brake_env.model.effects import F64, AtlasEffects, SensorMap
from brake_env.model.params import BrakeModel
from sim2real.effects.interface import Effect, InEventPhysics, SensorContext, apply_sensor
from sim2real.effects.library import parse_effect


def resolve(texts: Sequence[str], model: BrakeModel) -> AtlasEffects:
    """The physics of ``texts`` (``NAME:P=V,...`` each) for an atlas of ``model``.

    Raises:
        ValueError: An unknown effect or parameter, a value out of range, the same effect
            twice, or an effect an atlas cannot hold (between events), naming it and why.
    """
    effects = parse_effects(texts)
    refused = [e for e in effects if e.kind == "between-events" and not e.is_neutral]
    if refused:
        raise ValueError(
            f"effect {refused[0].key!r} acts between events (each event's start temperature"
            " depends on the previous event and the time since it), which an atlas over"
            " (layer, speed, mass, slope) cannot hold, so the twin and the physics model"
            " cannot take it; on such logs use the rolling-window model (--predictor window)"
        )
    kept = [e for e in effects if not e.is_neutral]
    inevent = [e for e in kept if e.kind == "in-event"]
    sensor = [e for e in kept if e.kind == "sensor"]
    return AtlasEffects(
        keys=tuple(e.key for e in kept),
        modifier=InEventPhysics(inevent, model) if inevent else None,
        measure=_sensor_map(sensor) if sensor else None,
    )


def parse_effects(texts: Sequence[str]) -> list[Effect]:
    """Each text parsed (:func:`~sim2real.effects.library.parse_effect`); an effect named
    twice is refused (which value would hold?)."""
    effects = [parse_effect(t) for t in texts]
    names = [e.name for e in effects]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise ValueError(f"effect(s) {twice} given more than once; give each effect once")
    return effects


def _sensor_map(sensor: list[Effect]) -> SensorMap:
    def measure(fields: Mapping[str, F64], start_temp_c: float) -> F64:
        temp = np.asarray(fields["temp_mean_c"], dtype=np.float64)
        ctx = SensorContext(
            np.full(temp.shape, start_temp_c),
            np.asarray(fields["temp_peak_c"], dtype=np.float64),
            np.asarray(fields["stop_time_s"], dtype=np.float64),
        )
        return apply_sensor(sensor, temp, ctx)

    return measure
