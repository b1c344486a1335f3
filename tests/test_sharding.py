"""Lanes split over devices (swim_jax/placement/sharding.py). Host CPU devices must be requested before JAX
starts, so the multi-device checks run in subprocesses with XLA_FLAGS set."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from swim_jax.placement.sharding import lane_sharding, place, set_host_devices

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _python(code: str, devices: int, timeout: int = 1800) -> dict:
    env = dict(os.environ, XLA_FLAGS=f"--xla_force_host_platform_device_count={devices}", JAX_PLATFORMS="cpu")
    proc = subprocess.run([sys.executable, "-c", code], cwd=REPO, env=env, capture_output=True, text=True,
                          timeout=timeout)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_one_device_keeps_everything_in_place():
    sh, why = lane_sharding(4)
    assert sh is None and why == "one device"
    x = {"a": np.ones(3)}
    assert place(x, None) is x


def test_set_host_devices_replaces_an_existing_flag(monkeypatch):
    monkeypatch.setenv("XLA_FLAGS", "--xla_cpu_foo=1 --xla_force_host_platform_device_count=8")
    set_host_devices(2)
    assert os.environ["XLA_FLAGS"] == "--xla_cpu_foo=1 --xla_force_host_platform_device_count=2"


def test_lanes_split_over_two_host_devices():
    out = _python(
        "import json, jax, jax.numpy as jnp\n"
        "from swim_jax.placement.sharding import lane_sharding, place\n"
        "sh, why = lane_sharding(4)\n"
        "x = place({'w': jnp.arange(8.).reshape(4, 2)}, sh)['w']\n"
        "y = jax.jit(lambda v: v * 2)(x)\n"
        "none, why3 = lane_sharding(3)\n"
        "from swim_jax.placement.sharding import over_lanes\n"
        "blocks = jax.jit(over_lanes(lambda v, t: jnp.zeros(v.shape[0]) + v.shape[0] + t, sh, replicated=(1,)))(x, 10.)\n"
        "print(json.dumps({'why': why, 'shards': [list(s.data.shape) for s in x.addressable_shards],\n"
        "  'devices': sorted(str(s.device) for s in y.addressable_shards), 'y': y.tolist(), 'none3': none is None, 'why3': why3,\n"
        "  'blocks': blocks.tolist()}))\n",
        devices=2, timeout=300)
    assert out["why"] == "4 lanes over 2 cpu devices"
    assert out["shards"] == [[2, 2], [2, 2]] and len(set(out["devices"])) == 2
    assert out["y"] == [[0, 2], [4, 6], [8, 10], [12, 14]]
    assert out["none3"] and "do not divide over 2 devices" in out["why3"]
    assert out["blocks"] == [12, 12, 12, 12]  # over_lanes: each device sees its own 2 lanes; t passed whole


@pytest.mark.slow
def test_sharded_training_equals_one_device_training(tmp_path):
    """The same tiny 2-seed run, lanes on one device vs split over 2 host devices, in one process:
    the same evaluations (to float rounding) and one compiled chunk program per placement."""
    code = (
        "import json, numpy as np\n"
        "from swim_jax import config as c\nfrom swim_jax.run import train\n"
        "tiny = ['seeds=2','total_steps=2000','eval_freq=1000','learning_starts=1000','eval_episodes=2',"
        "'replay_size=4000','agent.hidden=[16,16]','agent.batch_size=32']\n"
        f"a = train.run(c.resolve('hopper_relu', tiny + ['shard_lanes=false']), {str(tmp_path / 'one')!r}, log=lambda s: None)\n"
        f"lines = []\n"
        f"b = train.run(c.resolve('hopper_relu', tiny + ['lane_groups=false']), {str(tmp_path / 'two')!r}, log=lines.append)\n"
        "print(json.dumps({'a': a.evaluations.tolist(), 'b': b.evaluations.tolist(), 'lines': lines,\n"
        "  'devices': b.timing['devices'], 'compiles': b.chunk_fn._cache_size()}))\n"
    )
    out = _python(code, devices=2)
    assert out["lines"][0] == "lanes: 2 lanes over 2 cpu devices" and out["devices"] == 2
    assert out["compiles"] == 1  # a program per placement, each compiled once (none after the first chunk)
    np.testing.assert_allclose(out["b"], out["a"], rtol=1e-3, atol=1e-3)
