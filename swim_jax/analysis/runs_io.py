"""Read ``swim_jax.run.train`` run folders and group them into (env, activation) comparisons.

A run folder holds ``config.yaml`` (the resolved config) and ``evaluations.npy`` (``[n_evals, seeds]``
mean evaluation returns; evaluation ``i`` is at step ``i · eval_freq``). See ``swim_jax/run/train.py``.

Grouping policy (documented in the report too):

* one group per ``env.id``; inside it one curve set per activation label (the activation name, plus
  its parameters that differ from their defaults: ``swim(k=0.75)``, ``swish(beta=2)``, and
  ``+learnable``; ``swim_jax.activations.ActivationSetting``). A config.yaml written before an
  activation parameter existed reads as having that parameter's default;
* several run folders with the same (env, activation label) are pooled as more seeds. They must agree
  on every config key except ``seeds``, ``first_seed``, ``seed``, ``name``, ``out_dir`` and
  ``keep_checkpoints``, and must not share a seed (same base ``seed`` and seed index) — else refused;
* all runs of one env must have the same ``total_steps`` and ``eval_freq``; runs that differ are
  refused with a message naming two conflicting runs (no alignment on common steps: a curve at a
  different budget is a different experiment). ``at_step`` reads every run at that budget instead
  (its evaluations up to that step; each run must have reached it): Table II at 300k from 1M runs;
* all runs of one env must share their numerics: precision and the dtype their matmul products ran
  in (``matmul_dtype``, as each stretch recorded it). Runs that differ are refused with one line
  naming them, unless ``mixed_precision``, which compares them and marks the env
  (:attr:`EnvGroup.mixed_precision`). Other config differences between activations of one env
  (network size, ...) are allowed but listed as warnings in the report;
* an incomplete run (fewer evaluations than ``1 + total_steps/eval_freq``, e.g. still training) is
  refused unless ``allow_incomplete``, in which case every run of that env is truncated to the
  evaluations all of them have, and the report says so;
* a run's ``metrics.csv`` (per chunk and seed learning metrics, ``swim_jax/io/learning_log.py``) is
  optional (older run folders have none); when present it is read and checked, and a curve set's
  metrics pool the seeds of those of its runs that have one, over the chunks of its evaluations.

Every problem raises :class:`RunError` with a one-line message.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import os
from dataclasses import dataclass, field

import numpy as np
import yaml

from swim_jax.io import cli_parser, learning_log, provenance
from swim_jax.io.schedule import STEPS_FILE, Schedule
from swim_jax.activations import ACTIVATIONS, ActivationSetting, label_activation, parameter_defaults
from swim_jax.agents.base import DEFAULT_KIND
from swim_jax.agents.registry import learning_panels

POOL_IGNORED_KEYS = frozenset({"seeds", "first_seed", "seed", "name", "out_dir", "keep_checkpoints",
                               "shard_lanes", "host_devices", "lane_groups",
                               "pad_single_seed"})  # placement only (at most float rounding), same experiment


class RunError(ValueError):
    """A missing, corrupt or incompatible run folder; ``str(e)`` is one line."""


@dataclass
class LearningMetrics:
    """``metrics.csv`` as arrays: ``values[column]`` is ``[n_chunks, seeds]`` for the float columns of
    :data:`METRIC_COLUMNS`, chunk ``i`` ending at env step ``steps[i] = (i + 1) · eval_freq``; nan
    where the file has no number (no update in that chunk yet, or no row)."""

    steps: np.ndarray  # [n_chunks]
    values: dict  # column -> [n_chunks, seeds]

    @property
    def n_seeds(self) -> int:
        return int(next(iter(self.values.values())).shape[1])


# what the report plots: the titled metrics every agent reports (swim_jax/agents/registry.py)
METRIC_COLUMNS = tuple(metric for metric, _ in learning_panels())


@dataclass
class Run:
    """One run folder: its config and its ``[n_evals, seeds]`` evaluation returns."""

    path: str
    config: dict
    env: str
    activation: str  # label: setting.label + sweep_suffix
    total_steps: int
    eval_freq: int
    seed_ids: list  # (base seed, seed index) per column
    returns: np.ndarray  # [n_evals, seeds]
    metrics: LearningMetrics | None = None  # from metrics.csv; None without one
    setting: ActivationSetting | None = None  # the activation the label names
    sweep_suffix: str = ""  # a sweep point's other swept values, "[tau=0.01]"; "" otherwise
    matmul_dtype: str = ""  # the dtype its matmul products ran in (read_matmul_dtype)

    @property
    def steps(self) -> np.ndarray:
        """The env step of each evaluation (evaluation i at i · eval_freq)."""
        return Schedule(self.total_steps, self.eval_freq).eval_steps(self.returns.shape[0])

    @property
    def algorithm(self) -> str:
        """Its ``agent.kind`` (``td3`` when the config does not say)."""
        return str((self.config.get("agent") or {}).get("kind", "td3"))

    @property
    def expected_evals(self) -> int:
        return 1 + self.total_steps // self.eval_freq

    @property
    def complete(self) -> bool:
        return self.returns.shape[0] == self.expected_evals


@dataclass
class Curves:
    """Pooled curves of one (env, activation): ``returns[n_evals, n_seeds]`` at ``steps``; the label's
    activation ``setting`` and ``sweep_suffix`` are those of its runs (pooled runs share them)."""

    env: str
    activation: str
    steps: np.ndarray
    returns: np.ndarray
    runs: list = field(default_factory=list)  # paths
    metrics: LearningMetrics | None = None  # pooled over the runs with a metrics.csv (None: no run has one)
    runs_without_metrics: list = field(default_factory=list)  # paths
    setting: ActivationSetting | None = None
    sweep_suffix: str = ""
    matmul_dtypes: list = field(default_factory=list)  # sorted dtypes of its runs' products (read_matmul_dtype)
    run_objects: list = field(default_factory=list, repr=False)  # the Runs pooled, cut to the curve's evaluations

    @property
    def n_seeds(self) -> int:
        return int(self.returns.shape[1])


@dataclass
class EnvGroup:
    """All activations of one env, on a common evaluation grid."""

    env: str
    total_steps: int
    eval_freq: int
    curves: dict  # activation label -> Curves
    truncated_to_step: int | None = None  # set when incomplete runs were truncated
    warnings: list = field(default_factory=list)
    mixed_precision: str | None = None  # set when runs of different numerics were compared on request

    @property
    def steps(self) -> np.ndarray:
        return next(iter(self.curves.values())).steps


def activation_label(act: dict) -> str:
    """The label of a config's ``agent.activation`` mapping: ``name``, with the parameters that
    differ from their registry defaults (``swim(k=0.75)``) and ``+learnable`` for learnable
    parameters (:class:`swim_jax.activations.ActivationSetting`)."""
    return ActivationSetting.from_config(act).label


def _with_default_activation_params(cfg: dict) -> dict:
    """``cfg`` with every registry activation parameter its ``agent.activation`` lacks set to the
    default, so a run folder written before that parameter existed pools with newer ones, and with
    ``agent.kind`` (not written for TD3, the default) set."""
    act = cfg["agent"]["activation"]
    missing = {k: v for k, v in parameter_defaults().items() if k not in act}
    return {**cfg, "agent": {"kind": DEFAULT_KIND, **cfg["agent"], "activation": {**act, **missing}}}


def load_run(path: str, at_step: int | None = None) -> Run:
    """Read and validate one run folder; raise :class:`RunError` (one line) if missing or corrupt.
    ``at_step``: the run as if its budget were that many steps (its evaluations and metrics up to
    that step; the run must have reached it)."""
    cfg_path, ev_path = _run_files(path)
    cfg = _read_config(cfg_path)
    cfg["matmul_dtype"] = provenance.config_matmul_dtype(path, cfg)  # an old folder's auto: what it ran
    try:
        env = cfg["env"]["id"]
        act = cfg["agent"]["activation"]
        if not isinstance(act, dict) or "name" not in act:
            raise KeyError("agent.activation.name")
        setting = ActivationSetting.from_config(act)
        total_steps = _pos_int(cfg["total_steps"], "total_steps")
        eval_freq = _pos_int(cfg["eval_freq"], "eval_freq")
        seeds = _pos_int(cfg["seeds"], "seeds")
        first_seed = int(cfg.get("first_seed", 0))
        base_seed = int(cfg.get("seed", 0))
    except (KeyError, TypeError, ValueError) as e:
        raise RunError(f"{cfg_path}: missing or invalid key {cli_parser.one_line(e)}") from None
    if not isinstance(env, str):
        raise RunError(f"{cfg_path}: env.id must be a string")
    if total_steps % eval_freq:
        raise RunError(f"{cfg_path}: total_steps={total_steps} is not a multiple of eval_freq={eval_freq} "
                       f"(swim_jax.run.train evaluates every eval_freq steps up to total_steps, so it must divide it)")
    plan = Schedule(total_steps, eval_freq)
    returns = _read_returns(ev_path, plan.n_evals, seeds)
    _check_steps(path, plan, returns.shape[0])
    metrics = load_metrics(path, eval_freq, total_steps, [first_seed + i for i in range(seeds)])
    if at_step is not None:
        if at_step <= 0 or at_step % eval_freq or at_step > total_steps:
            raise RunError(f"{path}: --at-step {at_step} is not an evaluation step of this run (a multiple of "
                           f"eval_freq={eval_freq} in 1..total_steps={total_steps})")
        n = 1 + plan.eval_index(at_step)
        if returns.shape[0] < n:
            raise RunError(f"{path}: has reached step {plan.eval_step(returns.shape[0] - 1)}, not --at-step {at_step}")
        returns, total_steps = returns[:n], at_step
        if metrics is not None:
            metrics = LearningMetrics(metrics.steps[: n - 1], {c: v[: n - 1] for c, v in metrics.values.items()})
    suffix = _point_suffix(path, act)
    return Run(
        path=path, config=_with_default_activation_params(cfg), env=env, activation=setting.label + suffix,
        total_steps=total_steps,
        eval_freq=eval_freq, seed_ids=[(base_seed, first_seed + i) for i in range(seeds)],
        returns=returns, metrics=metrics,
        setting=setting, sweep_suffix=suffix, matmul_dtype=read_matmul_dtype(path, cfg),
    )


def _check_steps(path: str, plan: Schedule, n: int) -> None:
    """A run folder's ``evaluation_steps.npy`` (written since 2026-12-06) must be the schedule's steps
    of its ``n`` evaluations; :class:`RunError` otherwise (older folders have none: the schedule's)."""
    file = os.path.join(path, STEPS_FILE)
    if not os.path.isfile(file):
        return
    try:
        steps = np.load(file, allow_pickle=False)
    except (ValueError, OSError, EOFError) as e:
        raise RunError(f"{file}: unreadable .npy ({cli_parser.one_line(e)})") from None
    if steps.shape != (n,) or not np.array_equal(steps, plan.eval_steps(n)):
        raise RunError(f"{file}: steps {steps.tolist()[:4]}... do not match config.yaml's schedule "
                       f"(evaluation i at i · eval_freq={plan.eval_freq}, {n} evaluations)")


def read_matmul_dtype(path: str, cfg: dict) -> str:
    """The dtype the run's matmul products ran in, per stretch as recorded
    (``swim_jax.io.provenance.recorded_matmul_dtypes``; consecutive repeats merged, a change written
    ``"bfloat16→float32"``); for a run that recorded nothing, what its config says (``bfloat16``, or
    its precision)."""
    stretches = provenance.recorded_matmul_dtypes(path)
    if stretches:
        return "→".join(d for i, d in enumerate(stretches) if i == 0 or d != stretches[i - 1])
    if provenance.config_matmul_dtype(path, cfg) == "bfloat16":
        return "bfloat16"
    return str(cfg.get("precision", "float32"))


def numerics(r: Run) -> str:
    """The run's precision and, where they differ from it, its matmul products: ``"float32"``,
    ``"float32, bfloat16 products"``."""
    precision = str(r.config.get("precision", "float32"))
    return precision if r.matmul_dtype == precision else f"{precision}, {r.matmul_dtype} products"


def _run_files(path: str) -> tuple[str, str]:
    """``(config.yaml, evaluations.npy)`` of the run folder ``path``; :class:`RunError` when either
    is missing (with a hint when ``path`` holds run folders instead)."""
    if not os.path.isdir(path):
        raise RunError(f"{path}: not a directory")
    cfg_path = os.path.join(path, "config.yaml")
    ev_path = os.path.join(path, "evaluations.npy")
    for p in (cfg_path, ev_path):
        if not os.path.isfile(p):
            inner = sorted(e for e in os.listdir(path)
                           if os.path.isfile(os.path.join(path, e, "config.yaml")))
            hint = (f"; it contains {len(inner)} run folder(s) such as {os.path.join(path, inner[0])}: "
                    f"pass those instead" if inner else " (not a run folder of python -m swim_jax.train?)")
            raise RunError(f"{path}: missing {os.path.basename(p)}{hint}")
    return cfg_path, ev_path


def _read_config(cfg_path: str) -> dict:
    """The mapping in ``config.yaml``; :class:`RunError` when unreadable or not a mapping."""
    try:
        with open(cfg_path) as f:
            cfg = yaml.safe_load(f)
    except (yaml.YAMLError, OSError, UnicodeDecodeError) as e:
        raise RunError(f"{cfg_path}: unreadable YAML ({cli_parser.one_line(e)})") from None
    if not isinstance(cfg, dict):
        raise RunError(f"{cfg_path}: expected a mapping, got {type(cfg).__name__}")
    return cfg


def _read_returns(ev_path: str, expected: int, seeds: int) -> np.ndarray:
    """``evaluations.npy`` as float64 ``[n_evals, seeds]`` with ``1 <= n_evals <= expected``, every
    value finite and real; :class:`RunError` otherwise."""
    try:
        returns = np.load(ev_path, allow_pickle=False)
    except (ValueError, OSError, EOFError) as e:
        raise RunError(f"{ev_path}: unreadable .npy ({cli_parser.one_line(e)})") from None
    if returns.ndim != 2 or returns.shape[1] != seeds or not 1 <= returns.shape[0] <= expected:
        raise RunError(f"{ev_path}: shape {returns.shape} does not match config.yaml "
                       f"(expected [<= {expected} evaluations, {seeds} seeds])")
    if returns.dtype.kind not in "iuf":  # complex would lose its imaginary part in the float cast
        raise RunError(f"{ev_path}: dtype {returns.dtype} is not real-valued numbers; expected float "
                       f"(or integer) returns")
    if not np.all(np.isfinite(returns)):
        raise RunError(f"{ev_path}: non-finite returns (NaN or inf)")
    return returns.astype(np.float64)


def load_metrics(path: str, eval_freq: int, total_steps: int, seeds: list[int]) -> LearningMetrics | None:
    """The run folder's ``metrics.csv`` as :class:`LearningMetrics` (columns in the order of
    ``seeds``, the run's seed indices), None when there is none. Raises :class:`RunError` (one line)
    when it is unreadable, names another seed, has a step that is not a chunk end
    (``k · eval_freq``, ``0 < k · eval_freq <= total_steps``) or a (step, seed) twice."""
    p = os.path.join(path, learning_log.FILENAME)
    if not os.path.isfile(p):
        return None
    try:
        m = learning_log.read(p)
    except (OSError, UnicodeDecodeError, csv.Error, KeyError, ValueError, TypeError) as e:
        raise RunError(f"{p}: unreadable ({cli_parser.one_line(e)}; expected the columns "
                       f"{','.join(learning_log.COLUMNS)})") from None
    column = {s: j for j, s in enumerate(seeds)}
    n = int(m["step"].max()) // eval_freq if m["step"].size else 0
    values = {c: np.full((n, len(seeds)), np.nan) for c in METRIC_COLUMNS}
    seen = set()
    for r, (step, seed) in enumerate(zip(m["step"].tolist(), m["seed"].tolist())):
        if seed not in column:
            raise RunError(f"{p}: row {r + 2} has seed {seed}, not one of the run's seeds {seeds}")
        if step <= 0 or step % eval_freq or step > total_steps:
            raise RunError(f"{p}: row {r + 2} has step {step}, not a chunk end (a multiple of "
                           f"eval_freq={eval_freq} in 1..total_steps={total_steps})")
        if (step, seed) in seen:
            raise RunError(f"{p}: step {step} of seed {seed} appears twice")
        seen.add((step, seed))
        for c in METRIC_COLUMNS:
            values[c][step // eval_freq - 1, column[seed]] = m[c][r]
    return LearningMetrics(Schedule(n * eval_freq, eval_freq).chunk_ends(), values)


def group_runs(runs: list[Run], allow_incomplete: bool = False, mixed_precision: bool = False) -> dict[str, EnvGroup]:
    """Group runs into ``{env: EnvGroup}`` following the module's policy; raise :class:`RunError`."""
    by_env: dict[str, list[Run]] = {}
    for r in runs:
        by_env.setdefault(r.env, []).append(r)
    groups = {}
    for env in sorted(by_env):
        env_runs = by_env[env]
        first = env_runs[0]
        for r in env_runs[1:]:
            if (r.total_steps, r.eval_freq) != (first.total_steps, first.eval_freq):
                raise RunError(
                    f"{env}: runs differ in budget and cannot be compared: {first.path} has "
                    f"total_steps={first.total_steps} eval_freq={first.eval_freq}, {r.path} has "
                    f"total_steps={r.total_steps} eval_freq={r.eval_freq}; report them separately")
        mixed = _numerics_differences(env_runs)
        if mixed and not mixed_precision:
            raise RunError(f"{env}: {mixed}; a difference between them may be one of precision: report runs of "
                           "one precision, or pass --mixed-precision to compare them anyway (their rows are marked)")
        n_common = min(r.returns.shape[0] for r in env_runs)
        truncated = None
        incomplete = [r for r in env_runs if not r.complete]
        if incomplete:
            r = incomplete[0]
            if not allow_incomplete:
                raise RunError(f"{r.path}: incomplete run ({r.returns.shape[0]} of {r.expected_evals} "
                               f"evaluations); pass --allow-incomplete to truncate {env} to common steps")
            truncated = (n_common - 1) * first.eval_freq
        by_act: dict[str, list[Run]] = {}
        for r in env_runs:
            by_act.setdefault(r.activation, []).append(r)
        curves = {}
        for act in sorted(by_act, key=_act_order):
            curves[act] = _pool(env, act, by_act[act], n_common, first.eval_freq)
        g = EnvGroup(env, first.total_steps, first.eval_freq, curves, truncated, mixed_precision=mixed)
        g.warnings = _cross_activation_differences(by_act) + ([f"compared on request (--mixed-precision): {mixed}"]
                                                               if mixed else [])
        groups[env] = g
    return groups


def load_runs(paths: list[str], at_step: int | None = None) -> list[Run]:
    """:func:`load_run` on every path (at ``at_step`` when given), sweep folders expanded to their
    points (:func:`expand_sweeps`)."""
    return [load_run(p, at_step) for p in expand_sweeps(paths)]


def expand_sweeps(paths: list[str]) -> list[str]:
    """Replace every sweep folder (``swim_jax.sweep``: ``sweep.csv`` + ``points/``) by its point
    folders, in grid order (``sweep.csv``'s row order); other paths are kept as given."""
    out = []
    for p in paths:
        table = os.path.join(p, "sweep.csv")
        if os.path.isfile(table):
            labels = _sweep_labels(table)
            if not labels:
                raise RunError(f"{table}: no sweep points (the sweep has not written an evaluation yet?)")
            out.extend(os.path.join(p, "points", label) for label in labels)
        else:
            out.append(p)
    return out


def _sweep_labels(table: str) -> list[str]:
    """The ``point`` column of ``sweep.csv``, in row order. The file is CSV with quoting (labels of
    multi-axis sweeps contain commas: ``"beta=0.5,tau=0.01"``). Tables written before quoting have
    bare labels: fine without commas; a row with more fields than the header is such an unquoted
    multi-axis label, whose pieces are the extra leading fields (no value or key holds a comma)."""
    try:
        with open(table, newline="") as f:
            rows = [r for r in csv.reader(f) if r]
    except (OSError, UnicodeDecodeError, csv.Error) as e:
        raise RunError(f"{table}: unreadable ({cli_parser.one_line(e)})") from None
    if not rows or rows[0][0] != "point":
        raise RunError(f"{table}: not a sweep table (expected a CSV header starting with 'point', "
                       f"as written by python -m swim_jax.sweep)")
    width = len(rows[0])
    labels = []
    for line, row in enumerate(rows[1:], 2):
        extra = len(row) - width
        if extra < 0:
            raise RunError(f"{table}: line {line} has {len(row)} fields, the header {width} (truncated file?)")
        labels.append(",".join(row[:extra + 1]))
    return labels


def _point_suffix(path: str, act: dict) -> str:
    """``[tau=0.01,actor_lr=0.0001]`` for a sweep point's non-activation values ('' otherwise):
    points that differ only there are different experiments, not more seeds."""
    p = os.path.join(path, "point.json")
    if not os.path.isfile(p):
        return ""
    try:
        with open(p) as f:
            values = json.load(f)["values"]
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise RunError(f"{p}: unreadable ({cli_parser.one_line(e)})") from None
    other = [f"{k.rsplit('.', 1)[-1]}={float(v):g}" for k, v in values.items() if not k.startswith("agent.activation.")]
    return f"[{','.join(other)}]" if other else ""


def load_and_group(paths: list[str], allow_incomplete: bool = False, at_step: int | None = None,
                   mixed_precision: bool = False) -> dict[str, EnvGroup]:
    """:func:`load_run` on every path (at ``at_step`` when given; sweep folders expanded to their
    points, duplicates refused), then :func:`group_runs`."""
    paths = expand_sweeps(paths)
    seen = {}
    for p in paths:
        key = os.path.realpath(p)
        if key in seen:
            raise RunError(f"{p}: given twice (also as {seen[key]})")
        seen[key] = p
    return group_runs([load_run(p, at_step) for p in paths], allow_incomplete=allow_incomplete,
                      mixed_precision=mixed_precision)


def _pool(env: str, act: str, runs: list[Run], n: int, eval_freq: int) -> Curves:
    ref = flat_config(runs[0].config, POOL_IGNORED_KEYS)
    owner = {}
    for r in runs:
        diff = _dict_diff(ref, flat_config(r.config, POOL_IGNORED_KEYS))
        if diff:
            k = "agent.kind" if "agent.kind" in diff else diff[0]  # another algorithm: its keys differ too
            raise RunError(f"{env}/{act}: cannot pool {runs[0].path} and {r.path} as seeds of one "
                           f"experiment: they differ in {k} ({ref.get(k)!r} vs "
                           f"{flat_config(r.config, POOL_IGNORED_KEYS).get(k)!r})")
        for sid in r.seed_ids:
            if sid in owner:
                raise RunError(f"{env}/{act}: {owner[sid]} and {r.path} both contain seed index {sid[1]} "
                               f"of base seed {sid[0]} (the same seed would be counted twice)")
            owner[sid] = r.path
    returns = np.concatenate([r.returns[:n] for r in runs], axis=1)
    steps = Schedule(n * eval_freq, eval_freq).eval_steps(n)
    return Curves(env, act, steps, returns, [r.path for r in runs], _pool_metrics(runs, n - 1, eval_freq),
                  [r.path for r in runs if r.metrics is None], runs[0].setting, runs[0].sweep_suffix,
                  sorted({r.matmul_dtype for r in runs}),
                  [dataclasses.replace(r, returns=r.returns[:n]) for r in runs])


def _pool_metrics(runs: list[Run], n_chunks: int, eval_freq: int) -> LearningMetrics | None:
    """The runs' metrics side by side (seeds of the runs that have a metrics.csv), over the first
    ``n_chunks`` chunks (those the evaluations cover; missing rows nan); None if no run has one."""
    have = [r.metrics for r in runs if r.metrics is not None]
    if not have:
        return None

    def rows(v: np.ndarray) -> np.ndarray:
        out = np.full((n_chunks, v.shape[1]), np.nan)
        out[: min(n_chunks, v.shape[0])] = v[:n_chunks]
        return out

    values = {c: np.concatenate([rows(m.values[c]) for m in have], axis=1) for c in METRIC_COLUMNS}
    return LearningMetrics(Schedule(n_chunks * eval_freq, eval_freq).chunk_ends(), values)


def _cross_activation_differences(by_act: dict[str, list[Run]]) -> list[str]:
    ignored = POOL_IGNORED_KEYS | {"agent.activation", "precision", "matmul_dtype"}  # (numerics: refused above)
    acts = sorted(by_act, key=_act_order)
    if len(acts) < 2:
        return []
    ref_act = acts[0]
    ref = flat_config(by_act[ref_act][0].config, ignored)
    out = []
    for a in acts[1:]:
        other = flat_config(by_act[a][0].config, ignored)
        for k in _dict_diff(ref, other):
            out.append(f"{ref_act} and {a} runs differ in {k}: {ref.get(k)!r} vs {other.get(k)!r}")
    return out


def _numerics_differences(runs: list[Run]) -> str | None:
    """None when every run has the same :func:`numerics` and none changed its products between
    stretches; else the runs by numerics in words (``"runs differ in precision or matmul_dtype:
    float32: walker_swim; float32, bfloat16 products: walker_swish, walker_relu"``)."""
    by: dict[str, list[str]] = {}
    for r in runs:
        by.setdefault(numerics(r), []).append(os.path.basename(os.path.normpath(r.path)))
    if len(by) < 2 and not any("→" in r.matmul_dtype for r in runs):
        return None
    return "runs differ in precision or matmul_dtype: " + "; ".join(f"{n}: {', '.join(ps)}" for n, ps in by.items())


def flat_config(d: dict, ignored) -> dict:
    """``d`` flattened to dotted keys (``agent.activation.k``: :func:`swim_jax.io.cli_parser.dotted_keys`),
    without the keys in ``ignored`` (a dotted key there drops its whole sub-tree)."""
    return {k: v for k, v in cli_parser.dotted_keys(d).items()
            if not any(k == i or k.startswith(i + ".") for i in ignored)}


def _dict_diff(a: dict, b: dict) -> list[str]:
    return sorted(k for k in set(a) | set(b) if a.get(k, _MISSING) != b.get(k, _MISSING))


_MISSING = object()


def _act_order(label: str):
    """Sort key of a label: the paper's activations first, in registry order (Swim, Swish, ReLU,
    each with its variants sorted by label), then every other label alphabetically."""
    paper = [name for name, spec in ACTIVATIONS.items() if spec.paper]
    base = label_activation(label)
    return (paper.index(base) if base in paper else len(paper), label)


def _pos_int(v, name: str) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or v != int(v) or int(v) <= 0:
        raise ValueError(f"{name}={v!r} (must be a positive integer)")
    return int(v)


__all__ = ["RunError", "Run", "Curves", "EnvGroup", "activation_label", "load_run", "group_runs",
           "load_and_group"]


