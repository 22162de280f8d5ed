"""Physics-based and data-driven RUL baselines (issue 4)."""
