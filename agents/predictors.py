"""Predictors by name, for the command line and the agents (torch and the twin loaded lazily)."""

from __future__ import annotations

from brake_env.atlas import Atlas
from brake_env.predictors import NoPrognostics, Oracle, Predictor

PREDICTORS = ("none", "physics", "data", "twin", "oracle")


def make_predictor(name: str, atlas: Atlas, seed: int = 0) -> Predictor:
    """An unfitted predictor.

    Args:
        name: One of ``PREDICTORS``: ``none`` (mean training life, no condition data),
            ``physics`` (paper 2.3), ``data`` (the MLP of paper 2.2, seeded by ``seed``),
            ``twin`` (the digital twin, paper 2.4), ``oracle`` (the true RUL).
        atlas: The brake atlas (physics and twin use it).
        seed: Seed of the predictors that draw random numbers (only ``data`` does).

    Raises:
        ValueError: An unknown name.
    """
    if name == "none":
        return NoPrognostics()
    if name == "oracle":
        return Oracle()
    if name == "physics":
        from baselines.physics import PhysicsPredictor

        return PhysicsPredictor(atlas)
    if name == "data":
        from baselines.mlp import MLPConfig, MLPPredictor  # imports torch

        return MLPPredictor(MLPConfig(seed=seed))
    if name == "twin":
        from twin import DigitalTwin

        return DigitalTwin(atlas)
    raise ValueError(f"unknown predictor {name!r}; valid are {list(PREDICTORS)}")
