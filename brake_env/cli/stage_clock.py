"""Wall and CPU seconds of each stage of a long command, the CPU of this process and of every
process it started (a local Ray's workers included). On Linux a thread reads each
descendant's own user + system time in /proc every ``every`` seconds and at each lap: Ray
ends its workers without this process reaping them, so their time never reaches
``RUSAGE_CHILDREN``. Each process counts once, by its own time when last seen: it loses at
most its last ``every`` seconds, and a process born and ended between two readings is not
counted. Elsewhere the CPU is this process's and its reaped children's."""

from __future__ import annotations

import os
import resource
import threading
import time
from pathlib import Path

PROC = Path("/proc")


def _ticks() -> float:
    return float(os.sysconf("SC_CLK_TCK")) if hasattr(os, "sysconf") else 100.0


def _stats() -> dict[int, tuple[int, int, float]]:
    """pid -> (parent pid, start time, user+system ticks) of every process /proc shows."""
    out = {}
    for d in PROC.iterdir():
        if not d.name.isdigit():
            continue
        try:
            text = (d / "stat").read_text()
        except OSError:  # ended since the listing
            continue
        # the command name may hold spaces and parentheses: the fields follow the last ")"
        f = text.rsplit(")", 1)[1].split()
        out[int(d.name)] = (int(f[1]), int(f[19]), float(f[11]) + float(f[12]))
    return out


class StageClock:
    """A clock of wall seconds and CPU seconds of this process tree since it was made.

    Use as a context manager (the sampling thread stops on exit); :meth:`lap` gives the
    seconds since the previous lap.
    """

    def __init__(self, every: float = 1.0) -> None:
        self.every = every
        self.tree = PROC.is_dir()
        self._seen: dict[tuple[int, int], float] = {}  # (pid, start) -> its CPU ticks
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True, name="stage-clock")
        self._wall0 = time.perf_counter()
        self._last = (0.0, 0.0)
        self._cpu0 = 0.0
        self._cpu0 = self.cpu()

    def __enter__(self) -> StageClock:
        if self.tree:
            self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join()

    def _run(self) -> None:
        while not self._stop.wait(self.every):
            self._sample()

    def _sample(self) -> None:
        stats = _stats()
        children: dict[int, list[int]] = {}
        for pid, (ppid, _, _) in stats.items():
            children.setdefault(ppid, []).append(pid)
        todo, mine = list(children.get(os.getpid(), [])), []
        while todo:
            pid = todo.pop()
            mine.append(pid)
            todo.extend(children.get(pid, []))
        with self._lock:
            for pid in mine:
                _, start, ticks = stats[pid]
                self._seen[(pid, start)] = ticks

    def cpu(self) -> float:
        """CPU seconds (user + system) of the tree since the clock was made."""
        own = resource.getrusage(resource.RUSAGE_SELF)
        total = own.ru_utime + own.ru_stime
        if self.tree:
            self._sample()
            with self._lock:
                total += sum(self._seen.values()) / _ticks()
        else:
            kids = resource.getrusage(resource.RUSAGE_CHILDREN)
            total += kids.ru_utime + kids.ru_stime
        return total - self._cpu0

    def wall(self) -> float:
        """Wall seconds since the clock was made."""
        return time.perf_counter() - self._wall0

    def lap(self) -> tuple[float, float]:
        """(wall, CPU) seconds since the previous lap (or since the clock was made)."""
        now = (self.wall(), self.cpu())
        lap = (now[0] - self._last[0], now[1] - self._last[1])
        self._last = now
        return lap
