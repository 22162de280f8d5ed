"""Shared fixtures: atlases are built once per session and cached in a temporary folder."""

from __future__ import annotations

import pytest

from brake_env.model.atlas import Atlas, AtlasSpec


@pytest.fixture(autouse=True, scope="session")
def _isolated_cache(tmp_path_factory: pytest.TempPathFactory) -> None:
    # Never touch the user's ~/.cache from the tests, nor leave SB3's logger folders in /tmp
    # (SB3 makes one per learn() that has no tensorboard_log).
    mp = pytest.MonkeyPatch()
    mp.setenv("BRAKEWEAR_CACHE_DIR", str(tmp_path_factory.mktemp("atlas-cache")))
    mp.setenv("SB3_LOGDIR", str(tmp_path_factory.mktemp("sb3-logs")))
    yield
    mp.undo()


@pytest.fixture(scope="session")
def atlas() -> Atlas:
    """The default atlas (the documented calibration), ~1 s to build."""
    return Atlas.build()


@pytest.fixture(scope="session")
def small_atlas() -> Atlas:
    """A coarse atlas of the default physics for fast simulator and dataset tests."""
    return Atlas.build(AtlasSpec(n_speed=6, n_mass=3, n_slope=5))


@pytest.fixture(scope="session")
def local_ray():
    """A local Ray with 2 CPUs for the whole session (started once: ~4 s); Runners join it.
    Tests that use it are skipped where Ray is not installed."""
    ray = pytest.importorskip("ray")
    from brake_env.runner import Runner

    runner = Runner(workers=2)  # starts Ray with the project's import path for the workers
    yield ray
    runner.__exit__()


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """For ``pytest -n 2 --dist loadgroup`` (make test): whole files per worker (their
    module fixtures built once), and every file that uses the local Ray on one worker, so
    that one Ray is started, not one per worker."""
    uses_ray = {item.path for item in items if "local_ray" in getattr(item, "fixturenames", ())}
    for item in items:
        group = "ray" if item.path in uses_ray else str(item.path)
        item.add_marker(pytest.mark.xdist_group(group))
