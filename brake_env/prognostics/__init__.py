"""RUL prognostics: the predictor protocol, the registry of predictors by name, the metrics,
the evaluation harness (paper 2.5, Table 4), its tables, figures and ``brakewear evaluate``."""
