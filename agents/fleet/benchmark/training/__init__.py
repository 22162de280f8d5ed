"""Plain RL from scratch on a benchmark suite (issue 41): a TOML training configuration
(:mod:`.config`), MaskablePPO (:mod:`.maskable`) and TorchRL MAPPO (:mod:`.mappo`) trained on
the suite's env and saved, a ``factory(env)`` that loads each for ``brakewear fleet-score``,
and the configuration's tuning on the dev split (:mod:`.tune`)."""
