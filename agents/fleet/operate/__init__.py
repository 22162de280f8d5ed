"""Your fleet today: its state from the logs of the pads in service and a saved model, and
the decision for it (``brakewear plan``; docs/plan.md)."""
