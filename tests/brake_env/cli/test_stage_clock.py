import resource
import subprocess
import sys

import pytest

from brake_env.cli.stage_clock import StageClock

# A child that spins until it has used 0.6 s of CPU by its own count, says so, then waits
# (alive, as a Ray worker is, never reaped before the clock reads it).
SPIN = (
    "import time\nwhile time.process_time() < 0.6: pass\nprint('spun', flush=True)\ntime.sleep(60)"
)


def _own_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_the_clock_counts_a_child_it_never_reaps_once() -> None:
    # read at each lap only (every=60): no sampling thread's CPU in the sums
    with StageClock(every=60) as clock:
        laps = [clock.lap()]
        own0 = _own_cpu()
        child = subprocess.Popen([sys.executable, "-c", SPIN], stdout=subprocess.PIPE, text=True)
        try:
            assert child.stdout is not None and child.stdout.readline() == "spun\n"
            laps.append(clock.lap())
            own = _own_cpu() - own0
            laps += [clock.lap(), clock.lap()]  # the child idle: nothing new, nothing twice
            total = clock.cpu()
        finally:
            child.kill()
            child.wait()
    child_cpu = laps[1][1] - own
    assert 0.55 <= child_cpu < 0.7  # its 0.6 s, to the kernel's tick (0.01 s) and rounding
    assert sum(c for _, c in laps) == pytest.approx(total, abs=0.02)
    assert all(w >= 0 and c >= 0 for w, c in laps)
    assert sum(c for _, c in laps[2:]) < 0.1
