"""Fixtures shared by the test modules."""

import jax
import pytest

from swim_jax.run.programs import use_compilation_cache

# Start JAX's backends now, so that in-process runs see one CPU device whichever test comes first:
# train.run asks for one host device per core (lane_groups, on by default) only before they start.
# Lane groups are tested in subprocesses with their own XLA_FLAGS (tests/test_lane_groups.py).
jax.devices()
# The persistent compilation cache every run uses (~/.cache/swim-jax/xla, $XDG_CACHE_HOME respected;
# off with SWIM_JAX_NO_COMPILATION_CACHE=1), from the session's first compile instead of its first
# train.run: a program compiled before (the MJX env programs take minutes each on 2 cores) is read
# back, keyed by its HLO, the XLA flags and jaxlib, so a changed program compiles anew.
use_compilation_cache()


@pytest.fixture(autouse=True)
def restore_x64():
    """Every test ends in the x64 mode it started in, whatever it (or the code it runs, e.g.
    ``programs.programs`` of a float64 config) switched: tests do not depend on their order, which
    differs between one process and the workers of ``pytest -n``."""
    prev = jax.config.jax_enable_x64
    yield
    jax.config.update("jax_enable_x64", prev)


@pytest.fixture
def x64():
    """JAX x64 mode (float64 arrays; envs built now get float64 physics) for one test; the previous
    mode comes back after it (:func:`restore_x64`), so the rest of the session keeps float32."""
    jax.config.update("jax_enable_x64", True)


# --------------------------------------------------------------------------- trained policies
# (tests/test_policy.py, tests/test_evaluate.py: swim_jax.policy and swim_jax.analysis.evaluate)

POLICY_TINY = ["total_steps=2000", "eval_freq=1000", "learning_starts=500", "eval_episodes=3", "replay_size=4000",
               "agent.hidden=[16,16]", "agent.batch_size=32", "env.backend=mujoco", "lane_groups=false"]
# a plain run: float64, Swim with k learned per layer, 2 seeds (the Gymnasium fidelity check needs float64)
POLICY_RUN_F64 = ("hopper_swim", ["seeds=2", "precision=float64", "agent.activation.learnable=true"])
# a sweep: float32 with bfloat16 matmuls, Swish's beta swept over 2 points, 1 seed (2 lanes)
POLICY_RUN_SWEEP = ("hopper_swish", ["seeds=1", "matmul_dtype=bfloat16", "sweep.agent.activation.beta=[0.5,2]"])


@pytest.fixture(scope="session")
def policy_runs(tmp_path_factory):
    """``{"f64": RunResult, "sweep": RunResult}``: two tiny finished runs (MuJoCo C physics, 2000
    steps, checkpoints at 1000 and 2000), trained once per session; each result has ``.cfg``."""
    from swim_jax import config as cfgmod
    from swim_jax.run import train

    prev = jax.config.jax_enable_x64
    out = {}
    try:
        for key, (config, extra) in (("f64", POLICY_RUN_F64), ("sweep", POLICY_RUN_SWEEP)):
            cfg = cfgmod.resolve(config, POLICY_TINY + extra)
            res = train.run(cfg, str(tmp_path_factory.mktemp(f"policy_{key}") / "run"), log=lambda line: None)
            res.cfg = cfg
            out[key] = res
    finally:
        jax.config.update("jax_enable_x64", prev)
    return out


NO_JAX_SITECUSTOMIZE = '''
import sys

BLOCKED = ("jax", "jaxlib", "flax", "optax", "orbax", "brax", "chex")


class _NoJax:
    """Makes importing JAX (and the libraries built on it) fail in this process."""

    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in BLOCKED:
            raise ImportError(f"{name}: blocked (this test runs without JAX)")
        return None


sys.meta_path.insert(0, _NoJax())
'''


@pytest.fixture
def no_jax_env(tmp_path):
    """Environment variables for a subprocess in which ``import jax`` (flax, orbax, ...) raises
    ImportError: a sitecustomize.py on PYTHONPATH installs an import hook that refuses them."""
    import os

    site = tmp_path / "no_jax_site"
    site.mkdir()
    (site / "sitecustomize.py").write_text(NO_JAX_SITECUSTOMIZE)
    repo = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    return dict(os.environ, PYTHONPATH=os.pathsep.join([str(site), repo]))
