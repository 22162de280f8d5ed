"""The wheel works without the source tree: build it, install it in a fresh venv, run
``brakewear train`` from a folder outside the repository (its package data included)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _copy_sources(dest: Path) -> None:
    """What the wheel is built from, without build leftovers or the editable install's
    metadata (building in the checkout would write build/ into it)."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())
    packages = {p.rstrip("*") for p in project["tool"]["setuptools"]["packages"]["find"]["include"]}
    ignore = shutil.ignore_patterns("__pycache__", "*.egg-info", "build")
    for name in sorted(packages):
        shutil.copytree(ROOT / name, dest / name, ignore=ignore)
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(ROOT / name, dest / name)


def _run(*cmd: str | Path, cwd: Path, env: dict[str, str] | None = None) -> str:
    proc = subprocess.run(
        [str(c) for c in cmd], cwd=cwd, env=env, capture_output=True, text=True, timeout=300
    )
    assert proc.returncode == 0, f"{cmd} failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    return proc.stdout


@pytest.mark.slow
def test_wheel_installs_and_trains_outside_the_source_tree(tmp_path: Path) -> None:
    src, dist, venv, work = (tmp_path / d for d in ("src", "dist", "venv", "work"))
    _copy_sources(src)
    # No build isolation: offline, with the setuptools of the test's environment.
    build = ["wheel", "--no-deps", "--no-build-isolation", "-q", "-w", dist, src]
    _run(sys.executable, "-m", "pip", *build, cwd=tmp_path)
    (wheel,) = dist.glob("brakewear-*.whl")

    # A fresh venv that sees the test environment's dependencies (torch, SB3, ...) as a
    # plain path: its .pth files, the editable install's finder among them, are not run.
    _run(sys.executable, "-m", "venv", "--without-pip", venv, cwd=tmp_path)
    python = venv / "bin" / "python"
    purelib = "import sysconfig; print(sysconfig.get_paths()['purelib'])"
    site = Path(_run(python, "-c", purelib, cwd=tmp_path).strip())
    (site / "test_deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    # --ignore-installed: never touch the editable install that the venv can see.
    install = ["install", "-q", "--no-deps", "--no-index", "--ignore-installed"]
    _run(python, "-m", "pip", *install, wheel, cwd=tmp_path)

    work.mkdir()
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    files = "import brake_env, agents; print(brake_env.__file__, agents.__file__)"
    where = _run(python, "-c", files, cwd=work, env=env)
    assert all(Path(p).is_relative_to(site) for p in where.split()), where

    # A tiny budget: fast pads (life ~2.4e4 events), short episodes, a few held-out pads.
    train = (
        "train --predictor none --timesteps 1024 --n-train-runs 1 --curve-pads 2"
        " --eval-pads 2 --episode-events 5000 --k-mean 1e-5 --out out --quiet"
    )
    _run(venv / "bin" / "brakewear", *train.split(), cwd=work, env=env)
    out = work / "out"
    assert (out / "model.zip").is_file() and (out / "evaluation.json").is_file()
    # The hyperparameters came from the installed package's agents/learning/hyperparams/none.toml.
    with open(ROOT / "agents" / "learning" / "hyperparams" / "none.toml", "rb") as f:
        shipped = tomllib.load(f)["ppo"]
    assert json.loads((out / "train.json").read_text())["hyperparams"] == shipped
    # A pip user finds RL Zoo's --conf-file through the command, inside the installed package.
    zoo = Path(_run(venv / "bin" / "brakewear", "hyperparams", "--zoo", cwd=work, env=env).strip())
    assert (
        zoo.is_relative_to(site)
        and zoo.read_text()
        == (ROOT / "agents" / "learning" / "hyperparams" / "rl_zoo3" / "ppo.yml").read_text()
    )
    # The fleet files and suites are package data: the installed package reads them.
    shipped = (
        "from brake_env.env.fleet.fleet_file import shipped_fleets;"
        " from agents.fleet.benchmark.suite import shipped_suites, read_suite;"
        " print(shipped_fleets(), shipped_suites(),"
        " read_suite('large').fleet_file.config.n_vehicles)"
    )
    got = _run(python, "-c", shipped, cwd=work, env=env)
    assert "'default-mixed'" in got and got.split()[-1] == "24", got
    # Every data file of the benchmark (suites, baselines and their distilled agents, entries
    # and their models, training configs) and every fleet file is in the installed package,
    # byte for byte.
    folders = ("agents/fleet/benchmark", "brake_env/env/fleet/fleets")
    data = [f for d in folders for f in sorted((ROOT / d).rglob("*"))
            if f.suffix in (".toml", ".json", ".zip", ".npz")]  # fmt: skip
    assert {".zip", ".npz"} <= {f.suffix for f in data} and len(data) > 10
    for f in data:
        installed = site / f.relative_to(ROOT)
        assert installed.is_file() and installed.read_bytes() == f.read_bytes(), installed
