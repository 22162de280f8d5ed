"""The value of diagnosing an unmodelled effect in maintenance cost: one ``fleet-study
--effect`` whose units were run in several ``--out`` folders (a unit redone apart, e.g. after
a failure, when the code that ran has changed so that the first folder no longer resumes),
summarised as ``fleet-study`` summarises a study.

Every folder's stored units are read back, each checked against its own digest and its
arrays'; the folders' unit settings must be equal but for the code digest (the same fleet,
episodes, budgets, effects and atlases, so the same evaluation episodes to pair over). The
study's settings come from the ``costs.json`` of the first folder that has one, its
predictors from ``--predictors``. Prints the study's tables (rows, ranking, the effect's
paired differences) and writes the summary as JSON with ``--json``.

Run: ``.venv/bin/python benchmarks/analysis/fleet_effect_cost.py out/fleet-effect
out/fleet-effect-twin --predictors oracle,window,twin,twin+effect --json
out/fleet-effect-logs/summary.json``
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path
from typing import Any

from agents.fleet.settings import FleetStudyConfig
from agents.fleet.study.run import report
from agents.fleet.study.summary import summarise
from agents.fleet.study.units import UNITS, study_keys
from brake_env.output import read_arrays, write_json
from brake_env.units import SETTINGS, _content_digest, _decode


def read_units(folder: Path) -> tuple[dict[str, Any], dict[str, Any]]:
    """(the unit settings of a study folder, every unit stored there by key), each unit
    checked against its digests."""
    units_dir = folder / UNITS
    settings = json.loads((units_dir / SETTINGS).read_text())
    got = {}
    for path in sorted(units_dir.glob("*.json")):
        if path.name == SETTINGS:
            continue
        doc = json.loads(path.read_text())
        if doc.get("sha256") != _content_digest(doc):
            raise SystemExit(f"{path}: the unit was changed since it was written")
        sha = doc.get("arrays_sha256")
        arrays = read_arrays(path.with_suffix(".npz"), sha, doc["key"]) if sha else {}
        got[doc["key"]] = _decode(doc["result"], arrays)
    return settings, got


def study_config(folders: list[Path], predictors: tuple[str, ...]) -> FleetStudyConfig:
    for f in folders:
        if (f / "costs.json").is_file():
            d = json.loads((f / "costs.json").read_text())["config"]
            return dataclasses.replace(FleetStudyConfig.from_dict(d), predictors=predictors)
    raise SystemExit(f"no costs.json in any of {[str(f) for f in folders]}")


def merged(folders: list[Path], config: FleetStudyConfig) -> tuple[dict[str, Any], dict[str, Any]]:
    """(the folders' common settings, the study's units from whichever folder holds them)."""
    common: dict[str, Any] | None = None
    units: dict[str, Any] = {}
    for f in folders:
        settings, got = read_units(f)
        settings = {k: v for k, v in settings.items() if k != "code"}
        if common is not None and settings != common:
            diff = sorted(k for k in {*settings, *common} if settings.get(k) != common.get(k))
            raise SystemExit(f"{f}: unit settings differ from the first folder's: {diff}")
        common = settings
        units.update({k: v for k, v in got.items() if k not in units})
    missing = [k for k in study_keys(config) if k not in units]
    if missing:
        raise SystemExit(f"units missing from every folder: {missing}")
    assert common is not None
    return common, units


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folders", nargs="+", type=Path, help="fleet-study --out folders")
    ap.add_argument("--predictors", required=True, help="comma-separated, as the study's")
    ap.add_argument("--json", type=Path, default=None, help="write the summary here")
    ap.add_argument("--resamples", type=int, default=4000, help="bootstrap resamples")
    a = ap.parse_args()
    config = study_config(a.folders, tuple(a.predictors.split(",")))
    settings, units = merged(a.folders, config)
    summary = summarise(config, units, a.resamples)
    if config.effects:
        summary["effect"].update(atlas=settings["atlas"], truth_atlas=settings["truth_atlas"])
    summary["folders"] = [str(f) for f in a.folders]
    print(report(summary))
    if a.json is not None:
        write_json(summary, a.json)
        print(f"wrote {a.json}")


if __name__ == "__main__":
    main()
