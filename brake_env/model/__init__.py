"""The physics, in pipeline order: materials and parameters, one braking event (physics),
the atlas and its lookup, the wear clock (wear), the K distribution (regime), the coupled
run-to-failure simulator and its literal reference loop (paper 2.1, Steps 1-5)."""
