"""RUL prognostics: what a predictor reads and gives (events), many pads at once (fleet), the
predictor base class (protocol), the registry of predictors by name, saving them (persist),
the metrics, the evaluation harness (paper 2.5, Table 4), its seeds, tables and figures; the
commands ``brakewear evaluate``, ``fit`` and ``predict`` in :mod:`.commands`."""
