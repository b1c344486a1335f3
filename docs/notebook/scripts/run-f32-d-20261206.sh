#!/bin/bash
# 2026-12-06 (second session, 21:00): after SAC's learning check (pid $1, started by run-f32-c.sh),
# the Walker2d-v4 ReLU cell first (the float32 Walker2d-v5 ReLU sits below Tianshou's TD3 at 300k:
# v4 against v5 is the next test of why), then the other envs' 300k cells, then Walker2d to 1M.
# 2026-12-06 23:07: "0 means no pid to wait for" did not hold: `kill -0 0` signals our own process
# group and succeeds, so the loop waited forever; the guard below skips the wait for 0 (or no argument).
while [ "${1:-0}" != 0 ] && kill -0 "$1" 2>/dev/null; do sleep 30; done
cd $HOME/swim-study/src || exit 1
for f in f32-walker-v4 f32-table2; do
  $HOME/swim-study/venv/bin/python -m swim_jax.study $HOME/swim-study/$f.yaml || exit $?
done
cd $HOME/swim-study/src-b || exit 1
$HOME/swim-study/venv/bin/python -m swim_jax.study $HOME/swim-study/f32-walker-1m.yaml
