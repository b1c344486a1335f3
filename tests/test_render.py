"""python -m swim_jax.render: argument and run-folder errors (fast), video writing, GL skip, frames
drawn offscreen; one slow end-to-end episode with a freshly initialised policy."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest
import yaml

from swim_jax.run import render

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _run_folder(tmp_path, seeds=2, first_seed=0, policy=True):
    d = tmp_path / "run"
    d.mkdir()
    cfg = {"env": {"id": "Hopper-v5"}, "agent": {"hidden": [8, 8], "activation": {"name": "swim"}},
           "seeds": seeds, "first_seed": first_seed, "total_steps": 2000, "eval_freq": 1000,
           "learning_starts": 100, "replay_size": 1000}
    (d / "config.yaml").write_text(yaml.safe_dump(cfg))
    if policy:
        np.savez(d / "final_policy.npz", **{"params/body/head/bias": np.zeros((seeds, 3), np.float32)})
    return d


def _main(args, capsys):
    rc = render.main([str(a) for a in args])
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


def test_unflatten_restores_the_nested_layout():
    flat = {"params/body/dense_0/kernel": 1, "params/body/dense_0/bias": 2, "params/body/head/bias": 3}
    assert render.unflatten(flat) == {"params": {"body": {"dense_0": {"kernel": 1, "bias": 2}, "head": {"bias": 3}}}}


@pytest.mark.parametrize("case", ["no_dir", "no_policy", "seed_out_of_range", "bad_ext", "exists"])
def test_bad_input_exit_2_one_line_nothing_written(tmp_path, capsys, monkeypatch, case):
    monkeypatch.setattr(render, "choose_gl_backend", lambda: "egl")  # keep the test free of GL probes
    out = tmp_path / "ep.gif"
    run = _run_folder(tmp_path, policy=(case != "no_policy"), first_seed=3)
    args = [run, "--seed", "3", "--out", out]
    if case == "no_dir":
        args[0] = tmp_path / "missing"
    elif case == "seed_out_of_range":
        args[2] = "5"  # seeds are 3..4
    elif case == "bad_ext":
        args[-1] = tmp_path / "ep.avi"
    elif case == "exists":
        out.write_bytes(b"keep")
    if case == "bad_ext":
        with pytest.raises(SystemExit) as e:
            render.main([str(a) for a in args])
        assert e.value.code == 2
        err = capsys.readouterr().err
    else:
        rc, _, err = _main(args, capsys)
        assert rc == 2
    assert len(err.strip().splitlines()) == 1, err
    expected = {"no_dir": "not a directory", "no_policy": "missing final_policy.npz",
                "seed_out_of_range": "seeds are 3..4", "bad_ext": ".gif or .mp4", "exists": "--force"}[case]
    assert expected in err
    if case == "exists":
        assert out.read_bytes() == b"keep"
    else:
        assert not out.exists()
    assert not [p for p in os.listdir(tmp_path) if p.startswith(".render-")]


def test_mp4_without_ffmpeg_is_skipped_with_exit_3(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(render, "ffmpeg_executable", lambda: None)
    rc, _, err = _main([_run_folder(tmp_path), "--out", tmp_path / "ep.mp4"], capsys)
    assert rc == 3 and err.startswith("render: skipped:") and "ffmpeg" in err and ".gif" in err
    assert not (tmp_path / "ep.mp4").exists()


def test_no_gl_backend_is_skipped_with_a_clear_message(monkeypatch):
    monkeypatch.setenv("MUJOCO_GL", "no-such-backend")
    with pytest.raises(render.RenderSkipped) as e:
        render.choose_gl_backend()
    msg = str(e.value)
    assert "\n" not in msg and "no offscreen OpenGL backend" in msg and "libegl1" in msg and "libosmesa6" in msg


FRAMES_SCRIPT = r"""
import json, sys
import numpy as np
from swim_jax.run import render
try:
    gl = render.choose_gl_backend()
except render.RenderSkipped as e:
    print(json.dumps({"skip": str(e)})); sys.exit(0)
from swim_jax import envs
model = envs.make("Hopper-v5").mj_model
qpos = np.stack([np.array(model.qpos0)] * 2)
qpos[1, 2] = 0.3
f = np.stack(render.render_frames(model, qpos, np.zeros((2, model.nv)), width=80, height=64))
print(json.dumps({"shape": list(f.shape), "dtype": str(f.dtype), "std": float(f.std()),
                  "differ": bool((f[0] != f[1]).any()), "gl": gl}))
"""


def test_render_frames_draws_each_pose_or_skips():
    """render_frames after choose_gl_backend, in a fresh process (MuJoCo reads MUJOCO_GL when it is
    imported): one 64×80 RGB frame per state, not blank, changed by the pose; skips with the GL
    advice where no backend works. A failure after a working backend was found is an error."""
    p = subprocess.run([sys.executable, "-c", FRAMES_SCRIPT], cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr[-2000:]
    res = json.loads(p.stdout.strip().splitlines()[-1])
    if "skip" in res:
        pytest.skip(res["skip"])
    assert res["shape"] == [2, 64, 80, 3] and res["dtype"] == "uint8", res
    assert res["std"] > 0 and res["differ"], res  # a picture, and the pose changes it


def test_write_gif(tmp_path):
    from PIL import Image

    frames = [np.full((24, 32, 3), i * 40, np.uint8) for i in range(5)]
    path = tmp_path / "a.gif"
    render.write_video(str(path), frames, fps=25)
    im = Image.open(path)
    assert im.n_frames == 5 and im.size == (32, 24) and im.info["duration"] == 40
    im.seek(3)
    assert np.asarray(im.convert("RGB"))[0, 0, 0] == 120
    assert os.listdir(tmp_path) == ["a.gif"]


@pytest.mark.slow
def test_end_to_end_episode_of_an_initialised_policy(tmp_path):
    """Build a run folder with an untrained actor, render 12 steps (skips where no GL backend)."""
    import jax

    from swim_jax import config as cfgmod
    from swim_jax.run.programs import build

    cfg = cfgmod.resolve(None, ["env.id=Hopper-v5", "agent.hidden=[8,8]", "agent.activation.name=swim",
                                "seeds=1", "total_steps=2000", "eval_freq=1000", "learning_starts=100",
                                "replay_size=1000"])
    env, _, agent = build(cfg)
    actor = agent.init(jax.random.key(0)).actor
    flat = {"/".join(str(getattr(k, "key", k)) for k in kp): np.asarray(v)[None]
            for kp, v in jax.tree_util.tree_flatten_with_path(actor)[0]}
    run = tmp_path / "run"
    run.mkdir()
    (run / "config.yaml").write_text(cfgmod.dump(cfg))
    np.savez(run / "final_policy.npz", **flat)
    out = tmp_path / "ep.gif"
    p = subprocess.run([sys.executable, "-m", "swim_jax.render", str(run), "--seed", "0", "--out", str(out),
                        "--max-steps", "12", "--fps", "125"], cwd=ROOT, capture_output=True, text=True, timeout=600)
    if p.returncode == 3:
        pytest.skip(p.stderr.strip())
    assert p.returncode == 0, p.stderr
    assert "episode return" in p.stdout
    # reference: the same episode stepped here
    ret, qpos, _, steps = render.rollout(env, agent, jax.tree_util.tree_map(np.asarray, actor), key=0, max_steps=12)
    assert f"episode return {ret:.2f} over {steps} steps" in p.stdout
    from PIL import Image

    im = Image.open(out)
    assert im.n_frames == steps + 1 and im.size == (320, 240)
    assert np.asarray(im.convert("RGB")).std() > 5  # not a blank frame
