"""The files of a run folder (their formats: the docstring of swim_jax/run/train.py).

:class:`RunFolder` writes them as a run goes: the configs when it starts, the evaluations, the
learning metrics (``metrics.csv``), the learnable activation parameters and TensorBoard events
after every chunk, and the final policy and timing at the end. A sweep writes one output folder per
point (``points/<label>/``) and ``sweep.csv``; without a sweep the run folder is the one output folder.
"""

from __future__ import annotations

import contextlib
import csv
import dataclasses
import json
import os
import time

import jax
import numpy as np
import yaml

from swim_jax import config as cfgmod
from swim_jax.run import learned_params
from swim_jax.io import learning_log, tensorboard_log
from swim_jax.io.schedule import STEPS_FILE
from swim_jax.config import Config
from swim_jax.placement.distributed import to_host
from swim_jax.placement.layout import LaneLayout


def new_run_dir(cfg: Config) -> str:
    """``<out_dir>/<name>-<UTC timestamp>``, with ``-2``, ``-3``, ... when that exists."""
    stamp = time.strftime("%Y%m%d-%H%M%S", time.gmtime())
    base = os.path.join(cfg.out_dir, f"{cfg.name}-{stamp}")
    path, n = base, 1
    while os.path.exists(path):
        n += 1
        path = f"{base}-{n}"
    return path


def point_outputs(cfg: Config, run_dir: str, points) -> list[tuple[str, Config]]:
    """(output folder, plain config) per sweep point; ``[(run_dir, cfg)]`` without a sweep."""
    if not cfg.sweep:
        return [(run_dir, cfg)]
    out = []
    for point in points:
        label = cfgmod.point_label(point)
        pc = dataclasses.replace(cfgmod.point_config(cfg, point), name=f"{cfg.name}-{label}")
        out.append((os.path.join(run_dir, "points", label), pc))
    return out


def write_evaluations(run_dir: str, cfg: Config, evals: np.ndarray, n_done: int) -> None:
    """Write the first ``n_done`` evaluations of the real seeds (CSV + .npy, and their steps:
    ``evaluation_steps.npy``), overwriting."""
    ev = evals[:n_done, : cfg.seeds]
    means = ev.mean(axis=2)  # [n, seeds]
    steps = cfgmod.schedule(cfg).eval_steps(n_done)
    np.save(os.path.join(run_dir, "evaluations.npy"), means)
    np.save(os.path.join(run_dir, STEPS_FILE), steps)
    np.save(os.path.join(run_dir, "evaluations_episodes.npy"), ev)
    for i in range(cfg.seeds):
        np.save(os.path.join(run_dir, f"evaluations_seed{cfg.first_seed + i}.npy"), means[:, i])
    with open(os.path.join(run_dir, "evaluations.csv"), "w") as f:
        cols = [f"seed_{cfg.first_seed + i}" for i in range(cfg.seeds)]
        f.write(",".join(["step", *cols, "mean", "std"]) + "\n")
        for j in range(n_done):
            row = [str(steps[j]), *(repr(float(x)) for x in means[j]),
                   repr(float(means[j].mean())), repr(float(means[j].std()))]
            f.write(",".join(row) + "\n")


def write_sweep_table(run_dir: str, cfg: Config, points, evals: np.ndarray) -> None:
    """``sweep.csv``: per point its values, the final and the best evaluation (mean over seeds of
    each seed's mean episode return; std over seeds), from ``evals[n_done, P·seeds, episodes]``."""
    keys = list(cfg.sweep)
    per_point = evals.mean(axis=2).reshape(evals.shape[0], len(points), cfg.seeds)  # [n, P, seeds]
    # csv quoting: multi-axis labels contain commas ("beta=0.5,tau=0.01") and are written quoted;
    # labels without commas are written bare, as before (swim_jax.analysis.runs_io.expand_sweeps reads both)
    with open(os.path.join(run_dir, "sweep.csv"), "w", newline="") as f:
        w = csv.writer(f, quoting=csv.QUOTE_MINIMAL, lineterminator="\n")
        w.writerow(["point", *keys, "final_mean", "final_std", "best_mean", "best_step"])
        for p, point in enumerate(points):
            m = per_point[:, p]  # [n, seeds]
            curve = m.mean(axis=1)
            best = int(np.argmax(curve))
            w.writerow([cfgmod.point_label(point), *(repr(point[k]) for k in keys),
                        repr(float(curve[-1])), repr(float(m[-1].std())), repr(float(curve[best])),
                        str(cfgmod.schedule(cfg).eval_step(best))])


def flat_params(params) -> dict[str, np.ndarray]:
    """``{"params/body/dense_0/kernel": array, ...}``: the layout of ``final_policy.npz``."""
    return {
        "/".join(str(getattr(k, "key", k)) for k in kp): np.asarray(v)
        for kp, v in jax.tree_util.tree_flatten_with_path(params)[0]
    }


LOG_FILES = (learned_params.FILENAME, learning_log.FILENAME)  # appended to after every chunk


class RunFolder:
    """The run folder of ``cfg`` at ``run_dir`` and its output folders: one per sweep point, the
    point's lanes of ``layout`` (swim_jax/placement/layout.py) writing into point ``p``'s.

    With several processes every process calls every method (some gather lanes from the others) and
    only the one made with ``writes=True`` (process 0) writes files."""

    def __init__(self, cfg: Config, run_dir: str, layout: LaneLayout, writes: bool = True):
        self.cfg, self.run_dir, self.layout, self.writes = cfg, run_dir, layout, writes
        self.seed_ids = layout.seed_ids()
        self.points = layout.points
        self.outputs = point_outputs(cfg, run_dir, self.points)  # (folder, plain config) per point
        self.lanes = layout.point_lanes()
        self.tb = None  # a tensorboard_log.TensorBoardLog once start_logs opened it

    def create(self, fresh: bool) -> None:
        """Make the folders; a fresh run writes config.yaml (per point too, with point.json)."""
        if not self.writes:
            return
        os.makedirs(self.run_dir, exist_ok=True)
        if not fresh:
            return
        with open(os.path.join(self.run_dir, "config.yaml"), "w") as f:
            f.write(cfgmod.dump(self.cfg))
        for point, (out_dir, point_cfg) in zip(self.points, self.outputs):
            os.makedirs(out_dir, exist_ok=True)
            if out_dir != self.run_dir:
                with open(os.path.join(out_dir, "config.yaml"), "w") as f:
                    f.write(cfgmod.dump(point_cfg))
                with open(os.path.join(out_dir, "point.json"), "w") as f:
                    json.dump({"label": cfgmod.point_label(point), "values": point}, f, indent=1)

    def grow_budget(self) -> int | None:
        """When resuming with a larger ``total_steps`` than the folder's config.yaml holds: write the
        configs again with the new budget (the run's and every point's) and remove the final policies
        of the old budget (written again when the run reaches the new one); returns the old budget,
        or None when it has not changed."""
        path = os.path.join(self.run_dir, "config.yaml")
        with open(path) as f:
            old = int((yaml.safe_load(f) or {}).get("total_steps", self.cfg.total_steps))
        if old == self.cfg.total_steps or not self.writes:
            return None if old == self.cfg.total_steps else old
        for out_dir, point_cfg in self.outputs:
            _write_text(os.path.join(out_dir, "config.yaml"), cfgmod.dump(point_cfg))
            with contextlib.suppress(FileNotFoundError):
                os.remove(os.path.join(out_dir, "final_policy.npz"))
        if all(d != self.run_dir for d, _ in self.outputs):
            _write_text(path, cfgmod.dump(self.cfg))
        return old

    def start_logs(self, restored_step: int | None, closing: contextlib.ExitStack) -> None:
        """Cut the logs after the checkpoint at ``restored_step``, or (None: training starts at step
        0) remove them; then open the TensorBoard writers (closed by ``closing``) if configured."""
        if not self.writes:
            return
        for out_dir, _ in self.outputs:
            for name in LOG_FILES:
                path = os.path.join(out_dir, name)
                if restored_step is not None:
                    learned_params.truncate_after(path, restored_step)
                elif os.path.exists(path):
                    os.remove(path)
            if restored_step is None and self.cfg.tensorboard:
                tensorboard_log.remove(out_dir)
        if self.cfg.tensorboard:
            every = self.cfg.eval_freq
            first_step = 0 if restored_step is None else (restored_step // every + 1) * every  # first logged below
            self.tb = tensorboard_log.TensorBoardLog(
                [(out_dir, self.seed_ids[lanes]) for lanes, (out_dir, _) in zip(self.lanes, self.outputs)], first_step)
            closing.callback(self.tb.close)

    def evaluation(self, j: int, returns: np.ndarray, agent) -> None:
        """Evaluation ``j``'s returns ``[lanes, episodes]`` as TensorBoard events, and the learnable
        activation parameters of ``agent`` (the lane-batched actor and critic) at its step."""
        step = j * self.cfg.eval_freq
        # gathered from every process before the writing process returns early
        values = (learned_params.activation_params(to_host(agent.actor), to_host(agent.critic))
                  if self.cfg.agent.activation.learnable else None)
        if not self.writes:
            return
        if self.tb is not None:
            for lanes, (out_dir, _) in zip(self.lanes, self.outputs):
                self.tb.evaluation(out_dir, step, self.seed_ids[lanes], returns[lanes].mean(axis=1))
        if values is not None:
            for lanes, (out_dir, _) in zip(self.lanes, self.outputs):
                learned_params.append(os.path.join(out_dir, learned_params.FILENAME), step,
                                      self.seed_ids[lanes], {k: v[lanes] for k, v in values.items()})

    def chunk(self, step: int, metrics: dict, episodes: np.ndarray, last_return: np.ndarray) -> None:
        """A chunk's learning metrics (per lane, ending at ``step``): metrics.csv rows and events."""
        if not self.writes:
            return
        for lanes, (out_dir, _) in zip(self.lanes, self.outputs):
            rows = learning_log.chunk_rows(step, self.seed_ids[lanes], {k: v[lanes] for k, v in metrics.items()},
                                           episodes[lanes], last_return[lanes])
            learning_log.append(os.path.join(out_dir, learning_log.FILENAME), rows)
            if self.tb is not None:
                self.tb.chunk(out_dir, rows)

    def evaluations(self, evals: np.ndarray, n_done: int) -> None:
        """The evaluation files of the first ``n_done`` of ``evals[n_evals, lanes, episodes]``."""
        if not self.writes:
            return
        for lanes, (out_dir, point_cfg) in zip(self.lanes, self.outputs):
            write_evaluations(out_dir, point_cfg, evals[:, lanes], n_done)
        if self.cfg.sweep:
            write_sweep_table(self.run_dir, self.cfg, self.points, evals[:n_done, : self.layout.real])

    def final_policy(self, final_actor: dict[str, np.ndarray]) -> None:
        """``final_policy.npz`` of every output folder from the flat actor params of the real lanes."""
        if not self.writes:
            return
        for lanes, (out_dir, _) in zip(self.lanes, self.outputs):
            np.savez(os.path.join(out_dir, "final_policy.npz"), **{k: v[lanes] for k, v in final_actor.items()})

    def timing(self, timing: dict) -> None:
        """``timing.json`` in the run folder and every output folder."""
        if not self.writes:
            return
        for out_dir in {self.run_dir, *(d for d, _ in self.outputs)}:
            with open(os.path.join(out_dir, "timing.json"), "w") as f:
                json.dump(timing, f, indent=2)


def _write_text(path: str, text: str) -> None:
    """Write ``path`` whole through a temporary file (a kill leaves the old file or the new one)."""
    with open(path + ".tmp", "w") as f:
        f.write(text)
    os.replace(path + ".tmp", path)
