"""Unmodelled effects an atlas is built with, named as text (docs/results/sim2real.md).

brake_env knows an effect only by its canonical text ``NAME:P=V,...`` (the syntax of
``brakewear simulate --effect``), kept in :attr:`brake_env.model.atlas.AtlasSpec.effects` and
so in the atlas's hash: a model fitted on an atlas with an effect never meets the nominal atlas
in silence. The physics of an effect comes from a plug-in (entry-point group
``brakewear.effects``; sim2real's library is the one shipped), so brake_env imports none of it.

A plug-in is ``resolve(texts, model) -> AtlasEffects``. It raises ValueError, naming the
effect and why, for an effect it does not know or that an atlas cannot hold (an effect of
the thermal history between events needs each event's time and predecessor, which a map
over (layer, speed, mass, slope) has not).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from importlib.metadata import entry_points

import numpy as np
from numpy.typing import NDArray

from brake_env.model.params import BrakeModel
from brake_env.model.physics import EventModifier

F64 = NDArray[np.float64]
GROUP = "brakewear.effects"
# What a sensor effect does to the atlas: the logged mean temperature from the atlas's
# fields (``temp_mean_c``, ``temp_peak_c``, ``stop_time_s``) and the start temperature.
SensorMap = Callable[[Mapping[str, F64], float], F64]


@dataclass(frozen=True, eq=False)
class AtlasEffects:
    """What a list of effects changes in an atlas.

    Attributes:
        keys: Canonical text of each effect, in the order given.
        modifier: The in-event physics (friction, heat, wear), or None.
        measure: The sensor's reading of the mean temperature, or None.
    """

    keys: tuple[str, ...]
    modifier: EventModifier | None = None
    measure: SensorMap | None = None

    def apply_sensor(self, fields: dict[str, F64], start_temp_c: float) -> None:
        """Put the logged mean temperature in place of the true one in an atlas's fields,
        where a sensor effect reads it (the twin compares the log with this field; the wear
        comes from the true physics)."""
        if self.measure is not None:
            measured = np.asarray(self.measure(fields, start_temp_c), dtype=np.float64)
            fields["temp_mean_c"] = measured.reshape(fields["temp_mean_c"].shape)


def resolve_effects(texts: Sequence[str], model: BrakeModel) -> AtlasEffects:
    """The physics of the effects ``texts`` (an empty list: nothing changes).

    Raises:
        ValueError: No plug-in provides effects, or the plug-in refuses one (by name).
    """
    if not texts:
        return AtlasEffects(())
    found = sorted(entry_points(group=GROUP), key=lambda ep: ep.name)
    if not found:
        raise ValueError(
            f"effects {list(texts)} need a package that provides them (entry points"
            f" {GROUP!r}: sim2real, installed with brakewear); none is installed"
        )
    resolved: AtlasEffects = found[0].load()(tuple(texts), model)
    return resolved


def canonical_effects(texts: Sequence[str], model: BrakeModel | None = None) -> tuple[str, ...]:
    """The canonical text of each effect (parameters in the effect's order, 6 digits), so
    that two spellings of one effect give one atlas."""
    return resolve_effects(texts, model or BrakeModel()).keys
