"""tools/bench_peers.py: the ``--ours`` row selection (command line, bad input, row mapping).

The benchmark itself runs the peers and our program for minutes and needs a second Python with torch
(see its docstring); it is run by hand (docs/BENCHMARKS.md). These tests cover what it derives from
its command line and from our benchmark's JSON."""

import os
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "tools"))
import bench_peers  # noqa: E402


def test_ours_command_puts_the_first_row_in_the_base_config_and_the_rest_in_variants():
    s = {"ours": ["native", "mjx", "native-bf16"], "lanes": 5, "steps": 300}
    cmd = bench_peers.ours_command("Walker2d-v5", s)
    assert cmd[1:4] == ["-m", "swim_jax.bench", "train"]
    text = " ".join(cmd)
    assert "--config walker_relu --lanes 5 --chunk-steps 300 --repeats 1" in text
    assert "--set env.backend=mujoco --set matmul_dtype=full" in text
    assert "--variant env.backend=mjx,matmul_dtype=full --variant env.backend=mujoco,matmul_dtype=bfloat16" in text
    assert cmd[-1] == "--no-roofline"
    only = bench_peers.ours_command("Walker2d-v5", {**s, "ours": ["native"]})
    assert "--variant" not in only


def test_our_rows_names_each_row_by_the_entry_that_produced_it():
    s = {"ours": ["native", "mjx", "native-bf16"], "lanes": 5}
    res = {"rows": [
        {"lanes": 5, "devices": 1, "variant": "", "env_steps_per_s": 300.0},
        {"lanes": 5, "devices": 1, "variant": "env.backend=mjx,matmul_dtype=full", "env_steps_per_s": 200.0},
        {"lanes": 5, "devices": 1, "variant": "env.backend=mujoco,matmul_dtype=bfloat16", "env_steps_per_s": 350.0},
        {"lanes": 1, "devices": 1, "variant": "", "env_steps_per_s": 90.0},
    ]}
    rows = bench_peers.our_rows(res, s)
    assert {k: v["env_steps_per_s"] for k, v in rows.items()} == {
        "ours-mujoco": 300.0, "ours-mjx": 200.0, "ours-mujoco-bf16": 350.0}
    assert rows["ours-mujoco"]["label"] == "swim-jax, 5 lanes, native MuJoCo, float32"
    assert rows["ours-mjx"]["label"] == "swim-jax, 5 lanes, MJX, float32"
    assert rows["ours-mujoco-bf16"]["label"] == "swim-jax, 5 lanes, native MuJoCo, bfloat16 matmuls"


@pytest.mark.parametrize("ours", ["gpu", "native,native", ",", "native,fast"])
def test_bad_ours_is_one_line_exit_2_and_nothing_written(ours, tmp_path, capsys):
    out = tmp_path / "bench"
    assert bench_peers.main(["--ours", ours, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--ours" in err[0] and "mjx, native, native-bf16" in err[0]
    assert not out.exists()
