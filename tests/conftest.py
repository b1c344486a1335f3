"""Fixtures shared by the test modules."""

import jax
import pytest

# Start JAX's backends now, so that in-process runs see one CPU device whichever test comes first:
# train.run asks for one host device per core (lane_groups, on by default) only before they start.
# Lane groups are tested in subprocesses with their own XLA_FLAGS (tests/test_lane_groups.py).
jax.devices()


@pytest.fixture
def x64():
    """JAX x64 mode (float64 arrays; envs built now get float64 physics) for one test, then the
    previous mode again, so the rest of the session keeps float32."""
    prev = jax.config.jax_enable_x64
    jax.config.update("jax_enable_x64", True)
    yield
    jax.config.update("jax_enable_x64", prev)


@pytest.fixture
def restore_x64():
    """The x64 mode before the test, restored after it whatever the code under test switched
    (e.g. a ``precision=float64`` config)."""
    prev = jax.config.jax_enable_x64
    yield
    jax.config.update("jax_enable_x64", prev)
