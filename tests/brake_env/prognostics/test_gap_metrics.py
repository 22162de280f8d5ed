"""Metrics of a run with gaps count events, not rows (protocol docstring, "Gaps")."""

from __future__ import annotations

import numpy as np

from brake_env.prognostics.evaluation import EvaluationConfig, run_metrics
from brake_env.prognostics.protocol import EventBatch, RULEstimate


def test_convergence_is_an_event_index_on_a_log_with_gaps() -> None:
    life, step = 10_000, 10
    event = np.arange(0, life, step)  # every tenth event logged
    n = event.size
    true = (life - 1 - event).astype(np.int64)
    ones = np.ones(n)
    ev = EventBatch(
        event, ones, ones, ones, ones, ones, ones, rul_events=true, wear_coeff=np.full(n, 2e-6)
    )
    rul = true.astype(np.float64).copy()
    rul[:50] += 0.5 * life  # wrong until row 50, i.e. event 500
    k = np.full(n, 2e-6)
    k[:80] *= 2.0  # K wrong until row 80, event 800
    est = RULEstimate(rul_mean=rul, wear_coeff=k)
    got = run_metrics(est, ev, EvaluationConfig())
    assert set(got["convergence_event"].values()) == {500}
    assert got["k_rel_error"]["convergence_frac_0.1"] == 800 / life
