"""Shared fixtures: atlases are built once per session and cached in a temporary folder."""

from __future__ import annotations

import functools
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from brake_env.model.atlas import Atlas, AtlasSpec, cached_atlas


def _session_cache(request: pytest.FixtureRequest, factory: pytest.TempPathFactory) -> Path:
    """This run's atlas cache: under xdist one folder for both workers (and the commands
    they start), so that each atlas is built once a run, not once a worker; the cache
    writes each file atomically (Atlas.save), so two workers may build one at once."""
    if hasattr(request.config, "workerinput"):  # an xdist worker: basetemp is <run>/popen-gwN
        cache = factory.getbasetemp().parent / "atlas-cache"
        cache.mkdir(exist_ok=True)
        return cache
    return factory.mktemp("atlas-cache")


@pytest.fixture(autouse=True, scope="session")
def _isolated_cache(
    request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[None]:
    # Never touch the user's ~/.cache from the tests, nor leave SB3's logger folders in /tmp
    # (SB3 makes one per learn() that has no tensorboard_log).
    mp = pytest.MonkeyPatch()
    mp.setenv("BRAKEWEAR_CACHE_DIR", str(_session_cache(request, tmp_path_factory)))
    mp.setenv("SB3_LOGDIR", str(tmp_path_factory.mktemp("sb3-logs")))
    yield
    mp.undo()


@pytest.fixture(scope="session")
def atlas(_isolated_cache: None) -> Atlas:
    """The default atlas (the documented calibration), through the run's cache: the
    commands and envs that load the default atlas find it there."""
    return cached_atlas(AtlasSpec())


@pytest.fixture(scope="session")
def small_atlas(_isolated_cache: None) -> Atlas:
    """A coarse atlas of the default physics for fast simulator and dataset tests."""
    return cached_atlas(AtlasSpec(n_speed=6, n_mass=3, n_slope=5))


_RAY: dict[str, Any] = {}  # the local Ray's Runner while it is up


@pytest.fixture
def local_ray() -> Any:
    """A local Ray with 2 CPUs, started once for the files that use it (~4 s); Runners
    join it. It is shut down as soon as the last of those files is done (see
    pytest_runtest_teardown): left up, its idle processes take CPU from every later test.
    Tests that use it are skipped where Ray is not installed."""
    ray = pytest.importorskip("ray")
    from brake_env.runner import Runner

    if "runner" not in _RAY:  # starts Ray with the project's import path for the workers
        _RAY["runner"] = Runner(workers=2)
    return ray


def _stop_ray() -> None:
    runner = _RAY.pop("runner", None)
    if runner is not None:
        runner.__exit__()


def pytest_runtest_teardown(item: pytest.Item, nextitem: pytest.Item | None) -> None:
    """Ray down once the next test is not in a file that uses it: the collection puts those
    files first and together (pytest_collection_modifyitems), so Ray starts once."""
    if "runner" in _RAY and (nextitem is None or not _uses_ray(nextitem.path)):
        _stop_ray()


def pytest_sessionfinish() -> None:
    _stop_ray()


@functools.cache
def _uses_ray(path: Path) -> bool:
    """Whether a test file uses the session's local Ray. Read from its text: the xdist
    controller, which schedules, sees the tests' node ids but not their fixtures."""
    return "local_ray" in path.read_text()


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """For ``pytest -n 2 --dist loadfile`` (make test), the longest work first: the files
    that use Ray (one unit of work, see below), then the files with a test marked slow,
    then the rest in their usual order. A long file started last would keep one worker
    busy after the other has finished."""
    slow = {item.path for item in items if item.get_closest_marker("slow")}
    items.sort(key=lambda item: 0 if _uses_ray(item.path) else 1 if item.path in slow else 2)


@pytest.hookimpl(tryfirst=True, optionalhook=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log: Any) -> Any:
    """``--dist loadfile``: whole files per worker (their module fixtures built once), in
    the order collected, and every file that uses the local Ray on the same worker, so
    that one Ray is started, not one per worker. (pytest-xdist's ``xdist_group`` marks
    do not work with pytest 9: xdist 3.8 renames ``item._nodeid``, which pytest 9 no
    longer reads, so every test was scheduled on its own.)"""
    if config.getvalue("dist") != "loadfile":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class FilesRayTogether(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            file = nodeid.split("::", 1)[0]
            return "ray" if _uses_ray(config.rootpath / file) else file

    config.option.loadscopereorder = False  # the collection's order: longest work first
    return FilesRayTogether(config, log)
