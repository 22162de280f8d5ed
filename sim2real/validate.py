"""Validation of the diagnosis on data whose effect is withheld from the model.

For each library effect at a few magnitudes inside its range, truth logs are simulated with
the effect, the nominal model (which does not know it) diagnoses them, and the attribution
is recorded. Controls: no effect at all (the answer must be "none") and an effect that is
not in the candidate library (pad glazing: friction falls as the pad wears; the answer
must be "none" too: abstention, no false attribution).

Truth runs are shorter than the paper's (K ten times larger, ~1.2e4 events per pad) and
fewer (8 per case), to keep the runtime to minutes; the diagnosis sees 4 calibration and 4
held-out runs.

Each case is one unit of :class:`brake_env.runner.Runner` (README "Running on a cluster"):
seeded by its own number, so its record is the same in this process and on Ray. With a
:class:`~brake_env.runner.UnitStore` from :func:`open_store` each record is saved as its
case finishes and an interrupted validation resumes from the finished cases.
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from brake_env.data.datasets import DatasetSpec
from brake_env.model.atlas import Atlas
from brake_env.model.regime import WearRegime
from brake_env.prognostics.persist import package_version
from brake_env.runner import Runner, Unit
from brake_env.units import UnitStore
from brake_env.units import open_store as units_store
from sim2real.attribute import NONE
from sim2real.config import DiagnosisConfig
from sim2real.diagnose import diagnose
from sim2real.effects import Effect, EventState, Param
from sim2real.library import LIBRARY
from sim2real.rul import rul_scorer
from sim2real.truth import TruthSpec, simulate_truth


class PadGlazing(Effect):
    """Out-of-library control: friction falls as the pad wears (glazed, thin pad).

    mu = mu(T) (1 - g (1 - V)). Not among the diagnosis candidates.
    """

    name = "pad_glazing"
    kind = "in-event"
    summary = "friction falls linearly with pad wear (not a candidate)"
    params = (Param("g", "-", 0.0, 0.0, 0.3, 0.15, "friction loss at zero volume"),)

    def friction_factor(self, s: EventState) -> ArrayLike:
        return 1.0 - self["g"] * (1.0 - s.volume_frac)


@dataclass(frozen=True)
class ValidationSpec:
    """What ``validate_gap`` runs.

    Attributes:
        seeds_mid: Seeds per library effect at its mid magnitude [-].
        low_magnitude: Also run each effect once at half its mid distance from neutral.
        n_controls: No-effect control cases [-].
        n_out_of_library: Cases of the out-of-library effect (pad glazing) [-].
        n_runs: Runs per case (half calibration, half held-out) [-].
        k_mean: Mean Archard coefficient of the truth runs [-] (10x the paper's: short runs).
        with_rul: Score the twin's RUL RMSE before/after (needs ``twin.DigitalTwin``).
        route_block_events: 0 for independent operating conditions (the paper); N > 0 for
            haul-road and pit blocks of N events (``brake_env.model.simulator.AlternatingRoutes``).
    """

    seeds_mid: int = 3
    low_magnitude: bool = False
    n_controls: int = 4
    n_out_of_library: int = 2
    n_runs: int = 8
    k_mean: float = 2e-5
    with_rul: bool = True
    route_block_events: int = 0
    config: DiagnosisConfig = field(default_factory=DiagnosisConfig)


@dataclass(frozen=True, eq=False)
class Case:
    """One validation case.

    Attributes:
        label: Shown in reports (``name:param=value``, ``control``, ...).
        expected: The answer a correct diagnosis gives (an effect name, or ``NONE``).
        effects: The effects the truth logs are simulated with (withheld from the model).
        seed: Seeds the truth logs and the diagnosis.
    """

    label: str
    expected: str
    effects: list[Effect]
    seed: int


def cases(spec: ValidationSpec, seed: int) -> list[Case]:
    """Every validation case: each library effect at its mid magnitude (and half of it),
    the no-effect controls and the out-of-library effect."""
    out: list[Case] = []
    for cls in LIBRARY:
        p = cls.params[0]
        mags = [("mid", p.mid)]
        if spec.low_magnitude:
            mags.append(("low", p.neutral + 0.5 * (p.mid - p.neutral)))
        for tag, val in mags:
            for _ in range(spec.seeds_mid if tag == "mid" else 1):
                label = f"{cls.name}:{p.name}={val:g}"
                out.append(Case(label, cls.name, [cls(**{p.name: val})], seed * 1000 + len(out)))
    for _ in range(spec.n_controls):
        out.append(Case("control", NONE, [], seed * 1000 + len(out)))
    for _ in range(spec.n_out_of_library):
        out.append(Case(_OOL_CASE, NONE, [PadGlazing(g=0.15)], seed * 1000 + len(out)))
    return out


def selected_cases(
    spec: ValidationSpec, seed: int, case_filter: Sequence[str] | None = None
) -> list[Case]:
    """The cases :func:`validate_gap` runs: those whose label contains any of
    ``case_filter`` (all without one), in the order of :func:`cases`."""
    return [
        c for c in cases(spec, seed) if not case_filter or any(f in c.label for f in case_filter)
    ]


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


def run_case(atlas: Atlas, spec: ValidationSpec, case: Case) -> dict[str, Any]:
    """Simulate one case's truth logs, diagnose them and record the attribution."""
    ds = DatasetSpec(
        n_train=spec.n_runs,
        n_id=0,
        n_ood_slow=0,
        n_ood_fast=0,
        wear=WearRegime(spec.k_mean, 0.1 * spec.k_mean),
        route_block_events=spec.route_block_events,
    )
    t0 = time.perf_counter()
    log = simulate_truth(atlas.spec, case.effects, TruthSpec(ds), seed=case.seed)["train"]
    t_sim = time.perf_counter() - t0
    rul = rul_scorer(atlas) if spec.with_rul else None
    res = diagnose(log, atlas, config=spec.config, seed=case.seed, rul=rul)
    a, q = res.summary["attribution"], res.summary["quantify"]
    ch = q["channel"]
    rec: dict[str, Any] = {
        "case": case.label,
        "expected": case.expected,
        "answer": a["verdict"],
        "seed": case.seed,
        "correct": a["verdict"] == case.expected,
        "reason": a["reason"],
        "fitted": a["winner"],
        "channel": ch,
        "gap_before": q["before"][ch]["structured_gap"],
        "gap_after": q["after"][ch]["structured_gap"] if "after" in q else None,
        "shrink": q["shrink"][ch] if "shrink" in q else None,
        "seconds_simulate": t_sim,
        "seconds_diagnose": time.perf_counter() - t0 - t_sim,
    }
    return {**rec, **_rul_record(q.get("rul") or {})}


def _rul_record(rul_q: dict[str, Any]) -> dict[str, float]:
    """The twin's RUL RMSE before and after, and its shrink, where they were scored."""
    b, af = rul_q.get("before"), rul_q.get("after")
    out = {}
    if b and "rmse" in b:
        out["rul_before"] = b["rmse"]
    if b and af and "rmse" in b and "rmse" in af:
        out["rul_after"] = af["rmse"]
        out["rul_shrink"] = 1.0 - af["rmse"] / max(b["rmse"], 1e-9)
    return out


def summarise(records: list[dict[str, Any]]) -> dict[str, Any]:
    """Confusion matrix (expected x answer) and the validation targets."""
    labels = sorted(
        {r["expected"] for r in records} | {r["answer"] for r in records},
        key=lambda x: (x == NONE, x),
    )
    # Rows: the withheld effect (controls "none", the out-of-library effect by its name).
    rows = [lab for lab in labels if lab != NONE]
    if any(_is_ool(r) for r in records):
        rows.append(_OOL)
    rows.append(NONE)
    conf = {e: {a: 0 for a in labels} for e in rows}
    for r in records:
        conf[_OOL if _is_ool(r) else r["expected"]][r["answer"]] += 1
    return {"labels": labels, "rows": rows, "confusion": conf, "targets": targets(records)}


def targets(records: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """Each target of the validation: measured value, required value, cases, met."""
    lib = [r for r in records if r["expected"] != NONE and _is_mid(r["case"])]
    ctrl = [r for r in records if r["case"] == "control"]
    ool = [r for r in records if _is_ool(r)]
    hits = [r for r in lib if r["correct"] and r["shrink"] is not None]
    # The twin's RUL is "affected" where its error on the effect's runs exceeds 1.5x its
    # median error on the no-effect controls (otherwise there is nothing to shrink).
    ctrl_rul = [r["rul_before"] for r in ctrl if "rul_before" in r]
    floor = 1.5 * float(np.median(ctrl_rul)) if ctrl_rul else 0.0
    rul = [r["rul_shrink"] for r in hits if "rul_shrink" in r and r["rul_before"] > floor]
    shrink = [r["shrink"] for r in hits]
    out: dict[str, dict[str, Any]] = {
        "top1_mid_library": _target(_frac([r["correct"] for r in lib]), 0.9, len(lib)),
        "none_on_controls": _target(_frac([r["correct"] for r in ctrl]), 0.95, len(ctrl)),
        "abstain_out_of_library": _target(_frac([r["correct"] for r in ool]), 1.0, len(ool)),
        "gap_shrink_median": _target(float(np.median(shrink)) if hits else None, 0.7, len(hits)),
        "gap_shrink_min": _target(float(min(shrink)) if hits else None, 0.7, len(hits)),
        "rul_rmse_shrink_median_affected": {
            **_target(float(np.median(rul)) if rul else None, 0.5, len(rul)),
            "affected_above_events": floor,
        },
    }
    for t in out.values():
        t["met"] = t["value"] is not None and t["value"] >= t["target"]
    return out


def _target(value: float | None, target: float, n: int) -> dict[str, Any]:
    return {"value": value, "target": target, "n": n}


def _frac(xs: list[bool]) -> float | None:
    return float(np.mean(xs)) if xs else None


_OOL_CASE = "pad_glazing:g=0.15 (not a candidate)"


def _is_ool(record: dict[str, Any]) -> bool:
    return "not a candidate" in record["case"]


_OOL = "pad_glazing (not a candidate)"


def _is_mid(case: str) -> bool:
    name, _, rest = case.partition(":")
    for cls in LIBRARY:
        if cls.name == name:
            p = cls.params[0]
            return rest == f"{p.name}={p.mid:g}"
    return False
