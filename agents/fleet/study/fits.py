"""The fleet study's predictors as its units get them (:func:`fit_job`): a registered one
fitted on freshly simulated pads (:func:`fit_unit`), a user's saved model loaded, or nothing
(the oracle and the fixed interval read the env).

A user's own fitted models (``fleet-study --model NAME=DIR``): each saved model
(``brakewear fit --out DIR``) is loaded instead of fitted and its RUL drives the same tuned
rule families as the registered predictors'.

A model is taken only on the study's physics: its atlas must be the one the predictors are
made on, or, with ``--effect``, the one the fleet wears on (a model fitted with the effects,
``fit --effect``), checked by hash as ``predict`` checks it, before any unit runs. Units
are keyed to the model's checksum (the study's settings), so another model under the same
name never reuses them.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from agents.fleet.settings import FED_BACK, UNFITTED, FleetStudyConfig
from agents.fleet.study.build import Fitted
from brake_env.data.datasets import DatasetSpec, make_dataset
from brake_env.model.atlas import Atlas
from brake_env.model.regime import WearRegime
from brake_env.prognostics.commands.predict_units import model_checksum
from brake_env.prognostics.persist import load_predictor, read_header
from brake_env.prognostics.registry import fit_predictors, make_predictor


def fit_job(
    config: FleetStudyConfig, predictor: str, nominal: Any, truth: Any
) -> tuple[Callable[..., Fitted], tuple[Any, ...]]:
    """The function and arguments of ``predictor``'s fit unit (not for :data:`UNFITTED`):
    a user's model loaded (keyed to its checksum), any other fitted."""
    if predictor in config.model_names:
        checksum = config.settings()["models"][predictor]
        return load_unit, (config, predictor, nominal, truth, checksum)
    return fit_unit, fit_args(config, predictor, nominal, truth)


def study_fit(
    config: FleetStudyConfig, predictor: str, nominal: Atlas, truth: Atlas
) -> Fitted | None:
    """The study's fit of ``predictor`` (as its units have it); None for the oracle and
    the fixed interval (nothing fitted)."""
    if predictor in UNFITTED:
        return None
    fn, args = fit_job(config, predictor, nominal, truth)
    return fn(*args)


def fit_args(
    config: FleetStudyConfig, predictor: str, nominal: Atlas, truth: Atlas
) -> tuple[Any, ...]:
    """:func:`fit_unit`'s arguments for the study's ``predictor``: ``NAME+effect`` is NAME
    made on the truth's atlas (the diagnosis fed back), any other name on the nominal one."""
    fed = predictor.endswith(FED_BACK)
    name = predictor.removesuffix(FED_BACK)
    return (name, truth if fed else nominal, config.seed, config.n_train_runs, truth)


def fit_unit(
    name: str, atlas: Atlas, seed: int, n_train_runs: int, truth: Atlas | None = None
) -> Fitted:
    """``name`` made on ``atlas`` and fitted on ``n_train_runs`` run-to-failure pads (the
    study's K) simulated on ``truth`` (default ``atlas``: the pads wear as it models them)."""
    if truth is None or truth.content_hash == atlas.content_hash:
        fitted, _ = fit_predictors((name,), atlas, seed, n_train_runs, WearRegime())
        return Fitted(fitted[name], atlas)
    spec = DatasetSpec(n_train=n_train_runs, n_id=0, n_ood_slow=0, n_ood_fast=0,
                       wear=WearRegime())  # fmt: skip
    log = make_dataset(truth, spec, seed).logs["train"]
    return Fitted(make_predictor(name, atlas, seed).fit(log), atlas)


def model_atlas_of(config: FleetStudyConfig, name: str, atlases: tuple[Atlas, ...]) -> Atlas:
    """The one of ``atlases`` (the study's nominal atlas, then the truth's) the model
    ``name`` was fitted with.

    Raises:
        ValueError: None of them: both hashes named, as ``predict`` names them.
    """
    path = config.model_dir(name)
    got = str(read_header(path)["atlas_hash"])
    for atlas in atlases:
        if atlas.content_hash == got:
            return atlas
    want = " or ".join(a.content_hash[:16] for a in dict.fromkeys(atlases))
    raise ValueError(
        f"model {name!r} ({path}) was fitted with atlas {got[:16]}, the study's atlas is"
        f" {want}: fit it on the study's physics (its --atlas or --preset), or give the study"
        " the model's atlas (--atlas)"
    )


def check_models(config: FleetStudyConfig, atlas: Atlas, truth: Atlas) -> None:
    """Every model of the study on its physics (:func:`model_atlas_of`), before any work."""
    for name in config.model_names:
        model_atlas_of(config, name, (atlas, truth))


def load_unit(
    config: FleetStudyConfig, name: str, atlas: Atlas, truth: Atlas, checksum: str
) -> Fitted:
    """The model ``name`` loaded on its atlas (a fit unit's result, not stored).

    Raises:
        ValueError: The model on disk is no longer the one the settings were keyed to.
    """
    path = config.model_dir(name)
    if model_checksum(path) != checksum:
        raise ValueError(f"model {name!r} ({path}) changed since the study started")
    own = model_atlas_of(config, name, (atlas, truth))
    return Fitted(load_predictor(path, own), own)
