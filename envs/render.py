"""Offscreen rendering of a trajectory of physics states with ``mujoco.Renderer``.

Needs an OpenGL backend for headless Linux, chosen by ``MUJOCO_GL`` *before* mujoco creates a
context: ``MUJOCO_GL=egl`` (Debian/Ubuntu package ``libegl1``, plus a GPU or Mesa's EGL
``libegl-mesa0``) or ``MUJOCO_GL=osmesa`` (software, package ``libosmesa6``). Where neither
works, :func:`render_trajectory` raises :class:`RenderingUnavailable` with that advice.
"""

from __future__ import annotations

import os
from typing import Optional, Sequence, Union

import mujoco
import numpy as np

GL_HELP = ("offscreen rendering needs an OpenGL backend: set MUJOCO_GL=egl (apt install libegl1 "
           "libegl-mesa0) or MUJOCO_GL=osmesa (apt install libosmesa6) before importing mujoco")


class RenderingUnavailable(RuntimeError):
    """No usable OpenGL context for offscreen rendering (message names the fix)."""


def render_trajectory(env, qpos: Union[np.ndarray, Sequence[np.ndarray]],
                      height: int = 240, width: int = 320,
                      camera: Optional[Union[int, str]] = None) -> np.ndarray:
    """Render each qpos row of ``qpos`` (shape ``(T, nq)``) of ``env``'s model to RGB frames.

    Positions only (``mj_forward`` at zero velocity per frame). Returns a
    ``uint8`` array of shape ``(T, height, width, 3)``. ``camera`` is a camera name/id of the
    XML (default: MuJoCo's free camera tracking nothing, -1). Raises
    :class:`RenderingUnavailable` when no GL backend can create an offscreen context.
    """
    model = env.mj_model
    qpos = np.asarray(qpos, dtype=np.float64)
    if qpos.ndim != 2 or qpos.shape[1] != model.nq:
        raise ValueError(f"qpos must have shape (T, {model.nq}), got {qpos.shape}")
    model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
    model.vis.global_.offheight = max(model.vis.global_.offheight, height)
    try:
        renderer = mujoco.Renderer(model, height=height, width=width)
    except Exception as e:  # GL backends fail with assorted exception types
        backend = os.environ.get("MUJOCO_GL", "<unset>")
        raise RenderingUnavailable(f"{GL_HELP} (MUJOCO_GL={backend}: {e})") from e
    data = mujoco.MjData(model)
    frames = np.empty((qpos.shape[0], height, width, 3), np.uint8)
    cam = -1 if camera is None else camera
    try:
        for i, q in enumerate(qpos):
            data.qpos[:] = q
            mujoco.mj_forward(model, data)
            renderer.update_scene(data, camera=cam)
            frames[i] = renderer.render()
    finally:
        renderer.close()
    return frames
