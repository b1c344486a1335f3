"""The actor of one lane out of a training checkpoint (``checkpoints/<step>/``), for ``swim_jax.policy.run_folder``.

swim_jax/io/checkpoint.py stores the whole training state (``(TrainState, evaluations)``) under the
names of its leaves (``0.agent.actor.params.body.dense_0.kernel``): the online actor is the leaves
under the path that ends in ``actor`` (not ``actor_target``), found by name, each with the lanes in
front (``[lanes, …]``) and checked against the shapes the config implies. Checkpoints written before
leaf names hold the leaves as ``"00000"``, ``"00001"``, … in ``jax.tree.leaves`` order; there the
actor is the first run of consecutive leaves shaped like the actor (its head as wide as the agent's,
:func:`swim_jax.policy.run_folder.actor_leaf_shapes`): every agent's state inside ``TrainState``
starts with it, its leaves in the sorted order of :func:`swim_jax.policy.run_folder.actor_leaf_names`;
what comes before it (keys, env state, replay buffer) has other shapes, and the critics carry a
critic axis. Only those leaves are read (orbax partial restore), so this works for checkpoints with
or without the replay buffer inside. Reading orbax needs JAX, so this module is imported only when
a policy at a checkpoint step is asked for.
"""

from __future__ import annotations

import logging
import os
from typing import Sequence

import numpy as np


def _orbax():
    logging.getLogger("absl").setLevel(logging.ERROR)  # "metadata file does not exist" notices
    import orbax.checkpoint as ocp

    return ocp


def stored_leaves(path: str) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
    """``{key: (shape, dtype)}`` of every leaf in the orbax item at ``path`` (``<step>/default``)."""
    ocp = _orbax()
    meta = ocp.StandardCheckpointer().metadata(path).item_metadata
    tree = getattr(meta, "tree", meta)
    from swim_jax.io.checkpoint import unnest

    return {k: (tuple(v.shape), np.dtype(v.dtype)) for k, v in unnest(dict(tree)).items()}


def _indexed(leaves: dict) -> bool:
    """Whether the leaves are keyed by index (a checkpoint written before leaf names)."""
    return bool(leaves) and all(k.isdigit() and len(k) == 5 for k in leaves)


def find_actor(leaves: dict[str, tuple[tuple[int, ...], np.dtype]], shapes: Sequence[tuple[int, ...]],
               names: Sequence[str] = ()) -> list[str]:
    """The keys of the actor's leaves: by name (``<path>.actor.<name>`` for each of ``names``, the
    actor's ``params/body/...`` names), or in a checkpoint keyed by index the first run of
    consecutive leaves of floats whose shapes after one common lane axis are ``shapes``. Either way
    each leaf's shape after the lane axis must be its entry of ``shapes``; ValueError otherwise."""
    if not _indexed(leaves):
        tail = "." + names[0].replace("/", ".") if names else None
        for key in sorted(leaves):
            prefix = key[: -len(tail)] if tail and key.endswith(tail) else None
            if prefix is None or prefix.rsplit(".", 1)[-1] != "actor":
                continue
            keys = [f"{prefix}.{n.replace('/', '.')}" for n in names]
            if all(k in leaves and leaves[k][0][1:] == tuple(want) for k, want in zip(keys, shapes)):
                return keys
        raise ValueError("no actor leaves of this config's shapes (is it a python -m swim_jax.train checkpoint "
                         "of this config?)")
    index = {int(k): k for k in leaves}
    n = len(shapes)
    for start in sorted(index):
        keys = [index.get(start + j) for j in range(n)]
        if None in keys:
            continue
        found = [leaves[k] for k in keys]
        lanes = {s[0][0] if s[0] else None for s in found}
        if len(lanes) != 1 or None in lanes or any(d.kind != "f" for _, d in found):
            continue
        if all(shape[1:] == tuple(want) for (shape, _), want in zip(found, shapes)):
            return keys
    raise ValueError("no run of leaves shaped like the actor (is it a python -m swim_jax.train checkpoint of this config?)")


def actor_leaves(checkpoints: str, step: int, lane: int, names: Sequence[str],
                 shapes: Sequence[tuple[int, ...]]) -> dict[str, np.ndarray]:
    """``{name: array}`` of lane ``lane``'s actor at checkpoint ``step`` under ``checkpoints``:
    ``names`` are the actor's leaf names in flattening order (``swim_jax.policy.run_folder.actor_leaf_names``),
    ``shapes`` their shapes without the lane axis. ValueError when the checkpoint has no such leaves
    or no such lane."""
    path = os.path.join(checkpoints, str(int(step)), "default")
    if not os.path.isdir(path):
        raise ValueError(f"no checkpoint item at {path}")
    leaves = stored_leaves(path)
    keys = find_actor(leaves, shapes, names)
    lanes = leaves[keys[0]][0][0]
    if not 0 <= lane < lanes:
        raise ValueError(f"lane {lane} is not in the checkpoint's {lanes} lanes")
    ocp = _orbax()
    from swim_jax.io.checkpoint import nest, unnest

    item = nest({k: np.zeros(leaves[k][0], leaves[k][1]) for k in keys})
    restore = nest({k: ocp.RestoreArgs(restore_type=np.ndarray) for k in keys})
    out = unnest(ocp.PyTreeCheckpointer().restore(path, args=ocp.args.PyTreeRestore(
        item=item, restore_args=restore, partial_restore=True)))
    return {name: np.asarray(out[k])[lane] for name, k in zip(names, keys)}
