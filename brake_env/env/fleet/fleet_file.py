"""Fleet files: a fleet described by a TOML file whose keys are
:class:`~brake_env.env.fleet.config.FleetConfig`'s fields, read by ``gym.make(...,
fleet=FILE)``, the PettingZoo version and every fleet command's ``--fleet``.

A file's top level holds ``FleetConfig``'s plain fields (``n_vehicles = 16``, ``regime =
"mixed"``), a ``[costs]`` table :class:`~brake_env.env.fleet.config.FleetCosts`'s fields and
``currency`` (the name of the unit every cost is in), a ``[noise]`` table the sensor
noise's, and optionally ``name``, ``description``, ``family`` (the env family it is a fleet
of, :mod:`~brake_env.env.fleet.family`; default ``brake``, whose keys are FleetConfig's)
and ``shifts_per_year`` (the shifts a
vehicle could work in a year, which turns a cost per vehicle-shift into one per year; not
a ``FleetConfig`` field: it prices results and changes no episode). A key the file leaves
out keeps the default, as with ``gym.make``'s keywords. The shipped fleets (``small``, ``default``,
``default-mixed``, ``large``; :func:`shipped_fleets`) are files in ``fleets/`` beside this
module, and a name is read as one of them. A bad file gets one ValueError naming the file
and the key.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import os
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.family import BRAKE, family, family_of

FLEETS_DIR = Path(__file__).with_name("fleets")
DEFAULT_CURRENCY = "USD"
# 2 x 12 h shifts a day, every day: FleetConfig.episode_shifts' "730: a year on a 2 x 12 h
# roster" (its holding cost is priced over the same 730).
DEFAULT_SHIFTS_PER_YEAR = 730
_META = ("name", "description", "family")


@dataclass(frozen=True)
class FleetFile:
    """A fleet file read and validated.

    Attributes:
        name: The file's ``name`` (default: its stem).
        source: The path it was read from.
        config: The fleet.
        currency: The unit every cost is in.
        description: The file's ``description`` (may be empty).
        shifts_per_year: Shifts a vehicle could work in a year (windows included): a
            cost per vehicle-shift x vehicles x this is the fleet's cost a year.
    """

    name: str
    source: str
    config: FleetConfig
    currency: str = DEFAULT_CURRENCY
    description: str = ""
    shifts_per_year: int = DEFAULT_SHIFTS_PER_YEAR

    @property
    def family(self) -> str:
        """The name of the env family (:mod:`~brake_env.env.fleet.family`) it is a fleet of."""
        return family_of(self.config).name

    @property
    def digest(self) -> str:
        """A digest of what the file describes (the config and the currency), not of its
        bytes: two files of the same fleet, comments and order aside, share it.
        ``shifts_per_year`` is left out: it only scales the money a study reports (from its
        per-vehicle-shift figures), so the shipped suites' digests stay as they were."""
        payload: dict[str, Any] = {
            "config": dataclasses.asdict(self.config), "currency": self.currency,
        }  # fmt: skip
        if self.family != BRAKE:  # (the brake files' digests stay as they were)
            payload["family"] = self.family
        text = json.dumps(payload, sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:16]


def shipped_fleets() -> tuple[str, ...]:
    """The names of the shipped fleet files."""
    return tuple(sorted(p.stem for p in FLEETS_DIR.glob("*.toml")))


def fleet_path(fleet: str | os.PathLike[str]) -> Path:
    """The file of a shipped fleet's name, or ``fleet`` as a path (which must be a file).

    Raises:
        ValueError: Neither a shipped name nor a readable file, named with the choices.
    """
    text = os.fspath(fleet)
    if text in shipped_fleets():
        return FLEETS_DIR / f"{text}.toml"
    path = Path(text)
    if not path.is_file():
        raise ValueError(
            f"fleet {text!r}: no such file, and not a shipped fleet ({', '.join(shipped_fleets())})"
        )
    return path


def read_fleet(fleet: str | os.PathLike[str] | FleetFile, **overrides: Any) -> FleetFile:
    """The fleet of a shipped name or a TOML file, with ``overrides`` (``FleetConfig``'s
    fields, as ``gym.make``'s keywords) on top.

    Raises:
        ValueError: Not TOML, an unknown key, a value of the wrong kind or out of range:
            one message naming the file and the key.
    """
    if isinstance(fleet, FleetFile):
        base = fleet
    else:
        path = fleet_path(fleet)
        base = _read_file(path, path.stat().st_mtime_ns)
    if not overrides:
        return base
    try:
        config = type(base.config).from_kwargs(base.config, **overrides)
    except (TypeError, ValueError) as e:
        raise ValueError(f"fleet {base.name!r} ({base.source}): {e}") from None
    return dataclasses.replace(base, config=config)


@functools.lru_cache(maxsize=64)
def _read_file(path: Path, mtime_ns: int) -> FleetFile:
    """A fleet file parsed and validated, once per version of the file (a study's config
    reads its fleet at every ``config.fleet``; the key's mtime sees an edit)."""
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise ValueError(f"fleet file {path}: not TOML ({e})") from None
    return _from_dict(data, path)


def _from_dict(data: dict[str, Any], path: Path) -> FleetFile:
    """A fleet file's parsed TOML, validated."""
    data = dict(data)
    meta = {k: data.pop(k) for k in _META if k in data}
    for k, v in meta.items():
        if not isinstance(v, str):
            raise ValueError(f"fleet file {path}: {k} must be a string, got {v!r}")
    currency = DEFAULT_CURRENCY
    if "costs" in data:
        if not isinstance(data["costs"], dict):
            raise ValueError(f"fleet file {path}: costs must be a table ([costs])")
        costs = dict(data["costs"])
        currency = costs.pop("currency", DEFAULT_CURRENCY)
        if not isinstance(currency, str) or not currency.strip():
            raise ValueError(f"fleet file {path}: costs.currency must be a name, got {currency!r}")
        data["costs"] = costs
    if "noise" in data and not isinstance(data["noise"], dict):
        raise ValueError(f"fleet file {path}: noise must be a table ([noise])")
    name = meta.get("name", path.stem)
    year = _shifts_per_year(data.pop("shifts_per_year", DEFAULT_SHIFTS_PER_YEAR), path)
    try:
        config = family(meta.get("family", BRAKE)).config.from_kwargs(None, **data)
    except (TypeError, ValueError) as e:
        raise ValueError(f"fleet file {path}: {e}") from None
    return FleetFile(name, str(path), config, currency, meta.get("description", ""), year)


def _shifts_per_year(v: Any, path: Path) -> int:
    """The file's ``shifts_per_year``: a whole number of shifts, 1 to 366 x 24 (hourly)."""
    if isinstance(v, bool) or not isinstance(v, int) or not 1 <= v <= 366 * 24:
        raise ValueError(f"fleet file {path}: shifts_per_year must be a whole number of shifts"
                         f" in [1, 8784], got {v!r}")  # fmt: skip
    return v


def fleet_toml(fleet: FleetFile) -> str:
    """A fleet as the TOML of a fleet file (every field written; read back equal)."""
    d = dataclasses.asdict(fleet.config)
    costs, noise = d.pop("costs"), d.pop("noise")
    lines = [f"name = {json.dumps(fleet.name)}"]
    if fleet.family != BRAKE:
        lines.append(f"family = {json.dumps(fleet.family)}")
    if fleet.description:
        lines.append(f"description = {json.dumps(fleet.description)}")
    lines += [f"{k} = {_toml_value(v)}" for k, v in d.items()]
    lines.append(f"shifts_per_year = {fleet.shifts_per_year}")
    lines += ["", "[costs]", f"currency = {json.dumps(fleet.currency)}"]
    lines += [f"{k} = {_toml_value(v)}" for k, v in costs.items()]
    lines += ["", "[noise]", *(f"{k} = {_toml_value(v)}" for k, v in noise.items())]
    return "\n".join(lines) + "\n"


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return json.dumps(v)
    return repr(v)
