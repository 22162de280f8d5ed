"""Independent units of work (pads, seeds, cases, training runs) run in this process or as
Ray tasks, each result saved as it finishes so that an interrupted run resumes from what
finished (docs/cluster.md).

A unit is a module-level function and its arguments; its result depends on its arguments
alone (each unit is seeded by its own number), so the results are the same wherever it
runs. Large inputs that many units share (the atlas, fitted predictors) go through
:meth:`Runner.share`: on Ray they are put in the object store once and every task reads
them from there; in this process they are passed as they are.

In this process is the default and needs no Ray; ``workers`` > 0 starts a local Ray with
that many CPUs; an address joins a running cluster (``auto``: the one this machine belongs
to). Ray retries a task whose worker died; a unit that raises is reported by name after
the other units have finished (and been saved), so a rerun redoes only the failed ones.
The results are kept in a :class:`~brake_env.units.UnitStore` (:mod:`brake_env.units`).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, as_completed, wait
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

from brake_env.units import UnitStore

__all__ = [
    "AUTO", "RETRIES", "Later", "Runner", "Unit", "UnitStore", "UnitsFailed", "ray_available",
]  # fmt: skip

AUTO = "auto"
RETRIES = 2  # Ray reruns a task this many times when its worker process dies


@dataclass(frozen=True)
class Unit:
    """One independent piece of work: ``fn(*args)``.

    Attributes:
        key: Unique name in its run: progress, errors and the saved result use it.
        fn: A module-level function (Ray workers import it by name).
        args: Its arguments; values from :meth:`Runner.share` are resolved in the task.
        weight: Its expected cost relative to the others' (:meth:`Runner.run_graph` starts
            the heaviest ready unit first, so that no long unit is left running alone).
    """

    key: str
    fn: Callable[..., Any]
    args: tuple[Any, ...] = ()
    weight: float = 1.0


@dataclass(frozen=True)
class Later:
    """A unit that needs others' results: ``make(results)`` returns it (key ``key``) once
    every unit in ``needs`` has finished, ``results`` holding theirs by key."""

    key: str
    needs: tuple[str, ...]
    make: Callable[[Mapping[str, Any]], Unit]


class UnitsFailed(RuntimeError):
    """Some units raised; the message names each with its error."""

    def __init__(self, errors: Mapping[str, BaseException]) -> None:
        self.errors = dict(errors)
        lines = [f"  {k}: {type(e).__name__}: {e}" for k, e in self.errors.items()]
        super().__init__(f"{len(lines)} unit(s) failed:\n" + "\n".join(lines))


def ray_available() -> bool:
    """Whether Ray can be imported here."""
    try:
        import ray  # noqa: F401
    except ImportError:
        return False
    return True


class Runner:
    """Where units run. Use as a context manager (a local Ray it started is shut down).

    Args:
        workers: CPUs of a local Ray started here (0: run every unit in this process, in
            order; no Ray needed).
        address: A Ray cluster to join instead (``auto`` or ``HOST:PORT``); ``workers``
            is then ignored.
        retries: Times Ray reruns a task whose worker died.
    """

    def __init__(self, workers: int = 0, address: str | None = None, retries: int = RETRIES):
        if workers < 0:
            raise ValueError(f"Runner: workers must be >= 0, got {workers}")
        self.workers, self.address, self.retries = workers, address, retries
        self._ray: Any = None
        self._started = False
        self._remote: dict[Callable[..., Any], Any] = {}
        if address or workers:
            self._start_ray()

    def _start_ray(self) -> None:
        try:
            import ray
        except ImportError:
            raise ImportError(
                "running on Ray (--ray, or workers > 0) needs Ray: pip install 'brakewear[ray]'"
                " (or run in this process: --workers 0)"
            ) from None
        self._ray = ray
        if ray.is_initialized():
            return
        # The driver's import path reaches the workers, so an uninstalled checkout works.
        runtime_env = {"env_vars": {"PYTHONPATH": os.pathsep.join(_import_paths())}}
        kwargs: dict[str, Any] = {"runtime_env": runtime_env, "log_to_driver": False}
        if self.address:
            ray.init(address=self.address, **kwargs)
        else:
            ray.init(num_cpus=self.workers, include_dashboard=False, **kwargs)
        self._started = True

    @property
    def on_ray(self) -> bool:
        """Whether units run as Ray tasks."""
        return self._ray is not None

    def __enter__(self) -> Runner:
        return self

    def __exit__(self, *exc: object) -> None:
        if self._started:
            self._ray.shutdown()
            self._started = False

    def share(self, obj: Any) -> Any:
        """``obj`` as units should receive it: in Ray's object store (put once, read by
        every task), or itself in this process."""
        return self._ray.put(obj) if self.on_ray else obj

    def submit(self, fn: Callable[..., Any], *args: Any) -> Future[Any]:
        """``fn(*args)`` as a Ray task, or here and now in this process."""
        if not self.on_ray:
            done: Future[Any] = Future()
            try:
                done.set_result(fn(*args))
            except Exception as e:  # reported by the caller, like a task's error
                done.set_exception(e)
            return done
        remote = self._remote.get(fn)
        if remote is None:
            remote = self._ray.remote(max_retries=self.retries)(fn)
            self._remote[fn] = remote
        future: Future[Any] = remote.remote(*args).future()
        return future

    def run(
        self,
        units: Sequence[Unit],
        store: UnitStore | None = None,
        progress: Callable[[str, Any], object] | None = None,
    ) -> dict[str, Any]:
        """Every unit's result by key, in the order of ``units``.

        Results already in ``store`` are read, not recomputed; new ones are saved there as
        they finish. ``progress(key, result)`` is called as each unit finishes (in finishing
        order on Ray).

        Raises:
            UnitsFailed: After every other unit has finished, naming those that raised.
        """
        return self.start(units, store)(progress)

    def start(
        self, units: Sequence[Unit], store: UnitStore | None = None
    ) -> Callable[[Callable[[str, Any], object] | None], dict[str, Any]]:
        """:meth:`run`, submitted now (Ray works on them meanwhile); call the returned
        function with a progress callback (or None) to wait for the results."""
        keys = [u.key for u in units]
        if len(set(keys)) != len(keys):
            raise ValueError(f"unit keys must be unique, got {sorted(keys)}")
        results = {k: store.load(k) for k in keys if store is not None and k in store}
        todo = [u for u in units if u.key not in results]
        if not self.on_ray:  # each unit runs when its turn comes, in order
            here = [(u.key, partial(u.fn, *u.args)) for u in todo]
            return lambda progress: _collect(units, here, results, store, progress)
        futures = {self.submit(u.fn, *u.args): u.key for u in todo}
        on_ray = ((futures[f], f.result) for f in as_completed(futures))  # as they finish
        return lambda progress: _collect(units, on_ray, results, store, progress)

    def run_graph(
        self,
        nodes: Sequence[Unit | Later],
        store: UnitStore | None = None,
        progress: Callable[[str, Any], object] | None = None,
        kept: Callable[[str], bool] = lambda key: True,
    ) -> dict[str, Any]:
        """Units that need others' results, each started as soon as what it needs is in
        (no stage waits for its slowest unit). Each node comes after the units it needs.

        A unit whose key is ``kept`` is saved in ``store`` as it finishes and read from it
        when there; the others (e.g. fitted models) are not saved and run only when a unit
        that has to run needs them. In this process the units run in the order given; on
        Ray, as many at a time as the cluster has CPUs, the heaviest ready one first.
        ``progress(key, result)`` as each is read or finishes.

        Returns:
            The results of the units that ran or were read, by key, in the nodes' order.

        Raises:
            ValueError: Duplicate keys, or a node before a unit it needs.
            UnitsFailed: After every other unit has finished, naming those that raised and
                those not run because a unit they need failed.
        """
        keys = _checked_order(nodes)
        results = {k: store.load(k) for k in keys if store is not None and kept(k) and k in store}
        _report(results, progress)  # the units read from the store
        errors: dict[str, BaseException] = {}

        def unit_of(n: Unit | Later) -> Unit | None:
            failed = [k for k in _needs(n) if k in errors]
            if failed:
                errors[n.key] = RuntimeError(f"not run: it needs {', '.join(failed)}, which failed")
                return None
            try:  # a make that raises is that unit's failure, named with the others
                u = n if isinstance(n, Unit) else n.make(results)
            except Exception as e:
                errors[n.key] = e
                return None
            if u.key != n.key:
                raise ValueError(f"run_graph: {n.key}'s make gave a unit named {u.key}")
            return u

        def finish(key: str, get: Callable[[], Any]) -> None:
            try:
                results[key] = _finish(key, get(), store if kept(key) else None, progress)
            except Exception as e:
                errors[key] = _cause(e)

        todo = _wanted(nodes, results, kept)
        if not self.on_ray:
            for n in todo:
                u = unit_of(n)
                if u is not None:
                    finish(u.key, partial(u.fn, *u.args))
        else:
            self._run_graph_on_ray(todo, unit_of, finish, results, errors)
        if errors:
            raise UnitsFailed({k: errors[k] for k in keys if k in errors})
        return {k: results[k] for k in keys if k in results}

    def _run_graph_on_ray(
        self, todo: list[Unit | Later], unit_of: Callable[[Unit | Later], Unit | None],
        finish: Callable[[str, Callable[[], Any]], None], results: Mapping[str, Any],
        errors: Mapping[str, BaseException],
    ) -> None:  # fmt: skip
        """:meth:`run_graph`'s schedule on Ray: as many tasks in flight as the cluster has
        CPUs; when one ends, the heaviest unit whose needs are in starts."""
        cpus = max(1, int(self._ray.cluster_resources().get("CPU", 1)))
        waiting, ready = list(todo), list[Unit]()
        running: dict[Future[Any], str] = {}
        while waiting or ready or running:
            for n in [n for n in waiting if all(k in results or k in errors for k in _needs(n))]:
                waiting.remove(n)
                u = unit_of(n)
                if u is not None:
                    ready.append(u)
            ready.sort(key=lambda u: -u.weight)  # stable: equal weights keep the nodes' order
            while ready and len(running) < cpus:
                u = ready.pop(0)
                running[self.submit(u.fn, *u.args)] = u.key
            if running:
                done, _ = wait(running, return_when=FIRST_COMPLETED)
                for f in done:
                    finish(running.pop(f), f.result)


def _checked_order(nodes: Sequence[Unit | Later]) -> list[str]:
    """The nodes' keys, once it is checked that they are unique and each node comes after
    the units it needs."""
    keys = [n.key for n in nodes]
    if len(set(keys)) != len(keys):
        raise ValueError(f"unit keys must be unique, got {sorted(keys)}")
    before: set[str] = set()
    for n in nodes:
        late = [k for k in _needs(n) if k not in before]
        if late:
            raise ValueError(f"run_graph: {n.key} needs {late}, which must come before it")
        before.add(n.key)
    return keys


def _report(results: Mapping[str, Any], progress: Callable[[str, Any], object] | None) -> None:
    for k, v in results.items():
        if progress:
            progress(k, v)


def _needs(n: Unit | Later) -> tuple[str, ...]:
    return n.needs if isinstance(n, Later) else ()


def _wanted(
    nodes: Sequence[Unit | Later], results: Mapping[str, Any], kept: Callable[[str], bool]
) -> list[Unit | Later]:
    """The nodes to run: the kept ones not read already, and what they need (transitively)
    that is not read either."""
    need: set[str] = set()
    for n in reversed(nodes):
        if n.key not in results and (kept(n.key) or n.key in need):
            need.add(n.key)
            need.update(_needs(n))
    return [n for n in nodes if n.key in need and n.key not in results]


def _collect(
    units: Sequence[Unit],
    done: Iterable[tuple[str, Callable[[], Any]]],
    results: dict[str, Any],
    store: UnitStore | None,
    progress: Callable[[str, Any], object] | None,
) -> dict[str, Any]:
    """The results of ``units``: those in ``results`` already, then each of ``done`` (key,
    its result's getter) saved and reported as it comes; errors named at the end."""
    for k in list(results):
        if progress:
            progress(k, results[k])
    errors: dict[str, BaseException] = {}
    for key, get in done:
        try:
            results[key] = _finish(key, get(), store, progress)
        except Exception as e:
            errors[key] = _cause(e)
    return _ordered(units, results, errors)


def _finish(
    key: str, value: Any, store: UnitStore | None, progress: Callable[[str, Any], object] | None
) -> Any:
    if store is not None:
        store.save(key, value)
    if progress:
        progress(key, value)
    return value


def _ordered(
    units: Sequence[Unit], results: Mapping[str, Any], errors: Mapping[str, BaseException]
) -> dict[str, Any]:
    if errors:
        raise UnitsFailed({u.key: errors[u.key] for u in units if u.key in errors})
    return {u.key: results[u.key] for u in units}


def _cause(e: BaseException) -> BaseException:
    """The unit's own exception out of Ray's wrapper (RayTaskError keeps it as cause)."""
    inner = getattr(e, "cause", None)
    return inner if isinstance(inner, BaseException) else e


def _import_paths() -> list[str]:
    """Where this package and its siblings are imported from (the project's root)."""
    root = Path(__file__).resolve().parent.parent  # brake_env/runner.py -> the root
    return [str(root), *os.environ.get("PYTHONPATH", "").split(os.pathsep)][:8]
