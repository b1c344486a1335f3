#!/bin/bash
# 2026-12-07 (seventh session, 12:40), Z4 (AMD EPYC family 25 model 17). As run-f32-h, but each
# 2-seed piece trains its walker_relu first (`--cell walker_relu`, then the rest of the piece): after
# s01's ReLU, Walker2d ReLU has 3 seeds at 1M (0, 1, 4), enough for item 5's comparison with
# published TD3 at 1M (`published --pool --at-step 1000000`), the gap issue 48 asks to explain.
# The cells and their budgets are run-f32-h's; only the order changed.
# Order: what is left of the 300k cells, s4 (1 lane), s01 and s23 (2 lanes; ReLU first), the ReLU
# seeds 5-9 (v5, v4; ccc3cbb), Table II's bfloat16 walker_swim (644b99b).
S=$HOME/swim-study
py=$S/venv/bin/python
cd $S/src || exit 1
for f in f32-walker-v4 f32-table2; do $py -m swim_jax.study $S/$f.yaml || exit $?; done
cd $S/src-b || exit 1
$py -m swim_jax.study $S/f32-walker-1m-s4.yaml || exit $?
for f in f32-walker-1m-s01 f32-walker-1m-s23; do
  d=$HOME/swim-runs/study-$f/walker_relu   # the cell's folder (the file's out_dir), its log as the study writes it
  mkdir -p $d && echo "[$(date +%T)] $f walker_relu first: started (log $d/train.log)"
  $py -m swim_jax.study $S/$f.yaml --cell walker_relu >> $d/train.log 2>&1 || exit $?
  $py -m swim_jax.study $S/$f.yaml || exit $?
done
cd $S/src || exit 1
for f in f32-walker-relu-seeds5-9 f32-walker-v4-seeds5-9; do $py -m swim_jax.study $S/$f.yaml || exit $?; done
cd $S/src-t2 || exit 1
$py -m swim_jax.study $S/table2-walker-swim-bf16.yaml
