"""Train a shipped (or any) plain-RL configuration, save it and measure it on the dev split.

Run: ``python -m agents.fleet.benchmark.training.train --config maskable_ppo --out
agents/fleet/benchmark/entries/default/maskable-ppo.zip`` (a shipped config's name or a
file; ``--timesteps`` overrides its budget, ``--dev-episodes 0`` skips the measure). Prints
the training steps, the CPU time and the dev figure; writes the model and nothing else.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from agents.fleet.benchmark.training.config import read_config, suite_atlas
from agents.fleet.benchmark.training.run import dev_net, save, summary, train

BUDGET = {"maskable_ppo": "timesteps", "mappo": "frames"}


def main(argv: list[str] | None = None) -> dict[str, object]:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--config", required=True, help="a shipped config's name or a TOML file")
    ap.add_argument("--out", required=True, help="the model file to write (.zip or .pt)")
    ap.add_argument("--timesteps", type=int, default=None, help="override the budget")
    ap.add_argument("--dev-episodes", type=int, default=5, help="dev episodes to measure on")
    ap.add_argument("--force", action="store_true", help="replace an existing --out")
    args = ap.parse_args(argv)
    config = read_config(args.config)
    if args.timesteps is not None:
        config = config.with_settings(**{BUDGET[config.algorithm]: args.timesteps})
    out = Path(args.out)
    if out.exists() and not args.force:
        raise SystemExit(f"--out {out} exists (pass --force to replace a model you made)")
    atlas = suite_atlas(config.suite)
    policy, cost = train(config, atlas, log=print)
    meta: dict[str, object] = {"config": config.path, **cost}
    if args.dev_episodes > 0:
        t0 = time.process_time()
        net = dev_net(config, policy, atlas, args.dev_episodes)
        meta |= {"dev_net": net, "dev_cpu_seconds": time.process_time() - t0}
        print(summary(net))
    save(config, policy, out, meta)
    print(json.dumps(meta))
    print(f"wrote {out} ({out.stat().st_size / 1e6:.2f} MB)")
    return meta


if __name__ == "__main__":
    main()
