"""A study file read into its cells: :func:`load` gives a :class:`Study`, each :class:`Cell` one
ordinary run (its name, config and folder), every config resolved and validated, before anything
runs. The file's format and the command are in swim_jax/run/study.py; where each cell stands and
how it is trained, swim_jax/run/study_cells.py.
"""

from __future__ import annotations

import itertools
import os
from dataclasses import dataclass
from typing import Any, Mapping

from swim_jax import config as cfgmod
from swim_jax.config import Config, ConfigError
from swim_jax.io import cli_parser

STUDY_KEYS = ("name", "out_dir", "envs", "activations", "configs", "seeds", "total_steps", "overrides", "grid")
SET_BY_STUDY = ("name", "out_dir", "sweep", "local_processes", "seeds", "total_steps")  # not in overrides/grid


class StudyError(ValueError):
    """A bad study file, option or cell folder; ``str(e)`` is one line."""


@dataclass(frozen=True)
class Cell:
    """One run of the study: its stable name, position, config and run folder."""

    index: int
    name: str
    cfg: Config
    run_dir: str


@dataclass(frozen=True)
class Study:
    """A loaded, validated study file: its path, name, out_dir and cells in order."""

    path: str
    name: str
    out_dir: str
    cells: tuple[Cell, ...]

    def cell(self, key: str) -> Cell:
        """The cell named ``key``, or at position ``key`` (0-based, e.g. ``$SLURM_ARRAY_TASK_ID``)."""
        if key.isdigit():
            if int(key) < len(self.cells):
                return self.cells[int(key)]
            raise StudyError(f"--cell {key}: the study has {len(self.cells)} cells (0..{len(self.cells) - 1})")
        for c in self.cells:
            if c.name == key:
                return c
        raise StudyError(f"--cell {key!r}: no such cell; valid: {', '.join(c.name for c in self.cells)}")


def load(path: str, out_dir: str | None = None) -> Study:
    """Read and validate the study file at ``path`` (``out_dir`` overrides its own); every cell's
    config is resolved and validated, cells that would pool as one (env, activation) are refused,
    and so is an existing cell folder whose config.yaml differs from the cell's. :class:`StudyError`."""
    if not os.path.isfile(path):  # a bare name (table2) is a shipped study, configs/studies/<name>.yaml
        shipped = cfgmod.shipped_study(path)
        if shipped is None:
            raise StudyError(f"study file {path} not found; or a shipped study by name: "
                             f"{', '.join(cfgmod.available_studies())} (table2: the paper's)")
        path = shipped
    try:
        data = cfgmod.load_yaml_mapping(path, path, f"a mapping with keys {', '.join(STUDY_KEYS)}")
    except ConfigError as e:
        raise StudyError(str(e)) from None
    unknown = [k for k in data if k not in STUDY_KEYS]
    if unknown:
        raise StudyError(f"{path}: unknown key {unknown[0]!r}; valid keys: {', '.join(STUDY_KEYS)}")
    name = str(data.get("name") or os.path.splitext(os.path.basename(path))[0])
    out = os.path.abspath(os.path.expanduser(os.path.expandvars(
        out_dir or str(data.get("out_dir") or os.path.join("runs", f"study-{name}")))))
    configs = _config_names(path, data)
    shared = _overrides(path, data.get("overrides"), "overrides")
    for key in ("seeds", "total_steps"):
        if key in data:
            shared[key] = data[key]
    grid = _grid(path, data.get("grid"))
    points = [dict(zip(grid, combo)) for combo in itertools.product(*grid.values())] or [{}]
    cells = []
    for config in configs:
        for point in points:
            cell_name = config + (f"-{_point_label(point)}" if point else "")
            cfg = _cell_config(path, config, {**shared, **point}, cell_name, out)
            cells.append(Cell(len(cells), cell_name, cfg, os.path.join(out, cell_name)))
    _check_poolable(path, cells)
    for c in cells:
        _check_existing(c)
    return Study(os.path.abspath(path), name, out, tuple(cells))


def _string_list(path: str, data: dict, key: str) -> list[str]:
    value = data.get(key)
    if not isinstance(value, list) or not value or not all(isinstance(v, str) and v for v in value):
        raise StudyError(f"{path}: {key} must be a non-empty list of names, got {value!r}")
    if len(set(value)) != len(value):
        raise StudyError(f"{path}: {key} lists a name twice: {value}")
    return value


def _config_names(path: str, data: dict) -> list[str]:
    """The cells' config names: ``configs``, or ``<env>_<activation>`` over ``envs`` × ``activations``."""
    if "configs" in data:
        if "envs" in data or "activations" in data:
            raise StudyError(f"{path}: give either configs or envs with activations, not both")
        names = _string_list(path, data, "configs")
    elif "envs" in data or "activations" in data:
        names = [f"{e}_{a}" for e in _string_list(path, data, "envs") for a in _string_list(path, data, "activations")]
    else:
        raise StudyError(f"{path}: name the cells' configs: envs and activations (configs/<env>_<activation>.yaml) "
                         "or a configs list")
    valid = cfgmod.available_configs()
    for n in names:
        if n not in valid:
            raise StudyError(f"{path}: no config {n!r} (configs/{n}.yaml); valid configs: {', '.join(valid)}")
    return names


def _overrides(path: str, value, key: str) -> dict[str, Any]:
    """``{dotted key: value}`` from a (possibly nested) mapping; keys the study sets itself refused."""
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise StudyError(f"{path}: {key} must be a mapping of config keys to values, e.g. {{env.backend: mujoco}}")
    flat = cli_parser.dotted_keys(value)
    for k in flat:
        if k.split(".")[0] in SET_BY_STUDY:
            raise StudyError(f"{path}: {key}.{k} is set by the study itself (top-level seeds/total_steps/out_dir; "
                             f"a cell is one plain run); valid here: other config keys")
    return flat


def _grid(path: str, value) -> dict[str, list]:
    grid = _overrides(path, value, "grid")
    for k, values in grid.items():
        if not isinstance(values, list) or not values:
            raise StudyError(f"{path}: grid.{k} must be a non-empty list of values, got {values!r}")
        if len(set(map(repr, values))) != len(values):
            raise StudyError(f"{path}: grid.{k} lists a value twice: {values}")
    return grid


def _point_label(point: Mapping[str, Any]) -> str:
    return ",".join(f"{k.rsplit('.', 1)[-1]}={v:g}" if isinstance(v, float) else f"{k.rsplit('.', 1)[-1]}={v}"
                    for k, v in point.items())


def _set_dotted(data: dict, key: str, value) -> dict:
    data = dict(data)
    node = data
    parts = key.split(".")
    for p in parts[:-1]:
        node[p] = dict(node[p]) if isinstance(node.get(p), Mapping) else {}
        node = node[p]
    node[parts[-1]] = value
    return data


def _cell_config(path: str, config: str, values: dict[str, Any], name: str, out_dir: str) -> Config:
    """The validated config of one cell: ``configs/<config>.yaml`` with ``values`` set."""
    data = cfgmod.load_yaml_chain(config)
    for k, v in values.items():
        data = _set_dotted(data, k, v)
    data = {**data, "name": name, "out_dir": out_dir}
    try:
        return cfgmod.validate(cfgmod.from_dict(Config, data))
    except ConfigError as e:
        raise StudyError(f"{path}: cell {name}: {e}") from None


def _check_poolable(path: str, cells: list[Cell]) -> None:
    """Refuse two cells the report would pool as the same (env, activation) with the same seeds."""
    from swim_jax.analysis.runs_io import activation_label  # (imports the activation registry only)

    seen: dict[tuple, str] = {}
    for c in cells:
        key = (c.cfg.env.id, activation_label(cfgmod.to_dict(c.cfg.agent.activation)), c.cfg.seed, c.cfg.first_seed)
        if key in seen:
            raise StudyError(f"{path}: cells {seen[key]} and {c.name} cannot be pooled: both are {key[0]} with "
                             f"{key[1]} and the same seeds; a grid axis must change the activation (e.g. "
                             "agent.activation.k), or make it a separate study")
        seen[key] = c.name


def _check_existing(c: Cell) -> None:
    """Refuse a cell folder whose config.yaml is not this cell's (the study file or out_dir changed);
    what does not count as a change: :func:`swim_jax.config.first_difference` (a raised total_steps
    among them: the cell resumes to it)."""
    if not started(c):
        return
    diff = cfgmod.first_difference(c.cfg, c.run_dir)
    if diff:
        k, recorded, wanted = diff
        hint = ("; a budget can only grow" if k == "total_steps" else "")
        raise StudyError(f"cell {c.name}: {os.path.join(c.run_dir, 'config.yaml')} was started with {k}={recorded!r}, "
                         f"the study now gives {k}={wanted!r}{hint}; restore the study file or use another --out-dir")


def started(c: Cell) -> bool:
    """Whether cell ``c`` has a run folder with its config.yaml (its run has started)."""
    return os.path.isfile(os.path.join(c.run_dir, "config.yaml"))
