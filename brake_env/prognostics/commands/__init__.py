"""The prognostics commands: ``brakewear evaluate`` (one seed, :mod:`.evaluate`; several,
:mod:`.evaluate_seeds`), ``fit`` and ``predict`` (:mod:`.fit_predict`, the predict's units
in :mod:`.predict_units`) and the evaluation's output files (:mod:`.outputs`). They turn
arguments into the library's typed settings; nothing below them takes a Namespace."""
