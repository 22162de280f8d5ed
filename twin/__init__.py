"""The digital twin: state estimation, wear-coefficient identification, prognosis (paper 2.4).

:class:`DigitalTwin` is a predictor of the ``brake_env.prognostics.protocol`` protocol: a Bayesian
filter over the Archard coefficient K through the atlas, updated at every braking event;
:class:`TwinFleet` (``DigitalTwin.fleet``) runs many pads through it at once.
:mod:`twin.reference` keeps the paper's literal iterative procedure to test it against.
"""

from __future__ import annotations

from twin.calibration import fit_calibration
from twin.config import TwinCalibration, TwinConfig
from twin.fleet import TwinFleet
from twin.twin import DigitalTwin

__all__ = [
    "DigitalTwin",
    "TwinCalibration",
    "TwinConfig",
    "TwinFleet",
    "fit_calibration",
]
