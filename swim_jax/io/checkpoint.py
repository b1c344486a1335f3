"""Orbax checkpoints of an arbitrary pytree, keyed by the env step, keeping the last few.

The tree is stored under the names of its leaves: each leaf's path of attribute names, dict keys and
sequence indices joined by dots (:func:`leaf_names`: ``0.agent.actor.params.body.dense_0.kernel``),
as orbax's nested mapping of those parts, so any pytree (NamedTuples, flax/brax dataclasses, MJX
data) round-trips and a reader finds a part by its name (the policy reader finds the actor so:
swim_jax/policy/checkpoint.py). Restoring needs a template tree of the same structure (e.g. a freshly
initialised state, or its ``jax.eval_shape``); zero-size leaves are not stored and are rebuilt.
Checkpoints written before 2026-12-06 hold the leaves under their index in ``jax.tree.leaves``
order (``"00000"``, ``"00001"``, …): they are read by index, as they were written. Orbax writes each
checkpoint to a temporary directory and renames it when complete, so a process killed mid-save
leaves the previous checkpoints intact and ``latest_step`` never returns a partial one.
"""

from __future__ import annotations

import os

import jax
import jax.numpy as jnp
import numpy as np
import orbax.checkpoint as ocp


def _part(key) -> str:
    """One step of a leaf's path as a name part: an attribute's name, a dict key, a sequence index."""
    for attr in ("name", "key", "idx"):
        if hasattr(key, attr):
            return str(getattr(key, attr))
    return str(key)


def leaf_names(tree) -> list[str]:
    """The name of every leaf of ``tree``, in ``jax.tree.leaves`` order: its path's parts joined by dots."""
    return [".".join(_part(k) for k in path) for path, _ in jax.tree_util.tree_flatten_with_path(tree)[0]]


def _index_keys(tree) -> list[str]:
    """Every leaf's key in the format written before leaf names (``"00000"``, … in leaves order)."""
    return [f"{i:05d}" for i in range(len(jax.tree.leaves(tree)))]


def nest(flat: dict) -> dict:
    """``{"a.b.c": x}`` as ``{"a": {"b": {"c": x}}}`` (orbax's nested mapping)."""
    out: dict = {}
    for name, value in flat.items():
        node = out
        *parents, last = name.split(".")
        for p in parents:
            node = node.setdefault(p, {})
        node[last] = value
    return out


def unnest(tree, prefix: str = "") -> dict:
    """The inverse of :func:`nest`: a nested mapping's leaves by their dotted names."""
    if not isinstance(tree, dict):
        return {prefix: tree}
    out = {}
    for k, v in tree.items():
        out.update(unnest(v, f"{prefix}.{k}" if prefix else str(k)))
    return out


def _stored(tree, keys: list[str]) -> dict:
    """``{key: leaf}`` of ``tree``'s leaves under ``keys``, zero-size ones left out (orbax cannot store them)."""
    return {k: leaf for k, leaf in zip(keys, jax.tree.leaves(tree)) if np.size(leaf) > 0}


class Checkpointer:
    """Save/restore pytrees under ``directory/<step>/``; at most ``keep`` checkpoints are kept."""

    def __init__(self, directory: str, keep: int = 3):
        self.directory = os.path.abspath(directory)
        self.manager = ocp.CheckpointManager(
            self.directory,
            options=ocp.CheckpointManagerOptions(max_to_keep=keep, create=True),
            item_handlers=ocp.StandardCheckpointHandler(),  # (so a new manager reads item metadata)
        )

    def save(self, step: int, tree) -> None:
        """Write ``tree`` as checkpoint ``step`` (its leaves by name) and wait until it is complete on disk."""
        self.manager.save(int(step), args=ocp.args.StandardSave(nest(_stored(tree, leaf_names(tree)))))
        self.manager.wait_until_finished()

    def latest_step(self) -> int | None:
        """The newest complete checkpoint's step, or None."""
        return self.manager.latest_step()

    def all_steps(self) -> list[int]:
        """The steps of every kept checkpoint, oldest first."""
        return sorted(self.manager.all_steps())

    def _metadata(self, step: int) -> dict:
        """``{key: metadata}`` of every leaf checkpoint ``step`` holds (dotted names, or index keys)."""
        return unnest(dict(self.manager.item_metadata(int(step)).tree))

    def stored_keys(self, step: int) -> set[str]:
        """The keys of the leaves checkpoint ``step`` holds (their dotted names; index keys in a
        checkpoint written before leaf names), from its metadata alone."""
        return set(self._metadata(step))

    def _keys(self, step: int, tree) -> list[str]:
        """The keys checkpoint ``step`` holds ``tree``'s leaves under: their names, or their indices
        in a checkpoint written before leaf names."""
        stored = self._metadata(step)
        indexed = bool(stored) and all(k.isdigit() and len(k) == 5 for k in stored)
        return _index_keys(tree) if indexed else leaf_names(tree)

    def holds(self, step: int, tree) -> bool:
        """Whether checkpoint ``step`` holds exactly ``tree``'s non-empty leaves (arrays or
        ShapeDtypeStructs), from its metadata alone."""
        keys = self._keys(step, tree)
        want = {k for k, leaf in zip(keys, jax.tree.leaves(tree)) if np.prod(np.shape(leaf)) > 0}
        return set(self._metadata(step)) == want

    def stored_shapes(self, step: int, tree) -> list[tuple[int, ...] | None]:
        """Per leaf of ``tree`` (in leaves order) its shape in checkpoint ``step`` (None where it is
        not stored), from the metadata alone."""
        stored = self._metadata(step)
        return [tuple(stored[k].shape) if k in stored else None for k in self._keys(step, tree)]

    def restore(self, step: int, template, shardings=None):
        """Checkpoint ``step`` as a tree shaped like ``template`` (arrays or ShapeDtypeStructs).

        ``shardings`` (a tree of shardings matching ``template``, or None): where every array goes,
        straight from the files; with several processes each reads only its own devices' part. None:
        ordinary (uncommitted) arrays on the default device."""
        leaves, treedef = jax.tree.flatten(template)
        keys = self._keys(step, template)
        where = [None] * len(leaves) if shardings is None else jax.tree.leaves(
            shardings, is_leaf=lambda x: isinstance(x, jax.sharding.Sharding))
        abstract = {k: jax.ShapeDtypeStruct(np.shape(x), x.dtype, sharding=sh)
                    for k, x, sh in zip(keys, leaves, where) if np.prod(np.shape(x)) > 0}
        flat = unnest(self.manager.restore(int(step), args=ocp.args.StandardRestore(nest(abstract))))
        if shardings is not None:
            out = [flat[k] if k in flat else jax.device_put(np.zeros(np.shape(x), x.dtype), sh)
                   for k, x, sh in zip(keys, leaves, where)]
            return jax.tree.unflatten(treedef, out)
        # Orbax returns arrays committed to a device; jit keys its cache on that, so a committed
        # state would compile the training program again. Rebuild them as ordinary arrays.
        out = [jnp.asarray(np.asarray(flat[k])) if k in flat else jnp.zeros(np.shape(x), x.dtype)
               for k, x in zip(keys, leaves)]
        return jax.tree.unflatten(treedef, out)

    def close(self) -> None:
        """Stop the checkpoint manager (call once no save is needed any more)."""
        self.manager.close()


def latest_complete_step(directory: str) -> int | None:
    """The newest complete checkpoint's step under ``directory`` read from the folder names alone
    (orbax renames a checkpoint to its bare step once every process has written it), without
    starting a checkpoint manager; None when there is none. For error messages."""
    if not os.path.isdir(directory):
        return None
    steps = [int(name) for name in os.listdir(directory) if name.isdigit()]
    return max(steps) if steps else None
