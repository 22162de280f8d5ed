"""benchmarks/analysis/fleet_episode_noise.py on a made-up fleet ``costs.json``."""

from __future__ import annotations

from tests.benchmarks import load_script


def test_each_row_s_spread_and_the_episodes_a_tuning_run_needs():
    module = load_script("fleet_episode_noise")
    episodes = {"cost": [2.0, 4.0, 3.0, 5.0], "net": [2.0, 2.1, 1.9, 2.0]}
    s = {"rows": [{"predictor": "oracle", "policy": "rule", "episodes": episodes}]}
    _head, cost, net = module.rows(s)
    assert cost[:2] == ["oracle / rule", "cost"] and net[1] == "net"
    assert cost[2:6] == ["3.500", "1.291", "2.00", "5.00"]  # sd with ddof=1: sqrt(5/3)
    assert cost[6] == "667"  # ceil(var / SE^2) = ceil((5 / 3) / 0.0025)
    assert float(net[3]) < float(cost[3]) and int(net[6]) < int(cost[6])
