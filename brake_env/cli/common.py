"""What every ``brakewear`` command shares: common options, argument types, the atlas it runs
on, the wear-regime options, the plug-ins. Light on purpose: command modules import it at
parse time (tables and JSON files are in :mod:`brake_env.output`)."""

from __future__ import annotations

import argparse
import math
import shlex
import sys
from collections.abc import Callable, Sequence
from importlib.metadata import entry_points
from pathlib import Path
from typing import Any, NoReturn

from tqdm import tqdm

from brake_env.model.atlas import Atlas, AtlasSpec, cached_atlas
from brake_env.model.params import BrakeModel
from brake_env.model.regime import WearRegime
from brake_env.prognostics.registry import predictor_names
from brake_env.runner import Runner, ray_available


class Parser(argparse.ArgumentParser):
    """The ``brakewear`` parser (its subcommands' too): a bad option is one line on stderr,
    naming the command and the option, and exit code 2 (argparse's usage block is left to
    ``--help``)."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _typed(name: str, parse: Callable[[str], Any]) -> Callable[[str], Any]:
    parse.__name__ = name  # argparse names the type in "invalid <name> value"
    return parse


def int_at_least(lo: int) -> Callable[[str], int]:
    """An argparse ``type`` for integers >= ``lo``, with one clear error otherwise."""

    def parse(text: str) -> int:
        try:
            n = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer >= {lo}, got {text!r}") from None
        if n < lo:
            raise argparse.ArgumentTypeError(f"expected an integer >= {lo}, got {text}")
        return n

    return _typed(f"int>={lo}", parse)


def int_range(lo: int, hi: int) -> Callable[[str], int]:
    """An argparse ``type`` for integers in [``lo``, ``hi``], with one clear error otherwise."""
    at_least = int_at_least(lo)

    def parse(text: str) -> int:
        n = at_least(text)
        if n > hi:
            raise argparse.ArgumentTypeError(f"expected an integer in [{lo}, {hi}], got {text}")
        return n

    return _typed(f"int in [{lo}, {hi}]", parse)


# numpy's SeedSequence takes no negative seed, its legacy RandomState (Optuna's sampler)
# none above 2**32 - 1
MAX_SEED = 2**32 - 1
SEED = int_range(0, MAX_SEED)


def float_in(
    lo: float | None = None,
    hi: float | None = None,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
) -> Callable[[str], float]:
    """An argparse ``type`` for finite floats in [lo, hi] (``*_open``: the bound excluded)."""
    left = "" if lo is None else f"{lo:g} {'<' if lo_open else '<='} "
    right = "" if hi is None else f" {'<' if hi_open else '<='} {hi:g}"
    want = f"a finite number {left}x{right}"

    def parse(text: str) -> float:
        try:
            x = float(text)
        except ValueError:
            x = math.nan
        bad = not math.isfinite(x)
        bad |= lo is not None and (x <= lo if lo_open else x < lo)
        bad |= hi is not None and (x >= hi if hi_open else x > hi)
        if bad:
            raise argparse.ArgumentTypeError(f"expected {want}, got {text!r}")
        return x

    return _typed("float", parse)


POSITIVE = float_in(0.0, lo_open=True)
NONNEGATIVE = float_in(0.0)


def nonempty(text: str) -> str:
    """An argparse ``type`` for a name that is not blank."""
    if not text.strip():
        raise argparse.ArgumentTypeError(f"expected a name, got {text!r}")
    return text.strip()


def name_list(
    valid: Callable[[], Sequence[str]] | None = None, *, allow_empty: bool = False
) -> Callable[[str], tuple[str, ...]]:
    """An argparse ``type`` for a comma-separated list of names (each among ``valid()``
    when given, duplicates dropped); an empty list is refused unless ``allow_empty``."""

    def parse(text: str) -> tuple[str, ...]:
        names = tuple(dict.fromkeys(n.strip() for n in text.split(",") if n.strip()))
        known = list(valid()) if valid is not None else None
        bad = [n for n in names if known is not None and n not in known]
        if bad:
            raise argparse.ArgumentTypeError(f"unknown name(s) {bad}; valid are {known}")
        if not names and not allow_empty:
            among = f" among {','.join(known)}" if known is not None else ""
            raise argparse.ArgumentTypeError(
                f"expected a comma-separated list{among}, got {text!r}"
            )
        return names

    return _typed("list", parse)


def out_dir(text: str) -> str:
    """An argparse ``type`` for an output directory: new, or an existing directory (never a
    file, nor under one). When the command starts, :func:`brake_env.run_lock.hold_output`
    refuses a folder another command's mark names, an unreadable mark, a folder held by a
    running process or one it cannot write (a read-only folder, a dangling or looping
    link), and marks it as this command's (its arguments and a lock) before any work."""
    if not text.strip():
        raise argparse.ArgumentTypeError("expected a directory, got ''")
    path = Path(text)
    for p in (path, *path.parents):
        if p.exists():
            if not p.is_dir():
                what = "is a file" if p == path else f"is under {p}, a file"
                raise argparse.ArgumentTypeError(f"{text} {what}, not a directory")
            break
    return text


def read_atlas(path: str | Path, option: str = "--atlas") -> Atlas:
    """The atlas file ``path`` given by ``option``; one ValueError naming both when it is
    not an atlas ``brakewear`` wrote (a folder, a text file, an .npz without the atlas's
    metadata, or one holding pickled objects, which are never loaded)."""
    p = Path(path)
    if p.is_dir():
        raise ValueError(f"{option} {p}: is a folder; give an atlas .npz file")
    if not p.is_file():
        raise ValueError(f"{option} {p}: no such file; give an atlas .npz file")
    try:
        return Atlas.load(p)
    except ValueError as e:
        text = str(e)
        raise ValueError(
            f"{option} {p}: not an atlas brakewear wrote ({text.removeprefix(f'{p}: ')})"
        ) from None
    except (OSError, KeyError, EOFError, TypeError, AttributeError, UnicodeDecodeError) as e:
        what = f"no {e}" if isinstance(e, KeyError) else f"{type(e).__name__}: {e}"
        raise ValueError(f"{option} {p}: not an atlas brakewear wrote ({what})") from None


def load_atlas(args: argparse.Namespace, preset: str | None = None) -> Atlas:
    """The atlas file given by --atlas (its own parameters; :func:`read_atlas`), else the
    preset's cached atlas."""
    if getattr(args, "atlas", None) and preset is None:
        return read_atlas(args.atlas)
    spec = AtlasSpec(model=BrakeModel.preset(preset or args.preset))
    with tqdm(desc="atlas layers", unit="layer", disable=args.quiet, delay=0.5) as bar:
        return cached_atlas(spec, args.cache_dir, getattr(args, "rebuild", False), bar.update)


def add_common_args(sp: argparse.ArgumentParser, out_default: str) -> None:
    """The options every subcommand takes (plug-in commands use them too)."""
    sp.add_argument("--out", type=out_dir, default=out_default, help="output directory")
    sp.add_argument("--seed", type=SEED, default=0, help="random seed (same seed, same files)")
    sp.add_argument(
        "--preset",
        default="hot-duty",
        choices=["hot-duty", "cold-start"],
        help="brake calibration (docs/calibration.md)",
    )
    sp.add_argument(
        "--cache-dir",
        type=out_dir,
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
        type=nonempty,
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


# Predictor names of the registry: ``--predictors`` takes at least one, ``--agents`` may be
# empty ('' for no agent).
predictor_list = name_list(predictor_names)
agent_list = name_list(predictor_names, allow_empty=True)


def plugins(group: str) -> list[Any]:
    """Installed plug-ins of ``group``, ordered by name (demo stages are named "NN-what")."""
    return sorted(entry_points(group=group), key=lambda ep: ep.name)


def add_wear_args(sp: argparse.ArgumentParser, k_mean: float = WearRegime.k_mean) -> None:
    """Options of the wear regime (:class:`~brake_env.model.regime.WearRegime`)."""
    sp.add_argument("--k-mean", type=POSITIVE, default=k_mean, help="mean Archard coefficient")
    sp.add_argument(
        "--k-std", type=POSITIVE, default=None, help="std of the coefficient (default: k-mean / 10)"
    )
    sp.add_argument(
        "--ood-shift-sigma",
        type=NONNEGATIVE,
        default=WearRegime.ood_shift_sigma,
        help="OOD mean shift in units of --k-std",
    )


def wear_regime(args: argparse.Namespace) -> WearRegime:
    """The WearRegime of the ``--k-mean``, ``--k-std`` and ``--ood-shift-sigma`` options."""
    k_std = args.k_std if args.k_std is not None else 0.1 * args.k_mean
    return WearRegime(args.k_mean, k_std, args.ood_shift_sigma)


def command_line(args: argparse.Namespace) -> str:
    """The command that ran, as a result records it: ``brakewear`` and the arguments
    :func:`brake_env.cli.main.main` parsed (``sys.argv``'s when called otherwise)."""
    return "brakewear " + shlex.join(getattr(args, "argv", sys.argv[1:]))
