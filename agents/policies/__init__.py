"""Rule-based maintenance policies: anything with ``predict()`` that needs no learning."""
