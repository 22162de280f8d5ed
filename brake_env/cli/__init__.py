"""The ``brakewear`` command: shared options and output (common), ``atlas`` and
``simulate``, ``demo``, and the parser that loads the downstream packages' plug-ins (main)."""
