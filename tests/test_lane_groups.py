"""Lanes as one group per host CPU device (swim_jax/placement/lane_groups.py): the split, and a grouped run
against the same run as one program (float64; host devices must be requested before JAX starts, so
that check runs in a subprocess with XLA_FLAGS set)."""

from __future__ import annotations

import os
from types import SimpleNamespace

import numpy as np
import pytest

from swim_jax import config as cfgmod
from swim_jax.placement.lane_groups import StepsError, plan
from swim_jax.run.programs import auto_host_devices
from tests.test_sharding import _python

DEVICES = [SimpleNamespace(platform="cpu", id=i) for i in range(4)]


def test_plan_splits_lanes_into_groups_and_leftover_pieces():
    g = plan(5, DEVICES[:2], 1000)
    assert g.per_group == 2 and g.leftover == (4,) and g.lanes == 5
    assert g.parts() == [(0, 2), (2, 4), (4, 5)]
    assert g.piece_devices(0) == [0, 1]  # the leftover lane: half a call on each device
    assert g.describe() == "5 lanes as 2 groups of 2, one per cpu device, 1 more in 2 pieces per call over them"
    g = plan(7, DEVICES[:3], 999)
    assert g.parts() == [(0, 2), (2, 4), (4, 6), (6, 7)]
    g = plan(7, DEVICES, 1000)  # three leftover lanes, each starting on its own device
    assert g.per_group == 1 and g.parts()[-3:] == [(4, 5), (5, 6), (6, 7)]
    assert [g.piece_devices(j) for j in range(3)] == [[0, 1, 2, 3], [1, 2, 3, 0], [2, 3, 0, 1]]
    # every device carries the same share of the pieces
    assert sorted(d for j in range(3) for d in g.piece_devices(j)) == sorted([0, 1, 2, 3] * 3)
    assert plan(3, DEVICES, 1).devices == tuple(DEVICES[:3]) and plan(3, DEVICES, 1).leftover == ()  # ≤ one device per lane
    assert plan(4, DEVICES[:2], 7).leftover == ()  # no pieces: any steps per call
    assert plan(1, DEVICES, 10) is None and plan(5, DEVICES[:1], 10) is None  # one program is all there is
    with pytest.raises(StepsError, match="999 steps per call is not a multiple of 2"):
        plan(5, DEVICES[:2], 999)


def test_auto_host_devices_only_with_lane_groups(monkeypatch):
    monkeypatch.delenv("XLA_FLAGS", raising=False)
    cores = len(os.sched_getaffinity(0))
    on = cfgmod.resolve("hopper_relu", ["seeds=5", "lane_groups=true"])
    assert auto_host_devices(on) == (min(cores, 5) if cores >= 2 else 0)
    assert auto_host_devices(cfgmod.resolve("hopper_relu", ["seeds=5"])) == auto_host_devices(on)  # on by default
    assert auto_host_devices(cfgmod.resolve("hopper_relu", ["seeds=5", "lane_groups=false"])) == 0
    assert auto_host_devices(cfgmod.resolve("hopper_relu", ["seeds=1", "lane_groups=true"])) == 0  # one real lane
    assert auto_host_devices(cfgmod.resolve("hopper_relu", ["seeds=5", "lane_groups=true", "host_devices=3"])) == 0
    monkeypatch.setenv("XLA_FLAGS", "--xla_force_host_platform_device_count=2")  # the user's own count wins
    assert auto_host_devices(on) == 0


def test_grouped_training_equals_one_program(tmp_path):
    """3 lanes on 2 host devices (groups of 1, the third lane in two half-call pieces, one per device)
    against one program, float64, native physics, two chunks of two calls: the same evaluations,
    learning metrics (metrics.csv: the pieces' merged) and final actors to float rounding; the
    executables (each group's and the piece program on each device) all made before the first
    call, device 1's as copies of device 0's; resumed from a checkpoint (device 0's executables now
    read from the persistent cache, so device 1's are read too, not copied), the same run bit for
    bit; and when there are no groups although asked for, why."""
    code = (
        "import json, jax, numpy as np\n"
        "from swim_jax import config as c\nfrom swim_jax.run import train\n"
        # a cache of its own: the first run compiles (and copies), the resumed one reads the cache
        f"jax.config.update('jax_compilation_cache_dir', {str(tmp_path / 'xla-cache')!r})\n"
        "jax.config.update('jax_persistent_cache_min_compile_time_secs', 0.0)\n"
        "tiny = ['seeds=3','total_steps=2000','eval_freq=1000','progress_steps=500','learning_starts=500',"
        "'eval_episodes=2','replay_size=4000','agent.hidden=[16,16]','agent.batch_size=32','env.backend=mujoco',"
        "'precision=float64']\n"
        "lines = []\n"
        f"b = train.run(c.resolve('hopper_relu', tiny + ['lane_groups=true']), {str(tmp_path / 'groups')!r}, log=lines.append)\n"
        f"a = train.run(c.resolve('hopper_relu', tiny + ['lane_groups=false']), {str(tmp_path / 'one')!r}, log=lambda s: None)\n"
        "diff = max(float(np.max(np.abs(np.asarray(x) - np.asarray(y))))\n"
        "           for x, y in zip(jax.tree.leaves(a.final_actor), jax.tree.leaves(b.final_actor)))\n"
        "import shutil\n"
        f"shutil.copytree({str(tmp_path / 'groups')!r}, {str(tmp_path / 'resumed')!r})\n"
        f"shutil.rmtree({str(tmp_path / 'resumed' / 'checkpoints' / '2000')!r})\n"
        "jax.clear_caches()  # compiled again, so from the persistent cache, as a new process would\n"
        f"r = train.run(c.resolve('hopper_relu', tiny + ['lane_groups=true']), {str(tmp_path / 'resumed')!r}, resume=True, log=lambda s: None)\n"
        "resumed = max(float(np.max(np.abs(np.asarray(x) - np.asarray(y))))\n"
        "              for x, y in zip(jax.tree.leaves(r.final_actor), jax.tree.leaves(b.final_actor)))\n"
        "from swim_jax.run.programs import groups_for\n"
        "odd = groups_for(c.resolve('hopper_relu', tiny + ['progress_steps=125']), 3)\n"
        "one_seed = groups_for(c.resolve('hopper_relu', tiny + ['seeds=1']), 2)\n"
        "off = groups_for(c.resolve('hopper_relu', tiny + ['lane_groups=false']), 3)\n"
        "print(json.dumps({'a': a.evaluations.tolist(), 'b': b.evaluations.tolist(), 'lines': lines, 'diff': diff,\n"
        "  'resumed': resumed, 'r': r.evaluations.tolist(), 'r_copied': r.timing['chunk_executables_copied'],\n"
        "  'timing': {k: b.timing[k] for k in ('devices', 'lane_groups', 'chunk_compiles', 'chunk_executables_copied')},\n"
        "  'odd': [odd[0] is None, odd[1]], 'one_seed': [one_seed[0] is None, one_seed[1]], 'off': [off[0] is None, off[1]],\n"
        "  'one_devices': a.timing['devices']}))\n"
    )
    out = _python(code, devices=2, timeout=900)
    assert out["lines"][0] == "lanes: 3 lanes as 2 groups of 1, one per cpu device, 1 more in 2 pieces per call over them"
    assert out["timing"]["devices"] == 2 and out["one_devices"] == 1
    assert out["timing"]["chunk_compiles"] == 4  # group and piece program on each device, up front; none later
    assert out["timing"]["chunk_executables_copied"] == 2  # device 1's two compiled once, for device 0, and copied
    assert out["diff"] < 1e-9
    np.testing.assert_allclose(out["b"], out["a"], rtol=1e-9, atol=1e-9)
    # resumed from the step-1000 checkpoint (split again from the whole state): the same run exactly
    assert out["resumed"] == 0.0 and out["r"] == out["b"]
    assert out["r_copied"] == 0  # device 0's executables came from the persistent cache: read, not copied
    one, groups = (np.genfromtxt(tmp_path / run / "metrics.csv", delimiter=",", names=True) for run in ("one", "groups"))
    assert len(one) == 6 and one.dtype.names == groups.dtype.names
    assert one["updates"].sum() == 3 * 1500  # every lane updates from step 500 on, in both runs
    for name in one.dtype.names:  # counts exact; losses, Q and returns to float rounding (nan where none)
        np.testing.assert_allclose(groups[name], one[name], rtol=1e-9, atol=1e-9, err_msg=name)
    # no groups, and why: steps per call that cannot be halved; a padded single seed; none asked for
    assert out["odd"][0] and "125 steps per call is not a multiple of 2" in out["odd"][1] and "progress_steps" in out["odd"][1]
    assert out["one_seed"] == [True, ""]
    assert out["off"] == [True, ""]


def test_an_executable_copied_to_another_device_compiles_nothing_and_computes_the_same():
    """swim_jax/placement/executable_copies.py: a program (a pytree in, its first argument donated)
    compiled for device 0 and copied to device 1: no backend compile during the copy, results on
    device 1 equal bit for bit to the same program compiled for device 1 the usual way, the donated
    argument consumed, arguments on device 0 refused; a program with a host callback cannot be
    copied (None)."""
    out = _python(
        "import json, jax, jax.numpy as jnp, numpy as np\n"
        "jax.config.update('jax_enable_x64', True)\n"
        "from jax import monitoring\n"
        "from swim_jax.placement.executable_copies import copy_to_device\n"
        "compiles = []\n"
        "monitoring.register_event_duration_secs_listener(\n"
        "    lambda name, secs, **kw: compiles.append(name) if name.endswith('backend_compile_duration') else None)\n"
        "d0, d1 = jax.devices()\n"
        "def f(state, t):\n"
        "    x = state['x']\n"
        "    for _ in range(3):\n"
        "        x = jnp.tanh(x @ x.T * t) + state['b']\n"
        "    return {'x': x, 'b': state['b'] + 1}, jnp.sum(x)\n"
        "spec = lambda tree, d: jax.tree.map(lambda a: jax.ShapeDtypeStruct(a.shape, a.dtype,\n"
        "    sharding=jax.sharding.SingleDeviceSharding(d)), tree)\n"
        "rng = np.random.default_rng(0)\n"
        "state = {'x': rng.standard_normal((16, 16)), 'b': rng.standard_normal(16)}\n"
        "t = np.float64(0.3)\n"
        "fn = jax.jit(f, donate_argnums=0)\n"
        "c0 = fn.lower(spec(state, d0), spec(t, d0)).compile()\n"
        "before = len(compiles)\n"
        "c1 = copy_to_device(c0, d1)\n"
        "copy_compiles = len(compiles) - before\n"
        "ref = jax.jit(f).lower(spec(state, d1), spec(t, d1)).compile()(jax.device_put(state, d1), jax.device_put(t, d1))\n"
        "arg = jax.device_put(state, d1)\n"
        "got = c1(arg, jax.device_put(t, d1))\n"
        "try:\n"
        "    c1(jax.device_put(state, d0), jax.device_put(t, d0)); refused = False\n"
        "except ValueError:\n"
        "    refused = True\n"
        "cb = jax.jit(lambda x: jax.pure_callback(np.sin, jax.ShapeDtypeStruct(x.shape, x.dtype), x))\n"
        "print(json.dumps({'copy_compiles': copy_compiles, 'counted': before > 0,\n"
        "  'equal': all(np.array_equal(np.asarray(a), np.asarray(b)) for a, b in zip(jax.tree.leaves(got), jax.tree.leaves(ref))),\n"
        "  'devices': sorted({str(d) for leaf in jax.tree.leaves(got) for d in leaf.devices()}),\n"
        "  'donated': all(leaf.is_deleted() for leaf in jax.tree.leaves(arg)), 'refused': refused,\n"
        "  'callback': copy_to_device(cb.lower(spec(np.ones(3), d0)).compile(), d1) is None}))\n",
        devices=2, timeout=300)
    assert out["counted"] and out["copy_compiles"] == 0  # the listener saw c0's compile, none for the copy
    assert out["equal"] and out["devices"] == ["cpu:1"]
    assert out["donated"] and out["refused"] and out["callback"]
