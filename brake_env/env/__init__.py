"""BrakeWear-v0: its configuration, the pad service (installations, failures, costs), the
single and vector envs, and the RUL observation wrapper."""
