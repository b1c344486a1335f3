"""swim_jax/agents/: networks, replay buffer and one TD3 update against independent float64 references.

The reference re-implements the networks, TD target, losses, Adam and Polyak by hand in float64
(numpy for the forward math and Adam; jax.grad only differentiates the hand-written jnp forward).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from swim_jax.agents import replay
from swim_jax.agents.networks import Actor, NetworkOptions, TwinCritic
from swim_jax.agents.td3 import TD3, ActivationConfig, TD3Config

OBS, ACT, B = 5, 3, 16
LOW, HIGH = (-2.0, -1.0, -0.5), (2.0, 1.0, 0.5)  # deliberately non-symmetric per-dimension ranges


# ------------------------------------------------------------------------------------------------
# independent reference (float64)
# ------------------------------------------------------------------------------------------------

def ref_act(name, x, param):
    """The activation by its formula; ``param`` is its own parameter (k, beta or alpha)."""
    if name == "relu":
        return jnp.maximum(x, 0.0)
    if name == "swim":
        return x / 2 * (param * x / jnp.sqrt(1 + param * param * x * x) + 1)
    if name == "swish":
        return x / (1 + jnp.exp(-param * x))
    if name == "elu":
        return jnp.where(x > 0, x, param * (jnp.exp(jnp.minimum(x, 0.0)) - 1))
    raise AssertionError(name)


def ref_body(p, x, name, n_hidden, k):
    """p: dict with dense_i/head kernels, x @ W + b, activation after every hidden layer."""
    for i in range(n_hidden):
        x = ref_act(name, x @ p[f"dense_{i}"]["kernel"] + p[f"dense_{i}"]["bias"], k)
    return x @ p["head"]["kernel"] + p["head"]["bias"]


def ref_actor(p, s, name, n_hidden, k):
    low, high = jnp.asarray(LOW), jnp.asarray(HIGH)
    return jnp.tanh(ref_body(p["params"]["body"], s, name, n_hidden, k)) * (high - low) / 2 + (high + low) / 2


def ref_q(p, s, a, j, name, n_hidden, k):
    body = jax.tree.map(lambda x: x[j], p["params"]["critics"]["body"])
    return ref_body(body, jnp.concatenate([s, a], -1), name, n_hidden, k)[:, 0]


def ref_adam(params, grads, m, v, t, lr, b1=0.9, b2=0.999, eps=1e-8):
    """Adam (Kingma & Ba), bias-corrected, eps outside the sqrt (PyTorch/optax convention)."""
    m = jax.tree.map(lambda m_, g: b1 * m_ + (1 - b1) * g, m, grads)
    v = jax.tree.map(lambda v_, g: b2 * v_ + (1 - b2) * g * g, v, grads)
    new = jax.tree.map(
        lambda p, m_, v_: p - lr * (m_ / (1 - b1**t)) / (np.sqrt(v_ / (1 - b2**t)) + eps), params, m, v
    )
    return new, m, v


def np64(tree):
    return jax.tree.map(lambda x: np.asarray(x, np.float64), tree)


@pytest.mark.parametrize("act_name", ["relu", "swim", "elu"])
def test_td3_two_updates_match_float64_reference(act_name):
    """Update 1 (critic only) then update 2 (critic + delayed actor + Polyak) vs the reference."""
    with jax.enable_x64(True):
        cfg = TD3Config(hidden=(8, 8), activation=ActivationConfig(name=act_name, k=0.75, alpha=0.75),
                        actor_lr=1e-2, critic_lr=2e-2, batch_size=B, tau=0.05, discount=0.9)
        agent = TD3(cfg, OBS, LOW, HIGH, dtype=jnp.float64)
        state = agent.init(jax.random.PRNGKey(3))
        # perturb the targets so target != online (tests that the target nets are what is used)
        kp = jax.random.PRNGKey(11)
        state = state._replace(
            actor_target=jax.tree.map(lambda x: x + 0.1 * jax.random.normal(kp, x.shape, x.dtype), state.actor_target),
            critic_target=jax.tree.map(lambda x: x - 0.1 * jax.random.normal(kp, x.shape, x.dtype), state.critic_target),
        )
        rng = np.random.default_rng(0)
        batch = replay.Transition(
            obs=jnp.asarray(rng.normal(size=(B, OBS))),
            action=jnp.asarray(rng.uniform(LOW, HIGH, size=(B, ACT))),
            reward=jnp.asarray(rng.normal(size=B)),
            next_obs=jnp.asarray(rng.normal(size=(B, OBS))),
            terminated=jnp.asarray((rng.uniform(size=B) < 0.3).astype(np.float64)),
        )
        keys = [jax.random.PRNGKey(100), jax.random.PRNGKey(101)]
        update = jax.jit(agent.update_delayed)  # one program for both updates (the flag is traced)
        s1, m1 = update(state, batch, keys[0], jnp.asarray(False))
        s2, m2 = update(s1, batch, keys[1], jnp.asarray(True))

        # ---------------- reference ----------------
        name, nh, k = act_name, 2, 0.75
        refq = lambda p, s, a, j: ref_q(p, s, a, j, name, nh, k)
        refmu = lambda p, s: ref_actor(p, s, name, nh, k)
        m_act = (np.asarray(HIGH) - np.asarray(LOW)) / 2
        b = np64(batch)
        actor, critic = np64(state.actor), np64(state.critic)
        actor_t, critic_t = np64(state.actor_target), np64(state.critic_target)
        zeros = lambda t: jax.tree.map(np.zeros_like, t)
        mc, vc, ma, va = zeros(critic), zeros(critic), zeros(actor), zeros(actor)

        def target(key, actor_t, critic_t):
            eps = np.asarray(jax.random.normal(key, (B, ACT), jnp.float64)) * (0.2 * m_act)
            eps = np.clip(eps, -0.5 * m_act, 0.5 * m_act)
            a2 = np.clip(np.asarray(refmu(actor_t, b.next_obs)) + eps, LOW, HIGH)
            q1 = np.asarray(refq(critic_t, b.next_obs, a2, 0))
            q2 = np.asarray(refq(critic_t, b.next_obs, a2, 1))
            return b.reward + 0.9 * (1 - b.terminated) * np.minimum(q1, q2)

        def lq(c, y):
            return sum(jnp.mean((refq(c, b.obs, b.action, j) - y) ** 2) for j in range(2))

        # update 1: critic only
        y1 = target(keys[0], actor_t, critic_t)
        l1, g1 = jax.value_and_grad(lq)(critic, y1)
        critic1, mc, vc = ref_adam(critic, np64(g1), mc, vc, 1, 2e-2)
        np.testing.assert_allclose(m1.critic_loss, l1, rtol=1e-10)
        assert float(m1.actor_loss) == 0.0 and not bool(m1.actor_updated)
        jax.tree.map(lambda a, r: np.testing.assert_allclose(a, r, rtol=1e-9, atol=1e-12), np64(s1.critic), critic1)
        for got, want in [(s1.actor, actor), (s1.actor_target, actor_t), (s1.critic_target, critic_t)]:
            jax.tree.map(lambda a, r: np.testing.assert_array_equal(a, r), np64(got), want)

        # update 2: critic (Adam step 2), then actor on the NEW critic, then Polyak
        y2 = target(keys[1], actor_t, critic_t)
        l2, g2 = jax.value_and_grad(lq)(critic1, y2)
        critic2, mc, vc = ref_adam(critic1, np64(g2), mc, vc, 2, 2e-2)
        lmu_fn = lambda a: -jnp.mean(refq(critic2, b.obs, refmu(a, b.obs), 0))
        lmu, gmu = jax.value_and_grad(lmu_fn)(actor)
        actor2, ma, va = ref_adam(actor, np64(gmu), ma, va, 1, 1e-2)
        polyak = lambda t, p: 0.05 * p + 0.95 * t
        np.testing.assert_allclose(m2.critic_loss, l2, rtol=1e-10)
        np.testing.assert_allclose(m2.actor_loss, lmu, rtol=1e-10)
        assert bool(m2.actor_updated)
        close = lambda a, r: np.testing.assert_allclose(a, r, rtol=1e-9, atol=1e-12)
        jax.tree.map(close, np64(s2.critic), critic2)
        jax.tree.map(close, np64(s2.actor), actor2)
        jax.tree.map(close, np64(s2.actor_target), jax.tree.map(polyak, actor_t, actor2))
        jax.tree.map(close, np64(s2.critic_target), jax.tree.map(polyak, critic_t, critic2))
        assert s2.actor["params"]["body"]["dense_0"]["kernel"].dtype == jnp.float64


def test_td_target_truncation_bootstraps_termination_does_not():
    """y = r + γ·minQ' when terminated = 0 (incl. truncated steps, stored as 0), y = r when 1."""
    cfg = TD3Config(hidden=(8, 8), discount=0.99)
    agent = TD3(cfg, OBS, (-1.0,) * ACT, (1.0,) * ACT)
    st = agent.init(jax.random.PRNGKey(0))
    s = jnp.ones((2, OBS))
    batch = replay.Transition(s, jnp.zeros((2, ACT)), jnp.asarray([1.0, 1.0]), s, jnp.asarray([0.0, 1.0]))
    key = jax.random.PRNGKey(5)
    y = agent.td_target(st, batch, key)
    assert float(y[1]) == 1.0
    # the bootstrapped row: recompute min Q' of the same smoothed next action
    mu = agent.act(st.actor_target, s)
    eps = jnp.clip(jax.random.normal(key, mu.shape) * 0.2, -0.5, 0.5)
    q = agent.critic_net.apply(st.critic_target, s, jnp.clip(mu + eps, -1, 1))
    np.testing.assert_allclose(float(y[0]), 1.0 + 0.99 * float(jnp.min(q[:, 0])), rtol=1e-6)
    assert abs(float(jnp.min(q[:, 0]))) > 1e-4


def test_networks_shapes_ranges_and_twin_independence():
    actor = Actor(LOW, HIGH, NetworkOptions(hidden=(16, 16), activation="swim", activation_params={"k": 0.5}))
    pa = actor.init(jax.random.PRNGKey(0), jnp.zeros((1, OBS)))
    big = 100.0 * jax.random.normal(jax.random.PRNGKey(1), (64, OBS))
    a = actor.apply(pa, big)
    assert a.shape == (64, ACT)
    assert np.all(np.asarray(a) >= np.asarray(LOW)) and np.all(np.asarray(a) <= np.asarray(HIGH))
    critic = TwinCritic(NetworkOptions(hidden=(16, 16), activation="relu"))
    pc = critic.init(jax.random.PRNGKey(0), jnp.zeros((1, OBS)), jnp.zeros((1, ACT)))
    q = critic.apply(pc, big, a)
    assert q.shape == (2, 64)
    k0 = pc["params"]["critics"]["body"]["dense_0"]["kernel"]
    assert k0.shape == (2, OBS + ACT, 16) and not np.allclose(k0[0], k0[1])
    # PyTorch nn.Linear init: |w|, |b| <= 1/sqrt(fan_in)
    assert float(jnp.max(jnp.abs(k0))) <= 1 / np.sqrt(OBS + ACT) + 1e-7
    hk = pc["params"]["critics"]["body"]["head"]["kernel"]
    assert float(jnp.max(jnp.abs(hk))) <= 1 / 4 + 1e-7


def test_network_options_compare_by_value_and_keep_the_parameter_layout():
    """NetworkOptions hash and compare by value (list widths and dict parameters normalised), and
    the parameter tree keeps its names (checkpoints and final_policy.npz files store these paths)."""
    a = NetworkOptions(hidden=[8, 8], activation="swim", activation_params={"k": 0.5}, learnable=True)
    b = NetworkOptions(hidden=(8, 8), activation="swim", activation_params=(("k", 0.5),), learnable=True)
    assert a == b and hash(a) == hash(b) and a.hidden == (8, 8)
    cfg = TD3Config(hidden=(8, 8), activation=ActivationConfig(name="swim", k=0.5, learnable=True))
    st = TD3(cfg, OBS, (-1.0,) * ACT, (1.0,) * ACT).init(jax.random.PRNGKey(0))
    paths = lambda tree: sorted("/".join(str(getattr(k, "key", k)) for k in kp)
                                for kp, _ in jax.tree_util.tree_flatten_with_path(tree)[0])
    layers = [f"{m}/{p}" for m, ps in [("act_0", ["k"]), ("act_1", ["k"]), ("dense_0", ["bias", "kernel"]),
                                      ("dense_1", ["bias", "kernel"]), ("head", ["bias", "kernel"])] for p in ps]
    assert paths(st.actor) == [f"params/body/{l}" for l in layers]
    assert paths(st.critic) == [f"params/critics/body/{l}" for l in layers]


def test_learnable_activation_is_a_per_layer_param_that_trains():
    cfg = TD3Config(hidden=(8, 8), activation=ActivationConfig(name="swim", k=0.5, learnable=True), batch_size=4)
    agent = TD3(cfg, OBS, (-1.0,) * ACT, (1.0,) * ACT)
    st = agent.init(jax.random.PRNGKey(0))
    ks = st.actor["params"]["body"]
    assert float(ks["act_0"]["k"]) == 0.5 and float(ks["act_1"]["k"]) == 0.5
    assert st.critic["params"]["critics"]["body"]["act_0"]["k"].shape == (2,)
    rng = np.random.default_rng(0)
    batch = replay.Transition(*(jnp.asarray(rng.normal(size=sh), jnp.float32) for sh in
                                [(4, OBS), (4, ACT), (4,), (4, OBS), (4,)]))
    st2, _ = agent.update_delayed(st, batch, jax.random.PRNGKey(1), jnp.asarray(True))
    assert float(st2.actor["params"]["body"]["act_0"]["k"]) != 0.5
    assert np.all(np.asarray(st2.critic["params"]["critics"]["body"]["act_1"]["k"]) != 0.5)


def test_bfloat16_matmul_derivatives_are_bfloat16_products_summed_in_float32():
    """matmul_dtype=bfloat16: a Dense layer's derivatives are low-precision products too (as
    PyTorch's autocast computes them): with g = dL/dy rounded to bfloat16, dL/dx = bf16(g·bf16(W)ᵀ)
    and dL/dW = bf16(bf16(x)ᵀ·g), each summed at float32 accuracy; checked against float64 products
    of the rounded operands, rounded to bfloat16 (≥ 98 % of the entries equal, the rest within one
    rounding step), on a 2-D batch, a single row (acting) and under vmap (lanes)."""
    import flax.linen as nn
    import ml_dtypes

    from swim_jax.agents.networks import dense_precision_options

    to_bf16 = lambda a: np.asarray(np.asarray(a, np.float32).astype(ml_dtypes.bfloat16), np.float64)
    layer = nn.Dense(48, **dense_precision_options(jnp.float32, jnp.bfloat16))
    key_x, key_p, key_c = jax.random.split(jax.random.PRNGKey(3), 3)
    for shape in [(64, 40), (40,), (2, 64, 40)]:
        x = jax.random.normal(key_x, shape)
        c = jax.random.normal(key_c, (*shape[:-1], 48))  # L = Σ c·y, so dL/dy = c
        params = layer.init(key_p, x[..., 0, :] if len(shape) == 3 else x)
        loss = lambda p, x, c: jnp.sum(c * layer.apply(p, x))
        grad = jax.grad(loss, argnums=(0, 1))
        if len(shape) == 3:  # two lanes, one layer's parameters each
            params = jax.tree.map(lambda a: jnp.stack([a, 2 * a]), params)
            grad = jax.vmap(grad)
        (gp, gx) = jax.jit(grad)(params, x, c)
        w = np.asarray(params["params"]["kernel"], np.float64)
        for got in (gx, gp["params"]["kernel"], gp["params"]["bias"]):  # every entry a bfloat16 value
            assert got.dtype == jnp.float32 and np.array_equal(to_bf16(got), np.asarray(got, np.float64))
        def reference(x, c, w):  # float64 products of the rounded operands for one lane's rows
            x, g = np.atleast_2d(to_bf16(x)), np.atleast_2d(to_bf16(c))
            return (g @ to_bf16(w).T).reshape(np.shape(c)[:-1] + (-1,)), x.T @ g, np.sum(np.atleast_2d(c), 0)

        lanes = [(x[i], c[i], w[i], i) for i in range(2)] if len(shape) == 3 else [(x, c, w, ...)]
        for xi, ci, wi, i in lanes:
            for got, ref in zip((gx[i], gp["params"]["kernel"][i], gp["params"]["bias"][i]), reference(xi, ci, wi)):
                got = np.asarray(got, np.float64)
                np.testing.assert_allclose(got, ref, rtol=2 ** -7, atol=1e-6)
                # the rounded float64 product itself, bar a sum that lands next to a rounding boundary
                # (float32 g instead of bf16(g), the autograd default, matches only ~57 %)
                assert np.mean(got == to_bf16(ref)) >= 0.98
        plain = jax.grad(lambda x: jnp.sum(c * nn.Dense(48).apply(
            jax.tree.map(lambda a: a[0], params) if len(shape) == 3 else params, x)))(x)
        if len(shape) == 2:
            assert np.max(np.abs(np.asarray(plain) - np.asarray(gx))) > 1e-4  # not the float32 derivative


def test_dense_derivatives_are_the_float64_products_computed_as_plain_products(x64):
    """A Dense layer's derivatives through :func:`dense_dot_general` (the network dtype, here
    float64) are dL/dx = g·Wᵀ, dL/dW = xᵀ·g, dL/db = Σ g to 1e-12 of numpy's float64 products, on a
    2-D batch, a single row (acting) and under vmap (lanes); and in the compiled program no product
    contracts the kernel's output axis (the "g·Wᵀ" form XLA's CPU dot runs slower, docs/PERFORMANCE.md:
    dense-transposed-kernel): every dot
    contracts its right operand's first non-batch axis."""
    import re

    import flax.linen as nn

    from swim_jax.agents.networks import dense_precision_options

    layer = nn.Dense(48, **dense_precision_options(jnp.float64))
    key_x, key_p, key_c = jax.random.split(jax.random.PRNGKey(5), 3)
    for shape in [(64, 40), (40,), (2, 64, 40)]:
        x = jax.random.normal(key_x, shape, jnp.float64)
        c = jax.random.normal(key_c, (*shape[:-1], 48), jnp.float64)  # L = Σ c·y, so dL/dy = c
        params = layer.init(key_p, x[..., 0, :] if len(shape) == 3 else x)
        grad = jax.grad(lambda p, x, c: jnp.sum(c * layer.apply(p, x)), argnums=(0, 1))
        if len(shape) == 3:  # two lanes, one layer's parameters each
            params = jax.tree.map(lambda a: jnp.stack([a, 2 * a]), params)
            grad = jax.vmap(grad)
        compiled = jax.jit(grad).lower(params, x, c).compile()
        for dot in re.findall(r"dot\(.*", compiled.as_text()):
            batch = re.search(r"rhs_batch_dims=\{([\d,]*)\}", dot)
            n_batch = len(batch.group(1).split(",")) if batch and batch.group(1) else 0
            assert re.search(r"rhs_contracting_dims=\{(\d+)\}", dot).group(1) == str(n_batch), dot
        gp, gx = compiled(params, x, c)
        w = np.asarray(params["params"]["kernel"], np.float64)
        lanes = [(x[i], c[i], w[i], i) for i in range(2)] if len(shape) == 3 else [(x, c, w, ...)]
        for xi, ci, wi, i in lanes:
            xi, ci = np.asarray(xi), np.asarray(ci)
            rows_x, rows_c = np.atleast_2d(xi), np.atleast_2d(ci)
            for got, ref in zip((gx[i], gp["params"]["kernel"][i], gp["params"]["bias"][i]),
                                (ci @ wi.T, rows_x.T @ rows_c, rows_c.sum(0))):
                assert got.dtype == jnp.float64
                np.testing.assert_allclose(np.asarray(got), ref, rtol=1e-12, atol=1e-12)


def test_bfloat16_matmuls_round_inputs_and_weights_and_accumulate_in_float32():
    """matmul_dtype=bfloat16: each layer equals a float64 reference built from bfloat16-rounded
    input, kernel and bias (so the products are summed at >= float32 accuracy, not in bfloat16),
    parameters stay float32, and one TD3 update trains them."""
    import ml_dtypes

    bf16 = lambda a: np.asarray(np.asarray(a, np.float32).astype(ml_dtypes.bfloat16), np.float64)
    actor = Actor(LOW, HIGH, NetworkOptions(hidden=(64, 64), activation="relu", matmul_dtype=jnp.bfloat16))
    obs = jax.random.normal(jax.random.PRNGKey(1), (32, OBS))
    pa = actor.init(jax.random.PRNGKey(0), obs)
    assert all(x.dtype == jnp.float32 for x in jax.tree.leaves(pa))
    x, body = np.asarray(obs, np.float64), pa["params"]["body"]
    for name in ("dense_0", "dense_1", "head"):
        x = bf16(x) @ bf16(body[name]["kernel"]) + bf16(body[name]["bias"])
        x = np.maximum(x, 0.0) if name != "head" else x
        x = np.asarray(x, np.float32)  # the next layer sees the float32 activation
    lo, hi = np.asarray(LOW), np.asarray(HIGH)
    ref = np.tanh(x.astype(np.float64)) * (hi - lo) / 2 + (hi + lo) / 2
    got = np.asarray(jax.jit(actor.apply)(pa, obs), np.float64)
    np.testing.assert_allclose(got, ref, atol=1e-5)
    plain = np.asarray(Actor(LOW, HIGH, NetworkOptions(hidden=(64, 64), activation="relu")).apply(pa, obs), np.float64)
    assert np.max(np.abs(plain - got)) > 1e-4  # the rounding is really applied
    agent = TD3(TD3Config(hidden=(16, 16), batch_size=4), OBS, (-1.0,) * ACT, (1.0,) * ACT,
                matmul_dtype=jnp.bfloat16)
    st = agent.init(jax.random.PRNGKey(0))
    rng = np.random.default_rng(0)
    batch = replay.Transition(*(jnp.asarray(rng.normal(size=sh), jnp.float32) for sh in
                                [(4, OBS), (4, ACT), (4,), (4, OBS), (4,)]))
    st2, m = agent.update_delayed(st, batch, jax.random.PRNGKey(1), jnp.asarray(True))
    assert np.isfinite(float(m.critic_loss)) and np.isfinite(float(m.actor_loss))
    for before, after in ((st.actor, st2.actor), (st.critic, st2.critic)):
        leaves = jax.tree.leaves(after)
        assert all(x.dtype == jnp.float32 for x in leaves)
        assert not np.allclose(jax.tree.leaves(before)[0], leaves[0])


def test_unknown_activation_raises():
    agent = TD3(TD3Config(hidden=(4,), activation=ActivationConfig(name="nope")), OBS, (-1.0,), (1.0,))
    with pytest.raises(ValueError, match="valid"):
        agent.init(jax.random.PRNGKey(0))


def test_explore_and_random_action_stay_in_range():
    agent = TD3(TD3Config(hidden=(8,), expl_noise=5.0), OBS, LOW, HIGH)
    st = agent.init(jax.random.PRNGKey(0))
    a = agent.explore(st.actor, jnp.zeros((500, OBS)), jax.random.PRNGKey(1))
    r = agent.random_action(jax.random.PRNGKey(2), (500,))
    for x in (a, r):
        x = np.asarray(x)
        assert np.all(x >= np.asarray(LOW)) and np.all(x <= np.asarray(HIGH))
    r = np.asarray(r)
    np.testing.assert_allclose(r.min(0), LOW, atol=0.05)
    np.testing.assert_allclose(r.max(0), HIGH, atol=0.05)


# ------------------------------------------------------------------------------------------------
# replay
# ------------------------------------------------------------------------------------------------

def _tr(i):
    f = float(i)
    return replay.Transition(jnp.full((2,), f), jnp.full((1,), -f), jnp.asarray(f), jnp.full((2,), f + 0.5),
                             jnp.asarray(float(i % 2)))


def test_replay_wraparound_and_sampling_range():
    buf = replay.init(5, 2, 1)
    add = jax.jit(replay.add)
    for i in range(3):
        buf = add(buf, _tr(i))
    assert int(buf.size) == 3 and int(buf.ptr) == 3
    idx = np.asarray(replay.sample_indices(buf, jax.random.PRNGKey(0), 10_000))
    assert idx.min() == 0 and idx.max() == 2
    counts = np.bincount(idx, minlength=3)
    assert np.all(np.abs(counts / 10_000 - 1 / 3) < 0.03)
    for i in range(3, 7):  # 7 inserted into 5 slots: slots hold 5, 6, 2, 3, 4
        buf = add(buf, _tr(i))
    assert int(buf.size) == 5 and int(buf.ptr) == 2
    np.testing.assert_array_equal(np.asarray(buf.data.reward), [5, 6, 2, 3, 4])
    np.testing.assert_array_equal(np.asarray(buf.data.next_obs[:, 0]), [5.5, 6.5, 2.5, 3.5, 4.5])
    np.testing.assert_array_equal(np.asarray(buf.data.terminated), [1, 0, 0, 1, 0])
    batch = replay.sample(buf, jax.random.PRNGKey(1), 4000)
    assert set(np.asarray(batch.reward).astype(int)) == {2, 3, 4, 5, 6}
    # rows stay aligned: obs, action, next_obs of a sampled row all belong to the same transition
    np.testing.assert_array_equal(np.asarray(batch.obs[:, 0]), np.asarray(batch.reward))
    np.testing.assert_array_equal(np.asarray(batch.action[:, 0]), -np.asarray(batch.reward))
    assert buf.ptr.dtype == jnp.int32 and not buf.ptr.weak_type
