"""The cost study's work spread over processes: simulating pads in chunks and training
agents, side by side on a machine's cores (README "Maintenance cost by predictor").

Processes are spawned, not forked (torch's thread pools do not survive a fork); each task
gets its predictors and atlas pickled. With no workers everything runs here, in order, so
the numbers are the same either way: a pad's events and estimates depend on the pad alone.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from dataclasses import replace
from typing import Any, TypeVar

import numpy as np

from agents.pad_study import PadDraws, PadSet, collect_pads, concat_pad_sets
from brake_env.env.config import EnvConfig
from brake_env.model.atlas import Atlas
from brake_env.prognostics.protocol import Predictor

T = TypeVar("T")
CHUNK_PADS = 48  # pads per task: a few seconds to a minute of work, a fair share of a core


class Done(Future[T]):
    """A task already run in this process, as a future."""

    def __init__(self, value: T) -> None:
        super().__init__()
        self.set_result(value)


class Workers:
    """A pool of ``n`` processes (0: none, run everything here). Use as a context manager.

    Args:
        n: Worker processes.
    """

    def __init__(self, n: int) -> None:
        if n < 0:
            raise ValueError(f"Workers: n must be >= 0, got {n}")
        self.n = n
        self._pool: ProcessPoolExecutor | None = None
        if n:
            from multiprocessing import get_context

            self._pool = ProcessPoolExecutor(n, mp_context=get_context("spawn"))

    def __enter__(self) -> Workers:
        return self

    def __exit__(self, *exc: object) -> None:
        if self._pool is not None:
            self._pool.shutdown(cancel_futures=True)

    def submit(self, fn: Callable[..., T], *args: Any, **kwargs: Any) -> Future[T]:
        """``fn(*args, **kwargs)`` in a worker, or here and now without workers."""
        if self._pool is None:
            return Done(fn(*args, **kwargs))
        return self._pool.submit(fn, *args, **kwargs)

    def collect(
        self,
        draws: PadDraws,
        atlas: Atlas,
        config: EnvConfig,
        predictors: Mapping[str, Predictor],
        progress: Callable[[int], object] | None = None,
    ) -> PadSet:
        """:func:`~agents.pad_study.collect_pads` in chunks of pads spread over the workers
        (queued behind tasks already submitted); the same pad set."""
        return self.collect_later(draws, atlas, config, predictors)(progress)

    def collect_later(
        self,
        draws: PadDraws,
        atlas: Atlas,
        config: EnvConfig,
        predictors: Mapping[str, Predictor],
    ) -> Callable[[Callable[[int], object] | None], PadSet]:
        """:meth:`collect`, queued now; the returned function waits for the pad set (and
        advances a progress callback by the pads of each chunk done)."""
        if self._pool is None:
            return lambda progress: collect_pads(
                draws, atlas, config, predictors, progress=progress
            )
        chunks = np.array_split(np.arange(len(draws)), -(-len(draws) // CHUNK_PADS))
        futures = {
            self.submit(collect_pads, draws.subset(c), atlas, config, dict(predictors)): i
            for i, c in enumerate(chunks)
        }

        def join(progress: Callable[[int], object] | None) -> PadSet:
            parts: dict[int, PadSet] = {}
            for f in as_completed(futures):
                parts[futures[f]] = f.result()
                if progress:
                    progress(len(parts[futures[f]]))
            whole = concat_pad_sets([parts[i] for i in range(len(chunks))])
            return replace(whole, draws=draws)

        return join
