"""What every ``brakewear`` command shares: common options, argument types, the atlas it runs
on, the wear-regime options, the plug-ins. Light on purpose: command modules import it at
parse time (tables and JSON files are in :mod:`brake_env.output`)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from importlib.metadata import entry_points
from typing import Any

from tqdm import tqdm

from brake_env.model.atlas import Atlas, AtlasSpec, cached_atlas
from brake_env.model.params import BrakeModel
from brake_env.model.regime import WearRegime
from brake_env.prognostics.registry import predictor_names
from brake_env.runner import Runner, ray_available


def int_at_least(lo: int) -> Callable[[str], int]:
    """An argparse ``type`` for integers >= ``lo``, with one clear error otherwise."""

    def parse(text: str) -> int:
        n = int(text)
        if n < lo:
            raise argparse.ArgumentTypeError(f"expected an integer >= {lo}, got {text}")
        return n

    parse.__name__ = f"int>={lo}"  # argparse names the type in its error message
    return parse


def load_atlas(args: argparse.Namespace, preset: str | None = None) -> Atlas:
    """The atlas file given by --atlas (its own parameters), else the preset's cached atlas."""
    if getattr(args, "atlas", None) and preset is None:
        return Atlas.load(args.atlas)
    spec = AtlasSpec(model=BrakeModel.preset(preset or args.preset))
    with tqdm(desc="atlas layers", unit="layer", disable=args.quiet, delay=0.5) as bar:
        return cached_atlas(spec, args.cache_dir, getattr(args, "rebuild", False), bar.update)


def add_common_args(sp: argparse.ArgumentParser, out_default: str) -> None:
    """The options every subcommand takes (plug-in commands use them too)."""
    sp.add_argument("--out", default=out_default, help="output directory")
    sp.add_argument("--seed", type=int, default=0, help="random seed (same seed, same files)")
    sp.add_argument(
        "--preset",
        default="hot-duty",
        choices=["hot-duty", "cold-start"],
        help="brake calibration (docs/calibration.md)",
    )
    sp.add_argument(
        "--cache-dir",
        default=None,
        help="atlas cache (default $BRAKEWEAR_CACHE_DIR or ~/.cache/brakewear)",
    )
    sp.add_argument("--quiet", action="store_true", help="no progress bars")


def add_strict_arg(sp: argparse.ArgumentParser) -> None:
    """``--strict``: plausibility findings are errors (:mod:`brake_env.data.plausibility`)."""
    sp.add_argument(
        "--strict",
        action="store_true",
        help="stop on implausible data (readings in other units, runs counted as failures"
        " whose readings say otherwise, lives too short, fitted K far from physical) instead"
        " of warning",
    )


def add_runner_args(sp: argparse.ArgumentParser, workers: int = 0) -> None:
    """Where the command's independent units run (:class:`~brake_env.runner.Runner`)."""
    sp.add_argument(
        "--workers",
        type=int_at_least(0),
        default=workers,
        help="CPUs of a local Ray that runs the units (0: all in this process, no Ray)",
    )
    sp.add_argument(
        "--ray",
        nargs="?",
        const="auto",
        default=None,
        metavar="auto|ADDRESS",
        help="run the units on a Ray cluster (auto: the one this machine belongs to)",
    )


def make_runner(args: argparse.Namespace) -> Runner:
    """The runner ``--workers`` and ``--ray`` ask for. Workers without Ray installed run in
    this process, with a note (the same results, one core)."""
    workers = int(getattr(args, "workers", 0) or 0)
    address = getattr(args, "ray", None)
    if workers and not address and not ray_available():
        print(
            f"note: Ray is not installed, so the {workers} workers run as one, in this process"
            " (pip install 'brakewear[ray]' for parallel units)",
            file=sys.stderr,
        )
        workers = 0
    return Runner(workers=workers, address=address)


def predictor_list(text: str) -> tuple[str, ...]:
    """``--predictors``-style argument: comma-separated names of the predictor registry
    (:func:`~brake_env.prognostics.registry.predictor_names`), at least one."""
    out = tuple(x.strip() for x in text.split(",") if x.strip())
    if not out:
        raise argparse.ArgumentTypeError(f"name at least one predictor of {predictor_names()}")
    bad = [x for x in out if x not in predictor_names()]
    if bad:
        raise argparse.ArgumentTypeError(
            f"unknown predictor(s) {bad}; valid are {predictor_names()}"
        )
    return out


def plugins(group: str) -> list[Any]:
    """Installed plug-ins of ``group``, ordered by name (demo stages are named "NN-what")."""
    return sorted(entry_points(group=group), key=lambda ep: ep.name)


def add_wear_args(sp: argparse.ArgumentParser, k_mean: float = WearRegime.k_mean) -> None:
    """Options of the wear regime (:class:`~brake_env.model.regime.WearRegime`)."""
    sp.add_argument("--k-mean", type=float, default=k_mean, help="mean Archard coefficient")
    sp.add_argument(
        "--k-std", type=float, default=None, help="std of the coefficient (default: k-mean / 10)"
    )
    sp.add_argument(
        "--ood-shift-sigma",
        type=float,
        default=WearRegime.ood_shift_sigma,
        help="OOD mean shift in units of --k-std",
    )


def wear_regime(args: argparse.Namespace) -> WearRegime:
    """The WearRegime of the ``--k-mean``, ``--k-std`` and ``--ood-shift-sigma`` options."""
    k_std = args.k_std if args.k_std is not None else 0.1 * args.k_mean
    return WearRegime(args.k_mean, k_std, args.ood_shift_sigma)
