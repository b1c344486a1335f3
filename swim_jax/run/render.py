"""Render one episode of a trained policy: ``python -m swim_jax.render RUN_DIR --seed 0 --out FILE``.

    python -m swim_jax.render runs/cheetah_swim-20260101-120000 --seed 0 --out cheetah.gif
    python -m swim_jax.render RUN_DIR --seed 2 --out walker.mp4 --width 480 --height 360 --fps 30

Loads the run's ``config.yaml`` and ``final_policy.npz`` (actor parameters, leading axis = seed
position), rebuilds the env and actor exactly as ``swim_jax.run.train`` did (``swim_jax.run.programs.build``),
runs one episode with the deterministic policy (no exploration noise, like the evaluations) on the
MJX env, prints its return, then draws the visited states offscreen with ``mujoco.Renderer`` and
writes a GIF (Pillow) or an MP4 (needs an ``ffmpeg`` executable or the ``imageio-ffmpeg`` package).

``--seed`` is the seed index of the run (``first_seed`` … ``first_seed + seeds − 1``);
``--episode-key`` picks the reset noise of the episode (default 0). The episode return of one
episode differs from the run's evaluation (a mean over several episodes).

Offscreen GL: MuJoCo needs EGL or OSMesa on a headless Linux box. Debian/Ubuntu packages:
``libegl1`` + ``libegl-mesa0`` + ``libgl1-mesa-dri`` (EGL, software rendering via Mesa llvmpipe
works without a GPU), or ``libosmesa6`` (OSMesa). ``MUJOCO_GL`` chooses (``egl``/``osmesa``);
unset, EGL is tried, then OSMesa.

Exit status: 0 done; 2 bad input (missing/corrupt run folder, seed out of range, unsupported
``--out`` extension, existing ``--out`` without ``--force``): one line on stderr, nothing written;
3 skipped: no offscreen GL backend (or no ffmpeg for .mp4): one line on stderr, nothing written.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile

import jax
import jax.numpy as jnp
import numpy as np
import yaml
from PIL import Image

from swim_jax.io import cli_parser

GL_BACKENDS = ("egl", "osmesa")
_GL_PROBE = (
    "import mujoco\n"
    "m = mujoco.MjModel.from_xml_string('<mujoco><worldbody><geom size=\".1\"/></worldbody></mujoco>')\n"
    "r = mujoco.Renderer(m, 8, 8); d = mujoco.MjData(m); r.update_scene(d); r.render(); r.close()\n"
)
GL_HELP = ("install libegl1 libegl-mesa0 libgl1-mesa-dri (EGL) or libosmesa6 (OSMesa) and set "
           "MUJOCO_GL=egl or osmesa")


class RenderError(ValueError):
    """Bad input; ``str(e)`` is one line (exit 2)."""


class RenderSkipped(RuntimeError):
    """No offscreen GL backend or no video encoder; ``str(e)`` is one line (exit 3)."""


# ------------------------------------------------------------------------------------------------
# GL backend
# ------------------------------------------------------------------------------------------------


def choose_gl_backend() -> str:
    """Pick and export ``MUJOCO_GL`` for this process, probing candidates in subprocesses.

    Honours an explicit ``MUJOCO_GL``; otherwise tries ``egl`` then ``osmesa``. Must run before
    ``mujoco`` is first imported in this process (MuJoCo reads ``MUJOCO_GL`` at import). Raises
    :class:`RenderSkipped` naming the Debian packages when none works.
    """
    wanted = os.environ.get("MUJOCO_GL", "").strip().lower()
    candidates = (wanted,) if wanted else GL_BACKENDS
    errors = []
    for gl in candidates:
        env = dict(os.environ, MUJOCO_GL=gl, PYOPENGL_PLATFORM=gl if gl in GL_BACKENDS else "")
        try:
            p = subprocess.run([sys.executable, "-c", _GL_PROBE], env=env, capture_output=True, text=True,
                               timeout=120)
        except subprocess.TimeoutExpired:
            errors.append(f"{gl}: probe timed out")
            continue
        if p.returncode == 0:
            os.environ["MUJOCO_GL"] = gl
            if gl in GL_BACKENDS:
                os.environ.setdefault("PYOPENGL_PLATFORM", gl)
            return gl
        last = (p.stderr.strip().splitlines() or ["failed"])[-1]
        errors.append(f"{gl}: {last[:160]}")
    raise RenderSkipped(f"no offscreen OpenGL backend for MuJoCo ({'; '.join(errors)}); {GL_HELP}")


# ------------------------------------------------------------------------------------------------
# run folder -> env, agent, actor params
# ------------------------------------------------------------------------------------------------


def load_policy(run_dir: str, seed: int):
    """``(cfg, env, agent, actor_params)`` for seed index ``seed`` of ``run_dir``.

    Raises :class:`RenderError` (one line) when the folder, its config or its ``final_policy.npz`` is
    missing or inconsistent, or ``seed`` is not one of the run's seed indices.
    """
    # imported only now, after main's choose_gl_backend: they import mujoco, which reads MUJOCO_GL once
    from swim_jax import config as cfgmod
    from swim_jax.run.programs import build

    if os.path.isdir(os.path.join(run_dir, "points")) and os.path.isfile(os.path.join(run_dir, "sweep.csv")):
        points = sorted(os.listdir(os.path.join(run_dir, "points")))
        raise RenderError(f"{run_dir} is a sweep; render one of its points, e.g. "
                          f"{os.path.join(run_dir, 'points', points[0] if points else '<label>')}")
    for name in ("config.yaml", "final_policy.npz"):
        if not os.path.isfile(os.path.join(run_dir, name)):
            raise RenderError(f"{run_dir}: missing {name} (not a finished run folder of python -m swim_jax.train?)")
    try:
        _, cfg = cfgmod.read_run_config(run_dir)
    except (yaml.YAMLError, cfgmod.ConfigError, OSError, TypeError, ValueError) as e:
        raise RenderError(f"{run_dir}/config.yaml: {' '.join(str(e).split())[:300]}") from None
    pos = seed - cfg.first_seed
    if not 0 <= pos < cfg.seeds:
        raise RenderError(f"--seed {seed} is not in this run: its seeds are {cfg.first_seed}.."
                          f"{cfg.first_seed + cfg.seeds - 1}")
    try:
        with np.load(os.path.join(run_dir, "final_policy.npz"), allow_pickle=False) as z:
            flat = {k: z[k] for k in z.files}
    except (ValueError, OSError, EOFError) as e:
        raise RenderError(f"{run_dir}/final_policy.npz: unreadable ({' '.join(str(e).split())[:200]})") from None
    if not flat or any(v.ndim < 1 or v.shape[0] != cfg.seeds for v in flat.values()):
        raise RenderError(f"{run_dir}/final_policy.npz: arrays must have a leading axis of {cfg.seeds} seeds")

    env, _eval_env, agent = build(cfg)
    params = unflatten({k: v[pos] for k, v in flat.items()})
    _check_params(agent, env, params, run_dir)
    return cfg, env, agent, params


def unflatten(flat: dict) -> dict:
    """``{"a/b/c": x}`` → ``{"a": {"b": {"c": x}}}`` (the layout ``final_policy.npz`` is saved in)."""
    out: dict = {}
    for key, v in flat.items():
        node = out
        parts = key.split("/")
        for p in parts[:-1]:
            node = node.setdefault(p, {})
        node[parts[-1]] = v
    return out


def _check_params(agent, env, params, run_dir):
    """Raise :class:`RenderError` unless ``params`` has the shapes of ``agent``'s actor."""
    ref = agent.actor_net.init(jax.random.key(0), np.zeros((env.observation_size,), np.float32))
    got = jax.tree_util.tree_map(np.shape, params)
    want = jax.tree_util.tree_map(np.shape, jax.tree_util.tree_map(np.asarray, ref))
    if got != want:
        raise RenderError(f"{run_dir}/final_policy.npz: actor parameters do not match config.yaml's network")


# ------------------------------------------------------------------------------------------------
# episode
# ------------------------------------------------------------------------------------------------


def rollout(env, agent, params, key: int = 0, max_steps: int | None = None):
    """One deterministic-policy episode: ``(episode_return, qpos[T+1, nq], qvel[T+1, nv], steps)``.

    Stops at termination, at the env's time limit, or after ``max_steps`` steps if given. The
    return is the sum of the env's rewards over those steps (as the evaluations compute it).
    """
    params = jax.tree_util.tree_map(jnp.asarray, params)
    reset = jax.jit(env.reset)

    @jax.jit
    def step(state):
        return env.step(state, agent.act(params, state.obs))

    state = reset(jax.random.key(key))
    qpos, qvel = [np.asarray(state.pipeline_state.qpos)], [np.asarray(state.pipeline_state.qvel)]
    total, t = 0.0, 0
    limit = max_steps if max_steps is not None else (env.max_episode_steps or 1000)
    while t < limit:
        state = step(state)
        t += 1
        total += float(state.reward)
        qpos.append(np.asarray(state.pipeline_state.qpos))
        qvel.append(np.asarray(state.pipeline_state.qvel))
        if float(state.done):
            break
    return total, np.stack(qpos), np.stack(qvel), t


# ------------------------------------------------------------------------------------------------
# frames and video
# ------------------------------------------------------------------------------------------------


def render_frames(mj_model, qpos: np.ndarray, qvel: np.ndarray, width: int, height: int,
                  stride: int = 1) -> list[np.ndarray]:
    """RGB frames ``[height, width, 3]`` uint8 of every ``stride``-th state, offscreen.

    Uses the model's ``track`` camera when it has one (Gymnasium's XMLs do), else a camera tracking
    body 1 (the torso). Needs ``MUJOCO_GL`` set to a working backend before ``mujoco`` is imported.
    """
    import mujoco  # only now: MuJoCo reads MUJOCO_GL when first imported (see choose_gl_backend)

    model = mj_model
    model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
    model.vis.global_.offheight = max(model.vis.global_.offheight, height)
    data = mujoco.MjData(model)
    cam_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, "track")
    if cam_id >= 0:
        camera = cam_id
    else:
        camera = mujoco.MjvCamera()
        camera.type = mujoco.mjtCamera.mjCAMERA_TRACKING
        camera.trackbodyid = 1
        camera.distance = 3.0 * float(model.stat.extent)
        camera.elevation = -25.0
    frames = []
    with mujoco.Renderer(model, height, width) as r:
        for i in range(0, qpos.shape[0], stride):
            data.qpos[:] = qpos[i]
            data.qvel[:] = qvel[i]
            mujoco.mj_forward(model, data)
            r.update_scene(data, camera=camera)
            frames.append(r.render().copy())
    return frames


def ffmpeg_executable() -> str | None:
    """Path of an ffmpeg executable (``ffmpeg`` on PATH, else ``imageio_ffmpeg``'s), or ``None``."""
    exe = shutil.which("ffmpeg")
    if exe:
        return exe
    try:
        import imageio_ffmpeg  # optional package: only a fallback ffmpeg binary for .mp4

        return imageio_ffmpeg.get_ffmpeg_exe()
    except Exception:  # noqa: BLE001 - not installed or no binary
        return None


def write_video(path: str, frames: list[np.ndarray], fps: float) -> None:
    """Write ``frames`` (uint8 RGB, equal shapes) to ``path``: ``.gif`` via Pillow (looping), ``.mp4``
    via ffmpeg (H.264, yuv420p). Writes to a temporary file first, then renames."""
    if not frames:
        raise ValueError("no frames")
    ext = os.path.splitext(path)[1].lower()
    d = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".render-", suffix=ext, dir=d)
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)
    try:
        if ext == ".gif":
            imgs = [Image.fromarray(f) for f in frames]
            imgs[0].save(tmp, save_all=True, append_images=imgs[1:], duration=max(20, round(1000 / fps)),
                         loop=0, optimize=False)
        elif ext == ".mp4":
            exe = ffmpeg_executable()
            if exe is None:
                raise RenderSkipped("writing .mp4 needs ffmpeg (apt-get install ffmpeg, or pip install "
                                    "imageio-ffmpeg); use a .gif --out instead")
            h, w = frames[0].shape[:2]
            cmd = [exe, "-y", "-loglevel", "error", "-f", "rawvideo", "-pix_fmt", "rgb24", "-s", f"{w}x{h}",
                   "-r", f"{fps:g}", "-i", "-", "-an", "-vcodec", "libx264", "-pix_fmt", "yuv420p",
                   "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", tmp]
            p = subprocess.run(cmd, input=b"".join(np.ascontiguousarray(f).tobytes() for f in frames),
                               capture_output=True)
            if p.returncode != 0:
                raise RuntimeError(f"ffmpeg failed: {p.stderr.decode(errors='replace').strip()[-300:]}")
        else:
            raise ValueError(f"unsupported video extension {ext!r}")
        os.replace(tmp, path)
        tmp = None
    finally:
        if tmp is not None and os.path.exists(tmp):
            os.remove(tmp)


# ------------------------------------------------------------------------------------------------
# CLI
# ------------------------------------------------------------------------------------------------


def parse_args(argv):
    p = cli_parser.ArgumentParser(prog="python -m swim_jax.render", description=__doc__,
                                  formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("run_dir", metavar="RUN_DIR")
    p.add_argument("--seed", type=int, default=0, help="seed index of the run (default 0)")
    p.add_argument("--out", required=True, help="output video, .gif or .mp4")
    p.add_argument("--episode-key", type=int, default=0, help="PRNG key of the episode's reset noise")
    p.add_argument("--max-steps", type=int, default=None, help="stop after this many steps (default: time limit)")
    p.add_argument("--width", type=int, default=320)
    p.add_argument("--height", type=int, default=240)
    p.add_argument("--fps", type=float, default=30.0, help="approximate frame rate; states are subsampled to it "
                   "so the video plays in real time (default 30)")
    p.add_argument("--force", action="store_true", help="replace an existing --out file")
    a = p.parse_args(argv)
    if os.path.splitext(a.out)[1].lower() not in (".gif", ".mp4"):
        p.error(f"--out must end in .gif or .mp4, got {a.out!r}")
    if a.width < 16 or a.height < 16 or a.fps <= 0 or (a.max_steps is not None and a.max_steps < 1):
        p.error("--width/--height must be >= 16, --fps > 0, --max-steps >= 1")
    return a


def main(argv=None) -> int:
    """CLI entry point; returns the exit status (0 ok, 2 bad input, 3 skipped: no GL / no ffmpeg)."""
    args = parse_args(sys.argv[1:] if argv is None else list(argv))
    try:
        if not os.path.isdir(args.run_dir):
            raise RenderError(f"{args.run_dir}: not a directory")
        problem = cli_parser.output_file_problem("--out", args.out, args.force)
        if problem:
            raise RenderError(problem)
        if args.out.lower().endswith(".mp4") and ffmpeg_executable() is None:
            raise RenderSkipped("writing .mp4 needs ffmpeg (apt-get install ffmpeg, or pip install "
                                "imageio-ffmpeg); use a .gif --out instead")
        if "mujoco" not in sys.modules:
            gl = choose_gl_backend()
        else:
            gl = os.environ.get("MUJOCO_GL", "(already imported)")
        cfg, env, agent, params = load_policy(args.run_dir, args.seed)
        ret, qpos, qvel, steps = rollout(env, agent, params, key=args.episode_key, max_steps=args.max_steps)
        stride = max(1, round(1.0 / (float(env.dt) * args.fps)))
        try:
            frames = render_frames(env.mj_model, qpos, qvel, args.width, args.height, stride)
        except Exception as e:  # noqa: BLE001 - GL failures surface as assorted exception types
            raise RenderSkipped(f"offscreen rendering failed with MUJOCO_GL={gl} "
                                f"({' '.join(str(e).split())[:200]}); {GL_HELP}") from None
        write_video(args.out, frames, fps=1.0 / (stride * float(env.dt)))
    except RenderError as e:
        print(f"render: error: {e}", file=sys.stderr)
        return 2
    except RenderSkipped as e:
        print(f"render: skipped: {e}", file=sys.stderr)
        return 3
    print(f"{cfg.env.id} {cfg.agent.activation.name} seed {args.seed}: episode return {ret:.2f} over {steps} steps "
          f"(episode key {args.episode_key}); wrote {len(frames)} frames to {args.out} (MUJOCO_GL={gl})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
