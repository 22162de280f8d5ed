"""``brakewear train`` and ``brakewear compare``: typed settings from the command line,
the studies' units on the runner, reports and figures."""
