"""Building the ``brakewear`` parser loads ``agents.commands.cli`` as a plug-in; it must import
neither torch nor Stable-Baselines3 (they take seconds), only the commands that train do."""

from __future__ import annotations

import subprocess
import sys

CHECK = (
    "import sys; from brake_env.cli.main import build_parser; build_parser();"
    " print('torch' in sys.modules, 'stable_baselines3' in sys.modules)"
)


def _run(code: str) -> list[str]:
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout.split()


def test_the_parser_imports_neither_torch_nor_sb3() -> None:
    assert _run(CHECK) == ["False", "False"]


def test_the_agents_plugin_defers_training_and_comparison() -> None:
    code = (
        "import sys, argparse; from agents.commands.cli import register;"
        " register(argparse.ArgumentParser().add_subparsers());"
        " print(*(m in sys.modules for m in"
        " ('torch', 'stable_baselines3', 'matplotlib', 'agents.commands.compare')))"
    )
    assert _run(code) == ["False"] * 4


def test_train_and_compare_take_the_wear_regime_options() -> None:
    import argparse

    from agents.commands.cli import register
    from brake_env.cli.common import wear_regime

    parser = argparse.ArgumentParser()
    register(parser.add_subparsers(dest="command"))
    for command in ("train", "compare"):
        args = parser.parse_args([command, "--k-mean", "1e-5", "--ood-shift-sigma", "4"])
        wear = wear_regime(args)
        assert (wear.k_mean, wear.k_std, wear.ood_shift_sigma) == (1e-5, 1e-5 / 10, 4.0)


def test_brakewear_atlas_imports_neither_torch_nor_sb3(tmp_path) -> None:
    code = (
        "import sys; from brake_env.cli.main import main;"
        f" rc = main(['atlas', '--out', {str(tmp_path)!r}, '--quiet']);"
        " print(rc, 'torch' in sys.modules, 'stable_baselines3' in sys.modules)"
    )
    assert _run(code)[-3:] == ["0", "False", "False"]  # after the atlas table
    assert (tmp_path / "atlas.npz").is_file()
