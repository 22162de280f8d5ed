"""``brakewear fit --effect`` and ``--diagnosis``: a predictor fitted on the physics with an
unmodelled effect, the preset's or an ``--atlas`` file's physics with the effect added
(docs/results/sim2real.md, "Feeding the diagnosis back").

The effect goes into the atlas's spec (:attr:`brake_env.model.atlas.AtlasSpec.effects`), so
the atlas is built with it (and cached under its own hash like the nominal one), the saved
model records it, and ``predict`` rebuilds that atlas, never the nominal one.
``--diagnosis DIR`` reads the effect a ``brakewear diagnose`` run named, with its fitted
parameters; a diagnosis that abstained is refused with its reason.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from tqdm import tqdm

from brake_env.cli.common import load_atlas
from brake_env.model.atlas import Atlas, AtlasSpec, cached_atlas
from brake_env.model.effects import canonical_effects
from brake_env.model.params import BrakeModel

DIAGNOSIS = "diagnosis.json"


def add_effect_args(sp: argparse.ArgumentParser) -> None:
    """``--effect`` (repeatable) and ``--diagnosis``."""
    sp.add_argument(
        "--effect",
        action="append",
        default=[],
        metavar="NAME:P=V[,...]",
        help="fit on the physics with this unmodelled effect (the syntax of simulate"
        " --effect; repeatable); in-event and sensor effects, not between-events ones",
    )
    sp.add_argument(
        "--diagnosis",
        default=None,
        metavar="DIR",
        help="fit with the effect a brakewear diagnose run named in DIR (its diagnosis.json),"
        " at its fitted parameters; refused if that diagnosis abstained",
    )


def requested_effects(args: argparse.Namespace) -> tuple[str, ...]:
    """The effects of ``--effect`` and ``--diagnosis``, canonical (checked by the plug-in)."""
    texts = list(getattr(args, "effect", None) or [])
    if getattr(args, "diagnosis", None):
        texts.append(diagnosed_effect(args.diagnosis))
    if not texts:
        return ()
    return canonical_effects(texts, BrakeModel.preset(args.preset))


def effect_spec(args: argparse.Namespace, effects: tuple[str, ...]) -> AtlasSpec:
    """The spec of the atlas with ``effects``: the preset's, or that of the ``--atlas`` file
    (its grid and physics, its own effects kept, the new ones added)."""
    base = Atlas.load(args.atlas).spec if getattr(args, "atlas", None) else None
    if base is None:
        return AtlasSpec(model=BrakeModel.preset(args.preset), effects=effects)
    return with_effects(base, effects)


def with_effects(base: AtlasSpec, effects: Sequence[str]) -> AtlasSpec:
    """``base`` (its grid and physics) with ``effects`` added to its own, canonical.

    Raises:
        ValueError: An effect the plug-in does not know or an atlas cannot hold (named).
    """
    both = canonical_effects([*base.effects, *effects], base.model)
    return dataclasses.replace(base, effects=both)


def diagnosed_effect(folder: str | Path) -> str:
    """The named effect of a ``diagnose`` run (``NAME:P=V,...``).

    Raises:
        FileNotFoundError: No ``diagnosis.json`` in ``folder``.
        ValueError: Not a diagnosis, or it abstained (its reason quoted).
    """
    path = Path(folder) / DIAGNOSIS
    if not path.is_file():
        raise FileNotFoundError(f"--diagnosis {folder}: no {DIAGNOSIS} (run brakewear diagnose)")
    try:
        doc: Any = json.loads(path.read_text())
        attribution = doc["attribution"]
        winner, verdict = attribution["winner"], attribution["verdict"]
    except (ValueError, KeyError, TypeError):
        raise ValueError(f"--diagnosis {path}: not a diagnosis (no attribution)") from None
    if winner is None:
        reason = attribution.get("reason", "")
        raise ValueError(
            f"--diagnosis {path}: the diagnosis named no effect ({verdict}: {reason}); there is"
            " nothing to feed back. Fit the nominal twin, or the window model, which needs no"
            " physics"
        )
    if not isinstance(winner, str):
        raise ValueError(f"--diagnosis {path}: attribution.winner is {winner!r}, not a text")
    return winner


def fit_atlas(args: argparse.Namespace) -> Atlas:
    """The atlas ``fit`` uses: the preset's with the requested effects, from the cache."""
    effects = requested_effects(args)
    if not effects:
        return load_atlas(args)
    spec = effect_spec(args, effects)
    with tqdm(desc="atlas layers", unit="layer", disable=args.quiet, delay=0.5) as bar:
        return cached_atlas(spec, args.cache_dir, False, bar.update)
