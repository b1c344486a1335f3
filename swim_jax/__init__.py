"""swim-jax: Swim vs Swish vs ReLU for TD3 (and SAC) locomotion, one JAX program per run.

The commands are the modules at this level (``python -m swim_jax.train``, ``.sweep``, ``.study``,
``.report``, ``.evaluate``, ``.render``, ``.plots``, ``.bench``); each is a door into the room that
holds its code. The rooms, each importing only rooms listed before it (docs/ARCHITECTURE.md):

- ``io``         files, logs, command-line parsing, the CPU: imports nothing else of the project
- ``policy``     trained policies in NumPy, without JAX (and the activations' NumPy twins)
- ``activations`` Swim and its rivals in JAX, one registry (activations.py)
- ``envs``       the locomotion tasks (``envs/tasks``) on MJX or MuJoCo C physics (``envs/physics``)
- ``agents``     the algorithms (TD3, SAC) behind one interface: networks, replay buffer, updates, the jitted loop
- ``config``     the run configuration (config.py)
- ``placement``  where lanes go: lane groups, devices, processes
- ``analysis``   reading finished runs: report, statistics, evaluation in Gymnasium
- ``run``        one run of a config (program, loop, run folder), rendering, a whole study
- ``bench``      the benchmarks
"""

__all__ = ["train_run", "load_runs", "results", "resolve"]


def __getattr__(name: str):
    """The Python API (swim_jax/run/api.py: ``train_run``, ``load_runs``, ``results``, ``resolve``),
    imported on first use so that ``import swim_jax`` stays light."""
    if name in __all__:
        from swim_jax.run import api

        return getattr(api, name)
    raise AttributeError(f"module 'swim_jax' has no attribute {name!r}")
