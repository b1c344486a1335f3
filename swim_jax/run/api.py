"""The Python API, for notebooks and scripts (``import swim_jax``)::

    import swim_jax
    run = swim_jax.train_run("cheetah_relu", {"agent.activation.name": "swim"}, seeds=3, total_steps=50_000)
    run.returns                       # [evaluations, seeds] mean evaluation returns; run.steps their steps
    runs = swim_jax.load_runs(["runs/cheetah_swim-<ts>", "runs/cheetah_swish-<ts>"], at_step=30_000)
    rows = swim_jax.results(runs)     # tidy per-seed rows: env, env_version, algorithm, activation, ...

:func:`train_run` is ``python -m swim_jax.train`` in this process (same config resolution, validation,
run folder, checkpoints and ``--resume``); :func:`load_runs` reads run folders as the report does
(``swim_jax.analysis.runs_io.Run``); :func:`results` gives their evaluations as one row per seed and
evaluation step, the rows of a report's ``results.csv``.
"""

from __future__ import annotations

import json
from typing import Any, Callable, Iterable, Mapping

from swim_jax import config as cfgmod
from swim_jax.analysis import runs_io
from swim_jax.analysis.tidy import tidy_rows


def _override(key: str, value: Any) -> str:
    """``key=value`` as the command line takes it (values are read as YAML; JSON is YAML)."""
    return f"{key}={value if isinstance(value, str) else json.dumps(value)}"


def resolve(config: str, overrides: Mapping[str, Any] | None = None, **keys: Any) -> cfgmod.Config:
    """The validated config ``config`` (a shipped name such as ``walker_swim`` or a YAML file's path)
    with ``overrides`` (dotted keys: ``{"agent.activation.k": 0.75}``) and ``keys`` (top-level keys:
    ``seeds=3``) applied, as ``python -m swim_jax.train config=... key=value`` resolves it.
    :class:`swim_jax.config.ConfigError` (one line) on a bad key or value."""
    items = {**(overrides or {}), **keys}
    return cfgmod.resolve(config, [_override(k, v) for k, v in items.items()])


def train_run(config: str, overrides: Mapping[str, Any] | None = None, *, run_dir: str | None = None,
          log: Callable[[str], None] = print, **keys: Any) -> runs_io.Run:
    """Train ``config`` (see :func:`resolve`) in this process: every seed as one program, written to
    ``run_dir`` (default ``<out_dir>/<name>-<UTC timestamp>``, as the command writes it), progress
    lines to ``log``. Returns the finished run folder read back (:func:`load_runs`). A run folder
    that exists is resumed from its newest checkpoint: the config must be the one it started with
    (``swim_jax.config.first_difference``), but for a larger ``total_steps``, which grows its
    budget; else ``ConfigError`` naming the first difference. Raises ``ConfigError`` on bad input and
    ``swim_jax.run.train.NonFiniteError`` when training diverges."""
    import os

    from swim_jax.run import outputs, train as train_module
    from swim_jax.placement.sharding import set_host_devices
    from swim_jax.run.programs import auto_host_devices, backends_started

    cfg = resolve(config, overrides, **keys)
    resume = run_dir is not None and os.path.isfile(os.path.join(run_dir, "config.yaml"))
    if resume:  # the same run, or its budget grown: anything else is one line, as the command says it
        diff = cfgmod.first_difference(cfg, run_dir, cfgmod.PLACEMENT_KEYS | {"name"})
        if diff:
            raise cfgmod.ConfigError(f"{run_dir} was started with {diff[0]}={diff[1]!r}, not {diff[2]!r}: a run "
                                     "continues with the config it started with (only total_steps may grow)")
        cfg = train_module.resume_config(run_dir, [_override("total_steps", cfg.total_steps)])
    host_devices = cfg.host_devices or auto_host_devices(cfg)
    if host_devices and not backends_started():  # (once JAX has started, its devices are what they are)
        set_host_devices(host_devices)
    run_dir = run_dir or outputs.new_run_dir(cfg)
    log(f"run dir: {run_dir}")
    train_module.run(cfg, run_dir, resume=resume, log=log, status=log)
    return runs_io.load_run(run_dir)


def load_runs(paths: str | Iterable[str], at_step: int | None = None) -> list[runs_io.Run]:
    """The run folders ``paths`` (a sweep folder stands for its points), each read as the report
    reads it: config, ``returns[evaluations, seeds]``, ``steps``, metrics, activation label and the
    dtype of its products; ``at_step``: as if its budget were that many steps. Unfinished runs give
    the evaluations they have. ``swim_jax.analysis.runs_io.RunError`` (one line) on a bad folder."""
    paths = [paths] if isinstance(paths, str) else list(paths)
    return runs_io.load_runs(paths, at_step)


def results(runs: Iterable[runs_io.Run | str]) -> list[dict]:
    """One row per run, seed and evaluation step: ``env``, ``env_version``, ``algorithm``,
    ``activation`` (with its parameters), ``precision`` (with the products where they differ),
    ``seed``, ``step``, ``return`` (``swim_jax.analysis.tidy``); paths are read with :func:`load_runs`."""
    loaded: list[runs_io.Run] = []
    for r in runs:
        loaded.extend([r] if isinstance(r, runs_io.Run) else load_runs(r))
    return tidy_rows(loaded)
