#!/bin/bash
# the float32 study in the order that fits working sessions: every 300k cell first (from the ccc3cbb
# worktree, as walker_swim started), then the three Walker2d cells grown to 1M (from the src-b
# worktree, whose code grows a budget on resume: a raised total_steps)
cd $HOME/swim-study/src || exit 1
for f in f32-walker-300k f32-table2 f32-walker-v4; do
  $HOME/swim-study/venv/bin/python -m swim_jax.study $HOME/swim-study/$f.yaml || exit $?
done
cd $HOME/swim-study/src-b || exit 1
$HOME/swim-study/venv/bin/python -m swim_jax.study $HOME/swim-study/f32-walker-1m.yaml
