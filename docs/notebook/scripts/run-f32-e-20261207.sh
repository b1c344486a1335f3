#!/bin/bash
# 2026-12-07 (third session, 00:15): after run-f32-d.sh (pid $1: the 300k cells, then Walker2d to 1M),
# 5 more seeds (5-9) of the float32 Walker2d ReLU cells, v5 then v4, from the code of their seeds 0-4
# (ccc3cbb), so that each has Tianshou's 10 seeds (issue 48 item 5).
while [ "${1:-0}" != 0 ] && kill -0 "$1" 2>/dev/null; do sleep 30; done
cd $HOME/swim-study/src || exit 1
for f in f32-walker-relu-seeds5-9 f32-walker-v4-seeds5-9; do
  $HOME/swim-study/venv/bin/python -m swim_jax.study $HOME/swim-study/$f.yaml || exit $?
done
# 2026-12-07 00:30: then Table II's lost bfloat16 walker_swim cell again, from 644b99b (the code of every
# Table II cell; worktree ~/swim-study/src-t2), so that the precision table has its 12th pair.
cd $HOME/swim-study/src-t2 || exit 1
$HOME/swim-study/venv/bin/python -m swim_jax.study $HOME/swim-study/table2-walker-swim-bf16.yaml
