"""BrakeWearFleet-v0: a fleet of vehicles, each with a streamed pad (BrakeWear-v0's pad
life, vectorised over vehicles), scheduled windows, a workshop, spares and duty routes.

Modules by job: ``config`` (FleetConfig, FleetCosts), ``routes`` (duty routes and their
wear from the atlas), ``pads`` (the vectorised streamed pads), ``shop`` (bays, spares,
the deferral rule), ``spaces`` (observation/action layout, masks), ``env`` (the Gymnasium
env), ``render``, ``wrappers`` (fleet RUL observation) and ``parallel`` (PettingZoo; needs
the ``fleet`` extra).
"""
