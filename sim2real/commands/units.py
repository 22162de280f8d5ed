"""``validate-gap``'s units: each validation case is one unit of
:class:`brake_env.runner.Runner` (docs/cluster.md), seeded by its own number, so
its record is the same in this process and on Ray. With a :class:`~brake_env.runner.UnitStore`
from :func:`open_store` each record is saved as its case finishes and an interrupted
validation resumes from the finished cases.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable, Sequence
from typing import Any

from brake_env.model.atlas import Atlas
from brake_env.prognostics.persist import package_version
from brake_env.runner import Runner, Unit
from brake_env.units import UnitStore
from brake_env.units import open_store as units_store
from sim2real.validation.validate import (
    Case,
    ValidationSpec,
    run_case,
    selected_cases,
    summarise,
)


def case_key(case: Case) -> str:
    """The case's unit name (labels repeat across seeds; with the seed it is unique)."""
    return f"{case.label} seed={case.seed}"


def store_settings(
    atlas: Atlas, spec: ValidationSpec, seed: int, case_filter: Sequence[str] | None = None
) -> dict[str, Any]:
    """Everything the records depend on; a store of other settings is not resumed. The
    spec's fields are flat (``n_runs``, ``config.grid_points``...) so that a refusal names
    the one that changed."""
    return {
        "seed": seed,
        **_flat(dataclasses.asdict(spec)),
        "only": list(case_filter) if case_filter else None,
        "atlas_hash": atlas.content_hash,
        "package_version": package_version(),
    }


def _flat(tree: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in tree.items():
        out.update(_flat(v, f"{prefix}{k}.") if isinstance(v, dict) else {f"{prefix}{k}": v})
    return out


def open_store(
    directory: str | os.PathLike[str],
    atlas: Atlas,
    spec: ValidationSpec,
    seed: int,
    case_filter: Sequence[str] | None = None,
) -> UnitStore:
    """The store of finished cases in ``directory`` (created if new, locked, checked:
    :func:`brake_env.units.open_store`), saying how many of the cases are done.

    Raises:
        ValueError: ``directory`` holds cases of a validation with other settings, or
            another run is writing there.
    """
    keys = [case_key(c) for c in selected_cases(spec, seed, case_filter)]
    settings = store_settings(atlas, spec, seed, case_filter)
    return units_store(directory, settings, keys, "validate-gap", noun="cases")


def validate_gap(
    atlas: Atlas,
    spec: ValidationSpec | None = None,
    seed: int = 0,
    progress: Callable[[str], object] | None = None,
    case_filter: Sequence[str] | None = None,
    *,
    runner: Runner | None = None,
    store: UnitStore | None = None,
) -> dict[str, Any]:
    """Run every case; returns the per-case records, the confusion matrix and the targets.

    Args:
        atlas: The nominal model (shared once with every case: :meth:`Runner.share`).
        spec: What to run (default :class:`ValidationSpec`).
        seed: Seeds the cases (each its own number, :func:`cases`).
        progress: Called with ``"label: answer"`` as each case finishes (cases already in
            ``store`` first).
        case_filter: Run only the cases whose label contains one of these.
        runner: Where the cases run (default: one after another in this process). The
            records are the same, in case order, wherever they run.
        store: Saved cases (:func:`open_store` with the same arguments): read instead of
            rerun; new ones are saved as they finish.

    Raises:
        ValueError: ``store`` was opened with other settings.
        brake_env.runner.UnitsFailed: Naming the cases that raised (``label seed=N``),
            after the others finished (and were saved).
    """
    spec = spec or ValidationSpec()
    runner = runner or Runner()
    if store is not None:  # reopening with these settings checks they are the store's
        open_store(store.directory, atlas, spec, seed, case_filter)
    shared = runner.share(atlas)
    todo = selected_cases(spec, seed, case_filter)
    units = [Unit(case_key(c), run_case, (shared, spec, c)) for c in todo]
    done = runner.run(
        units,
        store,
        None if progress is None else lambda _, rec: progress(f"{rec['case']}: {rec['answer']}"),
    )
    records = list(done.values())
    return {"cases": records, **summarise(records)}
