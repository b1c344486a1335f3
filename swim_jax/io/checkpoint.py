"""Orbax checkpoints of an arbitrary pytree, keyed by the env step, keeping the last few.

The tree is stored as a flat dict of its leaves ("00000", "00001", …) so any pytree (NamedTuples,
flax/brax dataclasses, MJX data) round-trips: restoring needs a template tree of the same
structure (e.g. a freshly initialised state, or its ``jax.eval_shape``). Orbax writes each
checkpoint to a temporary directory and renames it when complete, so a process killed mid-save
leaves the previous checkpoints intact and ``latest_step`` never returns a partial one.
"""

from __future__ import annotations

import os

import jax
import jax.numpy as jnp
import numpy as np
import orbax.checkpoint as ocp


def _flat(tree) -> dict:
    """Leaves by index; zero-size leaves (orbax cannot store them) are left out and rebuilt."""
    return {f"{i:05d}": leaf for i, leaf in enumerate(jax.tree.leaves(tree)) if np.size(leaf) > 0}


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
        """Write ``tree`` as checkpoint ``step`` and wait until it is complete on disk."""
        self.manager.save(int(step), args=ocp.args.StandardSave(_flat(tree)))
        self.manager.wait_until_finished()

    def latest_step(self) -> int | None:
        """The newest complete checkpoint's step, or None."""
        return self.manager.latest_step()

    def all_steps(self) -> list[int]:
        """The steps of every kept checkpoint, oldest first."""
        return sorted(self.manager.all_steps())

    def stored_keys(self, step: int) -> set[str]:
        """The leaf keys (``"00000"``, ...) checkpoint ``step`` holds (zero-size leaves are never
        stored), from its metadata alone."""
        return set(self.manager.item_metadata(int(step)).tree.keys())

    def stored_shape(self, step: int, key: str) -> tuple[int, ...]:
        """The shape of leaf ``key`` in checkpoint ``step``, from its metadata alone."""
        return tuple(self.manager.item_metadata(int(step)).tree[key].shape)

    @staticmethod
    def keys_of(tree) -> set[str]:
        """The leaf keys :meth:`save` stores for ``tree`` (arrays or ShapeDtypeStructs)."""
        return {f"{i:05d}" for i, leaf in enumerate(jax.tree.leaves(tree)) if np.prod(np.shape(leaf)) > 0}

    def restore(self, step: int, template, shardings=None):
        """Checkpoint ``step`` as a tree shaped like ``template`` (arrays or ShapeDtypeStructs).

        ``shardings`` (a tree of shardings matching ``template``, or None): where every array goes,
        straight from the files; with several processes each reads only its own devices' part. None:
        ordinary (uncommitted) arrays on the default device."""
        leaves, treedef = jax.tree.flatten(template)
        where = [None] * len(leaves) if shardings is None else jax.tree.leaves(
            shardings, is_leaf=lambda x: isinstance(x, jax.sharding.Sharding))
        abstract = {
            f"{i:05d}": jax.ShapeDtypeStruct(np.shape(x), x.dtype, sharding=sh)
            for i, (x, sh) in enumerate(zip(leaves, where)) if np.prod(np.shape(x)) > 0
        }
        flat = self.manager.restore(int(step), args=ocp.args.StandardRestore(abstract))
        if shardings is not None:
            out = [flat[f"{i:05d}"] if f"{i:05d}" in flat else jax.device_put(np.zeros(np.shape(x), x.dtype), sh)
                   for i, (x, sh) in enumerate(zip(leaves, where))]
            return jax.tree.unflatten(treedef, out)
        # Orbax returns arrays committed to a device; jit keys its cache on that, so a committed
        # state would compile the training program again. Rebuild them as ordinary arrays.
        out = [jnp.asarray(np.asarray(flat[f"{i:05d}"])) if f"{i:05d}" in flat else jnp.zeros(np.shape(x), x.dtype)
               for i, x in enumerate(leaves)]
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
