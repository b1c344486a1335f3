"""Lanes as one group per host CPU device (swim_jax/lane_groups.py): the split, and a grouped run
against the same run as one program (float64; host devices must be requested before JAX starts, so
that check runs in a subprocess with XLA_FLAGS set)."""

from __future__ import annotations

import os
from types import SimpleNamespace

import numpy as np

from swim_jax import config as cfgmod
from swim_jax.lane_groups import plan
from swim_jax.programs import auto_host_devices
from tests.test_sharding import _python

DEVICES = [SimpleNamespace(platform="cpu", id=i) for i in range(4)]


def test_plan_splits_lanes_into_groups_and_rotating_leftovers():
    g = plan(5, DEVICES[:2])
    assert g.per_group == 2 and g.leftover == (4,) and g.lanes == 5
    assert g.parts() == [(0, 2), (2, 4), (4, 5)]
    assert [g.device_index(0, c) for c in range(4)] == [0, 0, 0, 0]  # a group stays on its device
    assert [g.device_index(1, c) for c in range(4)] == [1, 1, 1, 1]
    assert [g.device_index(2, c) for c in range(4)] == [0, 1, 0, 1]  # the leftover lane rotates
    assert g.describe() == "5 lanes as 2 groups of 2, one per cpu device, 1 more rotating over them"
    g = plan(7, DEVICES[:3])
    assert g.parts() == [(0, 2), (2, 4), (4, 6), (6, 7)]
    g = plan(6, DEVICES)  # two leftover lanes on different devices in every call
    assert g.parts()[-2:] == [(4, 5), (5, 6)]
    assert all(g.device_index(4, c) != g.device_index(5, c) for c in range(8))
    assert plan(3, DEVICES).devices == tuple(DEVICES[:3]) and plan(3, DEVICES).leftover == ()  # ≤ one device per lane
    assert plan(1, DEVICES) is None and plan(5, DEVICES[:1]) is None  # one program is all there is


def test_auto_host_devices_only_with_lane_groups(monkeypatch):
    monkeypatch.delenv("XLA_FLAGS", raising=False)
    cores = len(os.sched_getaffinity(0))
    on = cfgmod.resolve("hopper_relu", ["seeds=5", "lane_groups=true"])
    assert auto_host_devices(on) == (min(cores, 5) if cores >= 2 else 0)
    assert auto_host_devices(cfgmod.resolve("hopper_relu", ["seeds=5"])) == 0  # off by default
    assert auto_host_devices(cfgmod.resolve("hopper_relu", ["seeds=5", "lane_groups=true", "host_devices=3"])) == 0
    monkeypatch.setenv("XLA_FLAGS", "--xla_force_host_platform_device_count=2")  # the user's own count wins
    assert auto_host_devices(on) == 0


def test_grouped_training_equals_one_program(tmp_path):
    """3 lanes on 2 host devices (groups of 1, the third lane rotating) against one program, float64,
    native physics, two chunks of two calls: the same evaluations and final actors to float rounding;
    the executables (one per lane count and device) all compiled before the first call."""
    code = (
        "import json, jax, numpy as np\n"
        "from swim_jax import config as c, train\n"
        "tiny = ['seeds=3','total_steps=2000','eval_freq=1000','progress_steps=500','learning_starts=500',"
        "'eval_episodes=2','replay_size=4000','agent.hidden=[16,16]','agent.batch_size=32','env.backend=mujoco',"
        "'precision=float64']\n"
        "lines = []\n"
        f"b = train.run(c.resolve('hopper_relu', tiny + ['lane_groups=true']), {str(tmp_path / 'groups')!r}, log=lines.append)\n"
        f"a = train.run(c.resolve('hopper_relu', tiny), {str(tmp_path / 'one')!r}, log=lambda s: None)\n"
        "diff = max(float(np.max(np.abs(np.asarray(x) - np.asarray(y))))\n"
        "           for x, y in zip(jax.tree.leaves(a.final_actor), jax.tree.leaves(b.final_actor)))\n"
        "print(json.dumps({'a': a.evaluations.tolist(), 'b': b.evaluations.tolist(), 'lines': lines, 'diff': diff,\n"
        "  'timing': {k: b.timing[k] for k in ('devices', 'lane_groups', 'chunk_compiles')},\n"
        "  'one_devices': a.timing['devices']}))\n"
    )
    out = _python(code, devices=2, timeout=900)
    assert out["lines"][0] == "lanes: 3 lanes as 2 groups of 1, one per cpu device, 1 more rotating over them"
    assert out["timing"]["devices"] == 2 and out["one_devices"] == 1
    assert out["timing"]["chunk_compiles"] == 2  # 1 lane on each device, compiled up front; none later
    assert out["diff"] < 1e-9
    np.testing.assert_allclose(out["b"], out["a"], rtol=1e-9, atol=1e-9)
