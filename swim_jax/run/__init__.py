"""One run of a config and what it writes: the jitted training program (programs.py), the run loop
(train.py), the run folder (outputs.py), progress lines (heartbeat.py), rendering a trained policy,
and a whole study of runs (study.py)."""
