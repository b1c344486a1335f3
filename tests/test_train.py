"""The training program end to end on a tiny Hopper-v5 config (real envs, real TD3, small nets).

Compiles are the cost here, so one vmapped 2-seed run (module fixture, with TensorBoard output)
serves several tests; a single-seed run checks seed independence (same executable, no compile);
the resume test (slow) runs the CLI in subprocesses that share a persistent compilation cache.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import struct
import subprocess
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from tensorboardX.crc32c import crc32c
from tensorboardX.proto.event_pb2 import Event, SessionLog

from swim_jax.agents import loop
from swim_jax import config as cfgmod
from swim_jax.io import learning_log, provenance, tensorboard_log
from swim_jax.analysis import report
from swim_jax.run import train
from swim_jax.run.programs import lanes, matmul_dtype, programs, with_physics_backend

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TINY = [
    "seeds=2",
    "total_steps=4000",
    "eval_freq=1000",
    "learning_starts=1000",
    "eval_episodes=5",
    "replay_size=10000",
    "agent.hidden=[64,64]",
    "agent.batch_size=64",
    # env.backend=auto, the default: MuJoCo C physics on a CPU (bit for bit Gymnasium's,
    # tests/test_envs_native.py), whose program compiles in seconds; the MJX backend's training
    # program is exercised end to end by tests/test_sweep.py (env.backend=mjx)
]
CONFIG = "hopper_relu"
VMAPPED = ("tensorboard=true",)  # the module fixture's run also writes TensorBoard event files


def tiny(*extra: str) -> cfgmod.Config:
    return cfgmod.resolve(CONFIG, TINY + list(extra))


class CompileCounter:
    """Counts XLA backend compilations (jax.monitoring events) while ``active``."""

    def __init__(self):
        self.active = False
        self.events: list[str] = []
        jax.monitoring.register_event_duration_secs_listener(self._on_event)

    def _on_event(self, event: str, duration: float, **kwargs) -> None:
        if self.active and event == "/jax/core/compile/backend_compile_duration":
            self.events.append(event)


@pytest.fixture(scope="module")
def vmapped(tmp_path_factory):
    """2 seeds, 4 chunks; compile events counted from the end of the first chunk on."""
    counter = CompileCounter()
    lines: list[str] = []

    def log(line: str) -> None:
        lines.append(line)
        counter.active = True  # first chunk (and its evaluation + checkpoint) done

    t0 = time.time()
    res = train.run(tiny(*VMAPPED), str(tmp_path_factory.mktemp("vmapped") / "run"), log=log)
    counter.active = False
    res.wall = time.time() - t0
    res.lines = lines
    res.late_compiles = list(counter.events)
    return res


def test_outputs_and_progress_lines(vmapped):
    d = vmapped.run_dir
    for f in ["config.yaml", "evaluations.csv", "evaluations.npy", "evaluations_episodes.npy",
              "evaluations_seed0.npy", "evaluations_seed1.npy", "timing.json", "final_policy.npz"]:
        assert os.path.isfile(os.path.join(d, f)), f
    ev = np.load(os.path.join(d, "evaluations.npy"))
    assert ev.shape == (5, 2) and np.all(np.isfinite(ev))  # step 0 + one per chunk
    np.testing.assert_array_equal(ev, vmapped.evaluations.mean(axis=2))
    np.testing.assert_array_equal(np.load(os.path.join(d, "evaluations_seed1.npy")), ev[:, 1])
    csv = open(os.path.join(d, "evaluations.csv")).read().splitlines()
    assert csv[0] == "step,seed_0,seed_1,mean,std" and csv[-1].startswith("4000,")
    assert len(vmapped.lines) == 4 and all("env-steps/s" in l and "ETA" in l and "±" in l for l in vmapped.lines)
    # float32 products by default on every CPU (this one's bfloat16 instructions included): timing.json
    # and provenance.json say so, and no progress line says bf16
    assert vmapped.timing["matmul_dtype"] == "float32"
    assert provenance.recorded_matmul_dtypes(d) == ["float32"]
    assert not any("bf16 matmuls" in line for line in vmapped.lines)
    # keep_checkpoints=3 of the 4 chunk checkpoints
    assert sorted(os.listdir(os.path.join(d, "checkpoints"))) == ["2000", "3000", "4000", "replay"]
    # env.backend=auto chose MuJoCo C on this CPU and config.yaml records the choice, so a resumed
    # run keeps its physics wherever it resumes; the resolved config round-trips
    assert tiny().env.backend == "auto"
    assert train.parse_args(["--resume", d])[0] == with_physics_backend(tiny(*VMAPPED))
    assert train.parse_args(["--resume", d])[0].env.backend == "mujoco"


def test_no_recompilation_after_first_chunk(vmapped):
    assert vmapped.late_compiles == []
    assert vmapped.chunk_fn._cache_size() == 1
    assert vmapped.eval_fn._cache_size() == 1
    assert vmapped.timing["chunk_compiles"] == 1


def test_evaluation_0_is_the_initial_policies_evaluated_on_their_own(vmapped):
    """Evaluation 0 of the run equals the initial actors (``init_fn`` of the run's lanes) evaluated
    on their own, bit for bit, by the run's own compiled evaluation program (nothing compiled)."""
    cfg = with_physics_backend(tiny(*VMAPPED))
    prog = programs(cfg)
    ln = lanes(cfg, prog, None)
    with jax.default_matmul_precision(cfg.matmul_precision):  # as train.run traces its programs
        init = prog.init_fn(*ln.init_args)
        alone = np.asarray(prog.eval_fn(init.agent.actor, init.eval_key, jnp.asarray(0, jnp.int32)))
    np.testing.assert_array_equal(vmapped.evaluations[0], alone)
    assert prog.eval_fn is vmapped.eval_fn and vmapped.eval_fn._cache_size() == 1


def test_a_chunk_split_into_calls_with_progress_lines_changes_nothing(vmapped, tmp_path, monkeypatch):
    """progress_steps=500 runs each 1000-step chunk as two calls of the compiled program with a
    progress line between them: the same evaluations, bit for bit, as one call per chunk."""
    monkeypatch.setattr(train, "PROGRESS_EVERY_S", 0.0)
    status: list[str] = []
    res = train.run(tiny("progress_steps=500"), str(tmp_path / "run"), log=lambda s: None, status=status.append)
    np.testing.assert_array_equal(res.evaluations, vmapped.evaluations)
    progress = [l for l in status if "env-steps/s in this chunk" in l]
    assert [l.split("] ", 1)[1].split(":")[0] for l in progress] == [f"step {s}/4000" for s in (500, 1500, 2500, 3500)]
    assert any("compiling the training program" in l for l in status)
    assert res.chunk_fn._cache_size() == 1


def test_metrics_csv_logs_updates_losses_and_episodes_per_chunk_and_seed(vmapped):
    """metrics.csv: 4 chunks × 2 seeds; no update in the warm-up chunk (learning_starts=1000),
    then 1000 updates and 500 actor updates (policy_freq 2) per chunk with finite losses; the last
    row's episode count and return are the final training state's; the progress line shows them."""
    m = learning_log.read(os.path.join(vmapped.run_dir, learning_log.FILENAME))
    np.testing.assert_array_equal(m["step"], np.repeat([1000, 2000, 3000, 4000], 2))
    np.testing.assert_array_equal(m["seed"], np.tile([0, 1], 4))
    np.testing.assert_array_equal(m["updates"], [0, 0] + [1000] * 6)
    np.testing.assert_array_equal(m["actor_updates"], [0, 0] + [500] * 6)
    assert np.all(np.isnan(m["critic_loss"][:2])) and np.all(np.isfinite(m["critic_loss"][2:]))
    assert np.all(m["critic_loss"][2:] >= 0) and np.all(np.isfinite(m["actor_loss"][2:]))
    np.testing.assert_array_equal(m["episodes"][-2:], np.asarray(vmapped.states.episodes))
    np.testing.assert_array_equal(m["last_episode_return"][-2:],
                                  np.asarray(vmapped.states.last_return).astype(np.float64))
    assert "critic loss" not in vmapped.lines[0] and "critic loss" in vmapped.lines[1]


def _masked_crc(data: bytes) -> int:
    """TFRecord's masked CRC-32C of ``data``."""
    crc = crc32c(data)
    return (((crc >> 15) | (crc << 17)) + 0xA282EAD8) & 0xFFFFFFFF


def read_events(folder, purge: bool = True) -> dict[str, list[tuple[int, float]]]:
    """``{tag: [(step, value), ...]}`` of the scalar events of every event file in ``folder`` (file
    name order), parsed as TFRecords with both CRCs checked, and with TensorBoard's purge rule
    (unless not ``purge``): a SessionLog START at step T drops the values read so far at steps >= T."""
    out: dict[str, list[tuple[int, float]]] = {}
    for name in sorted(os.listdir(folder)):
        data = open(os.path.join(folder, name), "rb").read()
        pos = 0
        while pos < len(data):
            header = data[pos:pos + 8]
            (n,) = struct.unpack("<Q", header)
            body = data[pos + 12:pos + 12 + n]
            assert struct.unpack("<I", data[pos + 8:pos + 12])[0] == _masked_crc(header)
            assert struct.unpack("<I", data[pos + 12 + n:pos + 16 + n])[0] == _masked_crc(body)
            pos += 16 + n
            event = Event.FromString(body)
            if purge and event.HasField("session_log") and event.session_log.status == SessionLog.START:
                out = {tag: [(st, v) for st, v in series if st < event.step] for tag, series in out.items()}
            for value in event.summary.value:
                out.setdefault(value.tag, []).append((event.step, value.simple_value))
    return out


def _expected_events(run_dir: str, seed_pos: int, seed: int) -> dict[str, list[tuple[int, float]]]:
    """What the event files of ``seed`` must hold, from metrics.csv and evaluations.npy (float32:
    TensorBoard's scalar format; nan cells left out)."""
    m = learning_log.read(os.path.join(run_dir, learning_log.FILENAME))
    mine = m["seed"] == seed
    want = {tensorboard_log.train_tag(c): [(int(st), float(np.float32(v))) for st, v in zip(m["step"][mine], m[c][mine])
                                           if np.isfinite(v)]
            for c in tensorboard_log.TRAIN_COLUMNS}
    ev = np.load(os.path.join(run_dir, "evaluations.npy"))[:, seed_pos]
    eval_freq = int(m["step"][0])
    want[tensorboard_log.EVAL_TAG] = [(j * eval_freq, float(np.float32(v))) for j, v in enumerate(ev)]
    return {tag: series for tag, series in want.items() if series}


def test_tensorboard_events_equal_metrics_csv_and_evaluations(vmapped):
    """tensorboard=true: one folder of event files per seed whose scalars are metrics.csv's columns
    and the evaluation returns, value for value (as float32), at the same steps."""
    d = vmapped.run_dir
    assert sorted(os.listdir(os.path.join(d, "tensorboard"))) == ["seed_0", "seed_1"]
    for pos, seed in enumerate((0, 1)):
        folder = tensorboard_log.seed_folder(d, seed)
        assert len(os.listdir(folder)) == 1
        got, want = read_events(folder), _expected_events(d, pos, seed)
        assert got == want
        assert got["train/critic_loss"][0][0] == 2000 and len(got["train/updates"]) == 4  # none before learning_starts
        assert [st for st, _ in got["eval/return"]] == [0, 1000, 2000, 3000, 4000]


def test_tensorboard_events_of_a_resumed_run_hide_those_after_its_checkpoint(vmapped, tmp_path):
    """Killed after logging chunk 4 but before its checkpoint (checkpoint 4000 removed), then
    resumed: a second event file per seed starts with a purge marker, so TensorBoard reads each
    step once and the values equal the rewritten metrics.csv (the same executable: no compile)."""
    d = str(tmp_path / "run")
    shutil.copytree(vmapped.run_dir, d)
    shutil.rmtree(os.path.join(d, "checkpoints", "4000"))
    res = train.run(tiny(*VMAPPED), d, resume=True, log=lambda s: None)
    assert res.chunk_fn is vmapped.chunk_fn and res.chunk_fn._cache_size() == 1
    m = learning_log.read(os.path.join(d, learning_log.FILENAME))
    np.testing.assert_array_equal(m["step"], np.repeat([1000, 2000, 3000, 4000], 2))
    for pos, seed in enumerate((0, 1)):
        folder = tensorboard_log.seed_folder(d, seed)
        assert len(os.listdir(folder)) == 2
        assert read_events(folder) == _expected_events(d, pos, seed)
        raw = [st for st, _ in read_events(folder, purge=False)["eval/return"]]
        assert raw == [0, 1000, 2000, 3000, 4000, 4000]  # the purge marker is what hides the first 4000


def test_tensorboard_without_tensorboardx_one_line_exit_2_nothing_written(tmp_path):
    """tensorboard=true in a Python where tensorboardX cannot be imported (None in sys.modules makes
    every import of it fail): one error line naming the package and the install command, exit
    status 2, no run folder."""
    code = ("import sys; sys.modules['tensorboardX'] = None\n"
            "from swim_jax import train\nsys.exit(train.main(sys.argv[1:]))")
    p = subprocess.run([sys.executable, "-c", code, "config=hopper_relu", "tensorboard=true",
                        f"out_dir={tmp_path}/out"], cwd=REPO, capture_output=True, text=True, timeout=300)
    assert p.returncode == 2, p.stderr
    errors = [line for line in p.stderr.splitlines() if line.startswith("error: ")]
    assert len(errors) == 1 and errors[0] == p.stderr.strip().splitlines()[-1], p.stderr
    assert "tensorboard=true needs the optional package tensorboardX" in errors[0]
    assert "pip install -c requirements.lock -e '.[tensorboard]'" in errors[0]
    assert p.stdout == "" and not os.path.exists(tmp_path / "out")


def test_report_plots_the_runs_learning_metrics(vmapped, tmp_path, capsys):
    """python -m swim_jax.report on the trained run: learning.png/.svg, and results.json's learning
    metrics are metrics.csv's per-chunk means over the seeds (no point before the first update)."""
    out = tmp_path / "report"
    assert report.main([vmapped.run_dir, "--out", str(out), "--n-boot", "200"]) == 0, capsys.readouterr().err
    assert (out / "learning.png").read_bytes().startswith(b"\x89PNG") and (out / "learning.svg").is_file()
    rows = json.loads((out / "results.json").read_text())["envs"]["Hopper-v5"]["learning_metrics"]["relu"]
    m = learning_log.read(os.path.join(vmapped.run_dir, learning_log.FILENAME))
    assert rows["steps"] == [1000, 2000, 3000, 4000] and rows["seeds"] == 2
    for metric in ("critic_loss", "actor_loss", "q_mean"):
        v = m[metric].reshape(4, 2)  # rows: chunk, then seed
        assert rows[metric]["mean"][0] is None  # warm-up chunk: no update
        assert rows[metric]["mean"][1:] == pytest.approx(v[1:].mean(axis=1).tolist(), rel=1e-12)
        assert rows[metric]["min"][1:] == v[1:].min(axis=1).tolist()
    assert "![Learning metrics](learning.png)" in (out / "REPORT.md").read_text()


def test_chunk_metrics_are_count_weighted_means():
    """loop.summarize_updates and learning_log.combine against NumPy on synthetic metrics."""
    from swim_jax.agents.loop import summarize_updates
    from swim_jax.agents.td3 import UpdateMetrics

    rng = np.random.default_rng(0)
    T, L = 6, 3
    cl, al, q = (rng.normal(size=(T, L)).astype(np.float32) for _ in range(3))
    actor = rng.random((T, L)) < 0.5
    updated = np.array([False, False, True, True, True, True])
    c = summarize_updates(UpdateMetrics(jnp.asarray(cl), jnp.asarray(al), jnp.asarray(q), jnp.asarray(actor)),
                          jnp.asarray(updated))
    w = np.broadcast_to(updated[:, None], (T, L))
    np.testing.assert_allclose(np.asarray(c.critic_loss), (cl * w).sum(0) / w.sum(0), rtol=1e-6)
    aw = w & actor
    want_al = np.where(aw.sum(0) > 0, (al * aw).sum(0) / np.maximum(aw.sum(0), 1), np.nan)
    np.testing.assert_allclose(np.asarray(c.actor_loss), want_al, rtol=1e-6)
    np.testing.assert_array_equal(np.asarray(c.actor_updates), aw.sum(0))
    # two calls of 3 steps combine into the 6-step means
    halves = [summarize_updates(UpdateMetrics(*(jnp.asarray(x[sl]) for x in (cl, al, q, actor))), jnp.asarray(updated[sl]))
              for sl in (slice(0, 3), slice(3, 6))]
    both = learning_log.combine(halves)
    np.testing.assert_allclose(both["critic_loss"], np.asarray(c.critic_loss), rtol=1e-6)
    np.testing.assert_allclose(both["actor_loss"], want_al, rtol=1e-6)
    np.testing.assert_array_equal(both["updates"], w.sum(0))


def uniform_random_returns(cfg, eval_keys, eval_index):
    """Returns ``[seeds, eval_episodes]`` of U(low, high) actions from the episodes the run's
    evaluation ``eval_index`` starts (the same reset keys), built from swim_jax/agents/loop.py's pieces."""
    prog = programs(cfg)

    def run(eval_keys, eval_index):
        keys = loop.eval_reset_keys(eval_keys, eval_index, cfg.eval_episodes)
        act_keys = jax.vmap(jax.vmap(lambda k: jax.random.fold_in(k, 1)))(keys)

        def policy(obs, t):
            return jax.vmap(jax.vmap(lambda k: prog.agent.random_action(jax.random.fold_in(k, t))))(act_keys)

        return loop.episode_returns(prog.eval_env, keys, policy, cfg.env.max_episode_steps)

    return np.asarray(jax.jit(run)(eval_keys, jnp.int32(eval_index)))


def test_tiny_run_beats_random_policy_on_every_seed(vmapped):
    """Final deterministic-policy return > the uniform-random policy's mean return, per seed
    (random baseline from the evaluations' reset keys, 5 episodes × 4 indices)."""
    st = vmapped.states
    rand = np.concatenate([uniform_random_returns(tiny(), st.eval_key, j) for j in range(4)], axis=1)  # [seeds, 20]
    final = vmapped.evaluations[-1].mean(axis=1)
    print("random per seed", rand.mean(1), "initial", vmapped.evaluations[0].mean(1), "final", final)
    assert np.all(final > rand.mean(axis=1) + 3 * rand.std(axis=1) / np.sqrt(rand.shape[1]))
    assert np.all(final > vmapped.evaluations[0].mean(axis=1))


def test_different_seeds_differ(vmapped):
    ev = vmapped.evaluations
    assert not np.array_equal(ev[:, 0], ev[:, 1])
    k = vmapped.final_actor["params/body/dense_0/kernel"]
    assert not np.allclose(k[0], k[1])


def test_transitions_truncation_bootstraps_termination_does_not(vmapped):
    """In the real buffer: terminated ∈ {0,1}; Hopper episodes that fell are stored terminated=1;
    stored next_obs of a terminal step is the true final obs (not a reset obs near qpos0)."""
    buf = jax.tree.map(np.asarray, vmapped.states.buffer)
    assert np.all(buf.size == 4000) and np.all(buf.ptr == 4000)
    data = jax.tree.map(lambda x: x[:, :4000].reshape(-1, *x.shape[2:]), buf.data)
    term = data.terminated
    assert set(np.unique(term)) <= {0.0, 1.0} and term.sum() > 0
    # a fallen Hopper: height qpos[1] = obs[0] ≤ 0.7 or |angle| = |obs[1]| ≥ 0.2 or big values
    fin = data.next_obs[term == 1]
    unhealthy = (fin[:, 0] <= 0.7) | (np.abs(fin[:, 1]) >= 0.2) | np.any(np.abs(fin[:, 1:]) >= 100, axis=1)
    assert np.all(unhealthy)
    ok = data.next_obs[term == 0]
    assert np.mean((ok[:, 0] > 0.7) & (np.abs(ok[:, 1]) < 0.2)) == 1.0


def test_checkpoints_hold_each_transition_once_and_rebuild_the_buffer_exactly(vmapped):
    """The orbax checkpoints hold no replay buffer; checkpoints/replay/ holds every transition once,
    one segment per chunk; the buffer rebuilt from it at step 4000 is the run's final buffer, bit
    for bit (slots never written: zeros)."""
    from swim_jax.io.checkpoint import Checkpointer, leaf_names
    from swim_jax.io.replay_store import ReplayStore

    ckpt_dir = os.path.join(vmapped.run_dir, "checkpoints")
    store = ReplayStore(os.path.join(ckpt_dir, "replay"), 10000)
    assert [(a, b) for a, b, _ in store.segments()] == [(0, 1000), (1000, 2000), (2000, 3000), (3000, 4000)]
    data = vmapped.states.buffer.data
    got = store.rebuild(4000, {k: (a.shape, a.dtype) for k, a in data._asdict().items()})
    for k, a in data._asdict().items():
        np.testing.assert_array_equal(got[k], np.asarray(a), err_msg=k)
    assert np.all(got["obs"][:, 4000:] == 0) and np.any(got["obs"][:, :4000] != 0)
    ck = Checkpointer(ckpt_dir)
    whole = set(leaf_names((vmapped.states, np.zeros((5, 2, 5)))))
    stored = ck.stored_keys(4000)  # the leaves by name: exactly the buffer's arrays left out
    assert stored < whole and whole - stored == {f"0.buffer.data.{k}" for k in data._fields}
    assert {"0.agent.actor.params.body.head.kernel", "0.agent.critic.params.critics.body.dense_0.kernel", "1"} <= stored
    ck.close()


def _resumed_at_2000(src: str, dst: str) -> train.RunResult:
    shutil.copytree(src, dst)
    for step in ("3000", "4000"):
        shutil.rmtree(os.path.join(dst, "checkpoints", step))
    return train.run(tiny(*VMAPPED), dst, resume=True, log=lambda s: None)


def test_resume_from_a_checkpoint_equals_the_uninterrupted_run(vmapped, tmp_path):
    """Resumed from checkpoint 2000 (its buffer rebuilt from the replay segments): the same
    evaluations, final actor and final buffer as the uninterrupted run, bit for bit."""
    res = _resumed_at_2000(vmapped.run_dir, str(tmp_path / "resumed"))
    np.testing.assert_array_equal(res.evaluations, vmapped.evaluations)
    for k, v in res.final_actor.items():
        np.testing.assert_array_equal(v, vmapped.final_actor[k], err_msg=k)
    for a, b in zip(jax.tree.leaves(res.states.buffer), jax.tree.leaves(vmapped.states.buffer)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    assert res.chunk_fn is vmapped.chunk_fn and res.chunk_fn._cache_size() == 1


def test_a_run_checkpointed_with_its_whole_buffer_resumes_the_same(vmapped, tmp_path, monkeypatch):
    """A run folder written as before the replay store (every checkpoint the whole training state,
    buffer included, as the earlier code's ``ckpt.save(step, (states, evals.saved()))``; no
    checkpoints/replay/) still resumes, bit for bit the uninterrupted run."""
    with monkeypatch.context() as m:
        m.setattr(train, "_save", lambda ckpt, store, step, eval_freq, states, evals:
                  ckpt.save(step, (states, evals.saved())))
        old = train.run(tiny(*VMAPPED), str(tmp_path / "old"), log=lambda s: None)
    assert not os.path.exists(os.path.join(old.run_dir, "checkpoints", "replay"))
    np.testing.assert_array_equal(old.evaluations, vmapped.evaluations)
    res = _resumed_at_2000(old.run_dir, str(tmp_path / "resumed"))
    np.testing.assert_array_equal(res.evaluations, vmapped.evaluations)
    for k, v in res.final_actor.items():
        np.testing.assert_array_equal(v, vmapped.final_actor[k], err_msg=k)


def test_a_budget_grown_on_resume_equals_a_run_started_with_it(vmapped, tmp_path):
    """A finished run of 2000 steps resumed with ``total_steps=4000`` continues to 4000 bit for bit
    as the run started with 4000 (evaluations of every episode, final actor, replay buffer), its
    config.yaml now says 4000 and nothing recompiles; the CLI takes no other override on resume,
    nor a smaller budget (one line, exit 2, config.yaml untouched)."""
    short = train.run(tiny(*VMAPPED, "total_steps=2000"), str(tmp_path / "grown"), log=lambda s: None)
    d = short.run_dir
    assert short.evaluations.shape[0] == 3
    cfg, resume = train.parse_args(["--resume", d, "total_steps=4000"])
    assert resume == d and cfg == with_physics_backend(tiny(*VMAPPED))
    lines = []
    res = train.run(cfg, d, resume=True, log=lines.append)
    assert any("budget grown: total_steps 2000 -> 4000" in line for line in lines)
    np.testing.assert_array_equal(res.evaluations, vmapped.evaluations)
    np.testing.assert_array_equal(np.load(os.path.join(d, "evaluations.npy")), np.load(os.path.join(vmapped.run_dir, "evaluations.npy")))
    for k, v in res.final_actor.items():
        np.testing.assert_array_equal(v, vmapped.final_actor[k], err_msg=k)
    with np.load(os.path.join(d, "final_policy.npz")) as z:  # the final policy of the new budget
        np.testing.assert_array_equal(z[sorted(z.files)[0]], vmapped.final_actor[sorted(z.files)[0]])
    for a, b in zip(jax.tree.leaves(res.states.buffer), jax.tree.leaves(vmapped.states.buffer)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    assert res.chunk_fn is vmapped.chunk_fn and res.chunk_fn._cache_size() == 1
    assert train.parse_args(["--resume", d])[0].total_steps == 4000  # config.yaml says the new budget
    before = open(os.path.join(d, "config.yaml"), "rb").read()
    for argv, needle in [(["total_steps=2000"], "below the run's total_steps=4000"),
                         (["seeds=3"], "--resume takes only total_steps=N"),
                         (["total_steps=4500"], "multiple of eval_freq")]:
        with pytest.raises(cfgmod.ConfigError, match=needle):
            train.parse_args(["--resume", d, *argv])
    assert train.main(["--resume", d, "agent.tau=0.01"]) == 2
    assert open(os.path.join(d, "config.yaml"), "rb").read() == before


def test_an_old_folder_that_says_matmul_dtype_auto_resumes_as_it_ran(vmapped, tmp_path):
    """``matmul_dtype: auto`` (the old default: bfloat16 on CPUs with bfloat16 dot instructions)
    means what the folder's first stretch recorded, on any machine, for resume, evaluation and export."""
    d = str(tmp_path / "old")
    os.makedirs(d)
    text = open(os.path.join(vmapped.run_dir, "config.yaml")).read()
    assert "matmul_dtype: full" in text
    with open(os.path.join(d, "config.yaml"), "w") as f:
        f.write(text.replace("matmul_dtype: full", "matmul_dtype: auto"))
    assert train.parse_args(["--resume", d])[0].matmul_dtype == "full"  # nothing recorded: full
    for recorded, means in [("bfloat16", "bfloat16"), ("float32", "full")]:
        with open(os.path.join(d, provenance.FILENAME), "w") as f:
            json.dump([{"step": 0, "matmul_dtype": recorded}, {"step": 1000, "matmul_dtype": "float32"}], f)
        assert train.parse_args(["--resume", d])[0].matmul_dtype == means
        assert cfgmod.read_run_config(d)[1].matmul_dtype == means


def test_single_seed_equals_its_slot_in_the_vmapped_run(vmapped, tmp_path):
    """seeds=1 first_seed=1 (a padded 2-lane program: the same executable, nothing compiled)
    reproduces seed 1 of the 2-seed run bit for bit: evaluations and final actor."""
    lines = []
    res = train.run(tiny("seeds=1", "first_seed=1"), str(tmp_path / "single"), log=lines.append)
    progress = [line for line in lines if line.startswith("step ")]
    assert progress and all(" over 1 seed" in line and "1 seeds" not in line for line in progress)
    assert res.evaluations.shape == (5, 1, 5) and res.final_actor["params/body/head/bias"].shape[0] == 1
    np.testing.assert_array_equal(res.evaluations[:, 0], vmapped.evaluations[:, 1])
    for k, v in res.final_actor.items():
        np.testing.assert_array_equal(v[0], vmapped.final_actor[k][1], err_msg=k)
    assert res.chunk_fn is vmapped.chunk_fn and res.chunk_fn._cache_size() == 1
    ev = np.load(os.path.join(res.run_dir, "evaluations.npy"))
    assert ev.shape == (5, 1)


def test_nan_detection_names_seed_step_and_quantity(vmapped):
    """Poison seed 1's critic in the real compiled chunk: the first bad step is the first update."""
    st = jax.tree.map(jnp.copy, vmapped.states)
    critic = jax.tree.map(lambda x: x.at[1].set(jnp.nan) if x.ndim else x, st.agent.critic)
    st = st._replace(agent=st.agent._replace(critic=critic))
    out, metrics = vmapped.chunk_fn(st, jnp.int32(4000))
    hit = train._first_bad(np.asarray(out.bad_step))
    assert hit == (1, 4000, "critic_loss")
    assert np.all(np.asarray(out.bad_step)[0] == -1)
    assert np.isnan(np.asarray(metrics.critic_loss)[1]) and np.isfinite(np.asarray(metrics.critic_loss)[0])


# ------------------------------------------------------------------------------------------------
# CLI
# ------------------------------------------------------------------------------------------------

@pytest.mark.parametrize(
    "argv, needle",
    [
        (["config=nope"], "valid configs: ant_relu"),
        (["config=walker_swim", "agent.foo=1"], "valid keys under agent:"),
        (["config=walker_swim", "seeds=two"], "seeds: expected int"),
        (["config=walker_swim", "env.id=Pong-v5"], "valid: Hopper-v5"),
        (["config=walker_swim", "agent.activation.name=gelu"], "valid: elu, hard_swish, mish, relu, swim, swish"),
        (["config=walker_swim", "precision=float16"], "valid: float32, float64"),
        (["config=walker_swim", "matmul_precision=tf32"], "valid: highest, high, default"),
        (["config=walker_swim", "matmul_dtype=float16"], "valid: full, bfloat16"),
        (["config=walker_swim", "env.backend=bullet"], "unknown env.backend 'bullet'; valid: auto, mjx, mujoco"),
        (["config=walker_swim", "env.native_call=python"], "unknown env.native_call 'python'; valid: auto, ffi, callback"),
        (["config=walker_swim", "total_steps=12345"], "multiple of eval_freq"),
        (["config=walker_swim", "bogus"], "expected config=<name>"),
        ([], "valid configs:"),
    ],
)
def test_cli_errors_one_line_exit_2_nothing_written(argv, needle, tmp_path, capsys):
    rc = train.main(argv + [f"out_dir={tmp_path}/out"] if argv and argv[0].startswith("config=walker") else argv)
    err = capsys.readouterr().err
    assert rc == 2
    assert err.startswith("error: ") and err.count("\n") == 1 and needle in err, err
    assert not os.path.exists(tmp_path / "out")


def test_cli_error_exit_status_in_a_real_process(tmp_path):
    p = subprocess.run([sys.executable, "-m", "swim_jax.train", "config=walker_swim", "agent.activation.k=-1",
                        f"out_dir={tmp_path}/out"], cwd=REPO, capture_output=True, text=True, timeout=120)
    assert p.returncode == 2
    assert p.stderr.strip().splitlines()[-1].startswith("error: ") and "must be finite and > 0" in p.stderr
    assert not os.path.exists(tmp_path / "out")


def test_config_files_and_overrides_resolve():
    names = cfgmod.available_configs()
    for env in ["walker", "hopper", "cheetah", "swimmer", "ant"]:
        for act in ["swim", "swish", "relu"]:
            assert f"{env}_{act}" in names
    e = cfgmod.resolve("walker_swim", ["agent.actor_lr=1e-3", "total_steps=2e5", "agent.critic_lr=3.0e-4"])
    assert (e.agent.actor_lr, e.total_steps, e.agent.critic_lr) == (1e-3, 200000, 3e-4)
    with pytest.raises(cfgmod.ConfigError, match="expected int"):
        cfgmod.resolve("walker_swim", ["seeds=1.5"])
    c = cfgmod.resolve("walker_swim", ["seeds=5", "total_steps=200000", "agent.activation.k=0.75",
                                       "precision=float64", "env.id=Hopper-v5"])
    assert (c.seeds, c.total_steps, c.agent.activation.k, c.precision, c.env.id) == (5, 200000, 0.75, "float64", "Hopper-v5")
    assert c.agent.activation.name == "swim" and c.name == "walker_swim"
    d = cfgmod.resolve("cheetah_relu", [])
    # the reference protocol defaults
    a = d.agent
    assert (a.hidden, a.actor_lr, a.critic_lr, a.batch_size, a.discount, a.tau, a.policy_noise, a.noise_clip,
            a.expl_noise, a.policy_freq) == ((256, 256), 3e-4, 3e-4, 256, 0.99, 0.005, 0.2, 0.5, 0.1, 2)
    assert (d.learning_starts, d.eval_freq, d.eval_episodes, d.replay_size, d.total_steps, d.seeds) == (
        25000, 5000, 10, 1_000_000, 1_000_000, 5)
    assert d.env.id == "HalfCheetah-v5" and d.agent.activation.name == "relu"


# ------------------------------------------------------------------------------------------------
# resume after SIGKILL
# ------------------------------------------------------------------------------------------------

def _cli(args, env, **kw):
    return subprocess.run([sys.executable, "-m", "swim_jax.train", *args], cwd=REPO, env=env,
                          capture_output=True, text=True, timeout=1800, **kw)


def _groups(timing: dict) -> int:
    """The lane groups timing.json names (``"2 lanes as 2 groups of 1, ..."``), 0 for none."""
    text = timing["lane_groups"]
    return int(text.split(" groups of ")[0].split()[-1]) if text else 0


@pytest.mark.slow
def test_resume_after_sigkill_matches_uninterrupted_run(tmp_path):
    """Uninterrupted CLI run vs a CLI run SIGKILLed after its first checkpoint and resumed with
    ``--resume``: identical evaluations (every episode) and final actor parameters, and the
    resumed process compiles each program once. All three processes share a persistent
    compilation cache (the later two load the first one's executables instead of compiling);
    the reference is a CLI run rather than the in-process fixture so that the swim_jax/envs/agents code
    cannot change between reference and resume in a working tree that others edit."""
    env = dict(os.environ, JAX_COMPILATION_CACHE_DIR=str(tmp_path / "jax_cache"),
               JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS="0", PYTHONUNBUFFERED="1")
    ref = _cli([f"config={CONFIG}", *TINY, f"out_dir={tmp_path / 'ref'}"], env)
    assert ref.returncode == 0, ref.stderr[-2000:]
    ref_dir = next(l.split(": ", 1)[1] for l in ref.stdout.splitlines() if l.startswith("run dir: "))

    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "swim_jax.train", f"config={CONFIG}", *TINY, f"out_dir={out}"]
    p = subprocess.Popen(cmd, cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    run_dir = None
    try:
        for line in p.stdout:
            if line.startswith("run dir: "):
                run_dir = line.split(": ", 1)[1].strip()
            if line.startswith("step ") and " 1000/" in line.split("|")[0]:
                p.send_signal(signal.SIGKILL)  # mid-run: right after the first checkpoint
                break
    finally:
        p.wait(timeout=600)
    assert p.returncode == -signal.SIGKILL and run_dir
    assert not os.path.exists(os.path.join(run_dir, "final_policy.npz"))
    r = _cli(["--resume", run_dir], env)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "resumed" in r.stdout
    import json

    timing = json.load(open(os.path.join(run_dir, "timing.json")))
    ref_timing = json.load(open(os.path.join(ref_dir, "timing.json")))
    # restored state: no recompiles (one chunk executable per lane group this machine placed, as the reference's)
    assert timing["chunk_compiles"] == ref_timing["chunk_compiles"] == max(1, _groups(ref_timing))
    assert timing["eval_compiles"] == 1
    np.testing.assert_array_equal(np.load(os.path.join(run_dir, "evaluations_episodes.npy")),
                                  np.load(os.path.join(ref_dir, "evaluations_episodes.npy")))
    got, want = np.load(os.path.join(run_dir, "final_policy.npz")), np.load(os.path.join(ref_dir, "final_policy.npz"))
    assert sorted(got.files) == sorted(want.files)
    for k in want.files:
        np.testing.assert_array_equal(got[k], want[k], err_msg=k)


def test_programs_are_rebuilt_for_each_matmul_setting():
    """The program cache keys on every field that changes the program: a bfloat16-matmul config
    must not get the cached float32 program (building only, no compile)."""
    plain = programs(tiny("seeds=2", "matmul_dtype=full"))
    bf16 = programs(tiny("seeds=2", "matmul_dtype=bfloat16"))
    assert bf16 is not plain and plain.agent.matmul_dtype is None
    assert jnp.dtype(bf16.agent.matmul_dtype) == jnp.bfloat16
    assert programs(tiny("seeds=2", "matmul_dtype=full", "matmul_precision=default")) is not plain
    assert programs(tiny("seeds=5", "matmul_dtype=full")) is plain  # seeds only change the lane shapes


def test_float64_precision_builds_everything_in_float64():
    """precision=float64: env physics, observations, params, Adam state and replay are all f64
    (init program only; the full f64 chunk compiles too slowly for the default run)."""
    cfg = tiny("precision=float64", "seeds=2", "replay_size=100")
    prog = programs(cfg)
    assert jax.config.jax_enable_x64
    st = prog.init_fn(jnp.asarray(0, jnp.uint32), jnp.arange(2, dtype=jnp.int32))
    floats = [x for x in jax.tree.leaves(st) if jnp.issubdtype(x.dtype, jnp.floating)]
    assert floats and all(x.dtype == jnp.float64 for x in floats)
    assert st.env_state.obs.dtype == jnp.float64 and st.buffer.data.obs.dtype == jnp.float64


@pytest.mark.slow
def test_divergence_stops_with_message_and_keeps_last_good_checkpoint(tmp_path):
    """A critic learning rate of 1e30 blows the critic up in the second chunk: exit status 3, one
    message naming seed, step and quantity, the step-1000 checkpoint intact and restorable."""
    out = tmp_path / "out"
    p = subprocess.run([sys.executable, "-m", "swim_jax.train", f"config={CONFIG}", *TINY,
                        "agent.critic_lr=1e30", f"out_dir={out}"], cwd=REPO, capture_output=True,
                       text=True, timeout=1800)
    assert p.returncode == 3, p.stderr[-2000:]
    msg = p.stderr.strip().splitlines()[-1]
    assert msg.startswith("error: non-finite ") and " in seed " in msg and " at step " in msg, msg
    assert "last good checkpoint: step 1000" in msg, msg
    run_dir = next(l.split(": ", 1)[1] for l in p.stdout.splitlines() if l.startswith("run dir: "))
    assert sorted(os.listdir(os.path.join(run_dir, "checkpoints"))) == ["1000", "replay"]
    assert not os.path.exists(os.path.join(run_dir, "final_policy.npz"))
    cfg = train.parse_args(["--resume", run_dir])[0]
    prog = programs(cfg)
    from swim_jax.io.checkpoint import Checkpointer

    ck = Checkpointer(os.path.join(run_dir, "checkpoints"))
    ids = jnp.arange(2, dtype=jnp.int32)
    full = jax.eval_shape(prog.init_fn, jnp.asarray(0, jnp.uint32), ids)  # (the buffer: checkpoints/replay)
    st, ev = ck.restore(1000, (train._without_replay(full), jax.ShapeDtypeStruct((5, 2, 5), jnp.float32)))
    assert all(np.all(np.isfinite(np.asarray(x))) for x in jax.tree.leaves(st.agent))
    assert np.all(np.isfinite(np.asarray(ev)[:2])) and np.all(np.isnan(np.asarray(ev)[2:]))


def test_ynn_fusions_are_off_in_the_cpu_training_chunk_unless_asked_for():
    """The chunk's compiler options reach XLA: with float32 matmuls, YNNPACK fusions only with
    xla_cpu_ynn_fusions=true."""
    def compiled_text(cfg):
        prog = programs(cfg)
        states = prog.init_fn(jnp.asarray(0, jnp.uint32), jnp.arange(1, dtype=jnp.int32))
        return prog.chunk_fn.lower(states, jnp.asarray(0, jnp.int32), None).compile().as_text()

    full = ("seeds=1", "pad_single_seed=false", "matmul_dtype=full")
    assert "__ynn_fusion" not in compiled_text(tiny(*full))
    assert "__ynn_fusion" in compiled_text(tiny(*full, "xla_cpu_ynn_fusions=true"))


def test_matmul_dtype_is_the_runs_precision_on_every_cpu_unless_bfloat16_is_asked_for():
    """matmul_dtype: full (the default) multiplies in the run's precision whatever the CPU,
    bfloat16 only when asked; the old per-CPU ``auto`` is refused for new runs with one line."""
    assert cfgmod.Config().matmul_dtype == "full"
    assert matmul_dtype(tiny())[0] is None and matmul_dtype(tiny())[1].startswith("float32 matmuls")
    assert matmul_dtype(tiny("precision=float64"))[0] is None
    assert matmul_dtype(tiny("matmul_dtype=bfloat16"))[0] == jnp.bfloat16
    with pytest.raises(cfgmod.ConfigError, match="matmul_dtype=auto is no longer offered.*valid: full"):
        tiny("matmul_dtype=auto")


def test_bfloat16_chunk_keeps_ynn_fusions_and_runs():
    """matmul_dtype=bfloat16 keeps XLA's YNNPACK fusions (its CPU backend multiplies bfloat16
    natively only there) and the chunk runs: XLA's plain dot has no bf16 x bf16 -> f32 kernel, so a
    weight-gradient product left outside the fusions would fail at run time (networks.py)."""
    cfg = tiny("seeds=2", "matmul_dtype=bfloat16")
    prog = programs(cfg)
    states = prog.init_fn(jnp.asarray(0, jnp.uint32), jnp.arange(2, dtype=jnp.int32))
    compiled = prog.chunk_fn.lower(states, jnp.asarray(0, jnp.int32)).compile()
    assert "__ynn_fusion" in compiled.as_text()
    states, metrics = prog.chunk_fn(states, jnp.asarray(cfg.learning_starts, jnp.int32))
    assert np.all(np.isfinite(np.asarray(jax.tree.leaves(states.agent.critic)[0])))


def test_help_prints_usage_on_stdout_and_exits_0():
    out = subprocess.run([sys.executable, "-m", "swim_jax.train", "--help"], cwd=REPO,
                         capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("usage: python -m swim_jax.train config=<name>")
