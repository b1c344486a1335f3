"""Fixtures shared by the test modules."""

import jax
import pytest


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
