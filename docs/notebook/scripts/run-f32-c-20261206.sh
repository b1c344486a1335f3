#!/bin/bash
# 2026-12-06 (second session): after walker_relu's 300k cell (run by run-f32-b.sh's first study, pid
# given as $1), SAC's learning check (issue 49, from the src-c worktree), then the float32 study's
# remaining cells in run-f32-b.sh's order.
while kill -0 "$1" 2>/dev/null; do sleep 30; done
cd $HOME/swim-study/src-c || exit 1
$HOME/swim-study/venv/bin/python -m swim_jax.study configs/studies/sac-check.yaml || exit $?
cd $HOME/swim-study/src || exit 1
for f in f32-walker-300k f32-table2 f32-walker-v4; do
  $HOME/swim-study/venv/bin/python -m swim_jax.study $HOME/swim-study/$f.yaml || exit $?
done
cd $HOME/swim-study/src-b || exit 1
$HOME/swim-study/venv/bin/python -m swim_jax.study $HOME/swim-study/f32-walker-1m.yaml
