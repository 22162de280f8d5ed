"""Predictors by name: the built-in ones and the plug-ins of the ``brakewear.predictors``
entry-point group.

A downstream package (``baselines``, ``twin``, or a user's own) declares
``name = "module:factory"`` in that group, where ``factory(atlas, seed) -> Predictor``
returns an unfitted predictor. Only the names are read until a predictor is asked for, so
listing them imports neither torch nor the twin, and ``brake_env`` never imports its
downstream packages (docs/architecture.md).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from functools import cache
from importlib.metadata import entry_points

from brake_env.data.datasets import DatasetSpec, make_dataset
from brake_env.model.atlas import Atlas
from brake_env.model.regime import WearRegime
from brake_env.prognostics.protocol import NoPrognostics, Oracle, Predictor

GROUP = "brakewear.predictors"
Factory = Callable[[Atlas, int], Predictor]
# The predictor that reads the truth instead of the events: no fit, and an env or a study
# gives it the true RUL (studies list it last, as the upper bound of the comparison).
ORACLE = Oracle.name

_BUILTIN: dict[str, Factory] = {
    NoPrognostics.name: lambda atlas, seed: NoPrognostics(),
    ORACLE: lambda atlas, seed: Oracle(),
}


@cache
def _plugins() -> dict[str, object]:
    return {ep.name: ep for ep in entry_points(group=GROUP)}


# Tables and studies list predictors from the least informed to the oracle, the paper's
# three in its order; other plug-ins go before the oracle, in name order.
_ORDER = ("none", "physics", "data", "twin")


def predictor_names() -> tuple[str, ...]:
    """Every predictor name: ``none``, the paper's three, other plug-ins, ``oracle``."""
    names = {*_BUILTIN, *_plugins()}
    known = [n for n in _ORDER if n in names]
    others = sorted(names - {*known, ORACLE})
    return (*known, *others, ORACLE)


def make_predictor(name: str, atlas: Atlas, seed: int = 0) -> Predictor:
    """An unfitted predictor.

    Args:
        name: ``none`` (mean training life, no condition data), ``oracle`` (the true RUL)
            or a plug-in's name: ``physics`` (paper 2.3), ``data`` (the MLP of paper 2.2),
            ``twin`` (the digital twin, paper 2.4), ...
        atlas: The brake atlas (physics and twin use it).
        seed: Seed of the predictors that draw random numbers.

    Raises:
        ValueError: An unknown name.
    """
    if name in _BUILTIN:
        return _BUILTIN[name](atlas, seed)
    ep = _plugins().get(name)
    if ep is None:
        raise ValueError(f"unknown predictor {name!r}; valid are {list(predictor_names())}")
    factory: Factory = ep.load()  # type: ignore[attr-defined]
    return factory(atlas, seed)


def fit_predictors(
    names: tuple[str, ...],
    atlas: Atlas,
    seed: int,
    n_train_runs: int,
    wear: WearRegime | None = None,
) -> tuple[dict[str, Predictor], dict[str, float]]:
    """Each named predictor fitted on ``n_train_runs`` freshly simulated training pads whose
    K follows ``wear`` (default :class:`WearRegime`'s); and the seconds each fit took. The
    studies of ``agents`` (single pad and fleet) fit their predictors here."""
    spec = DatasetSpec(
        n_train=n_train_runs, n_id=0, n_ood_slow=0, n_ood_fast=0, wear=wear or WearRegime()
    )
    train_log = make_dataset(atlas, spec, seed).logs["train"]
    fitted, seconds = {}, {}
    for name in names:
        t0 = time.perf_counter()
        fitted[name] = make_predictor(name, atlas, seed).fit(train_log)
        seconds[name] = time.perf_counter() - t0
    return fitted, seconds
