"""The fleet's decision side: everything that acts on BrakeWearFleet-v0 (whose rules live in
:mod:`brake_env.env.fleet`), in one package. Sub-packages in import order, each importing
only those before it:

- ``settings``: :class:`~agents.fleet.settings.FleetTraining` and
  :class:`~agents.fleet.settings.FleetStudyConfig`, the episode seeds (the bottom);
- ``policies``: what a rule reads (``view``), the heuristics (``rules``) and the exact
  perfect-information reference of a small fleet (``reference``);
- ``evaluation``: episode costs with paired intervals (``costs``) and Optuna tuning of the
  heuristics (``tuning``);
- ``learning``: behaviour cloning (``imitation``), MaskablePPO (``agent``) and
  parameter-shared PPO (``shared``);
- ``study``: ``brakewear fleet-study``'s units, summary, figures and run;
- ``commands``: its parser (light) and the command, and the demo's fleet stage.
"""
