"""The gap diagnosis of an event log: its data (logdata.py), the replay through the nominal
model (replay.py, padfit.py), localise, attribute and quantify, the twin's RUL error (rul.py),
the checks before the long work (preconditions.py), settings (config.py) and the whole
diagnosis (diagnose.py)."""
