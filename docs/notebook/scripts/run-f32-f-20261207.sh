#!/bin/bash
# 2026-12-07 (fifth session, 05:50): a new machine (same Xeon model, "XE"; ~/swim-runs was gone).
# The finished 300k cells were copied back from runs/curated (config.yaml, evaluations, timing.json and
# final_policy.npz are what the study counts as done), so the study files skip them. cheetah_relu (at
# 57k on the old machine) starts again from 0. Order: the 300k cells left (cheetah_relu, Swimmer x 3),
# then Walker2d-v5 x 3 from 0 to 1M (44af3ff), then the ReLU seeds 5-9 (v5, v4), then Table II's
# bfloat16 walker_swim (644b99b).
S=$HOME/swim-study
cd $S/src || exit 1
for f in f32-walker-v4 f32-table2; do $S/venv/bin/python -m swim_jax.study $S/$f.yaml || exit $?; done
cd $S/src-b || exit 1
$S/venv/bin/python -m swim_jax.study $S/f32-walker-1m.yaml || exit $?
cd $S/src || exit 1
for f in f32-walker-relu-seeds5-9 f32-walker-v4-seeds5-9; do $S/venv/bin/python -m swim_jax.study $S/$f.yaml || exit $?; done
cd $S/src-t2 || exit 1
$S/venv/bin/python -m swim_jax.study $S/table2-walker-swim-bf16.yaml
