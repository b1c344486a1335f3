#!/bin/bash
# The float32 study (issue 48) on a machine whose ~/swim-runs is gone: venv, worktrees, study files,
# the finished cells adopted from runs/curated (so they are not trained again), then the driver.
# Idempotent: on a machine that has some of it, it does the rest. Since 2026-12-07 12:40 it starts
# run-f32-i (the 1M Walker2d cells in pieces that each finish within a session, ReLU first in each
# 2-seed piece; the script says why; run-f32-h before it, the same cells in another order).
#   bash docs/notebook/scripts/study-f32-setup-20261207.sh [--no-start]
set -euo pipefail
start=${1:-start}
R=$(cd "$(dirname "$0")/../../.." && pwd)   # the repository
S=$HOME/swim-study
[ -x "$R/.venv/bin/python" ] || (cd "$R" && python3 -m venv .venv && .venv/bin/pip install -q -c requirements.lock -e '.[test]')
mkdir -p "$S" "$HOME/swim-runs"
git -C "$R" worktree prune
for wt in src:ccc3cbb src-b:44af3ff src-t2:644b99b; do
  [ -d "$S/${wt%%:*}" ] || git -C "$R" worktree add -q --detach "$S/${wt%%:*}" "${wt##*:}"
done
[ -e "$S/venv" ] || ln -s "$R/.venv" "$S/venv"   # one venv: the lock's versions are the same at every study commit
cp "$R"/configs/studies/*.yaml "$S/"
running=$(pgrep -f "run-f32-[a-z]\.sh" || true)
[ -n "$running" ] || cp "$R/docs/notebook/scripts/run-f32-i-20261207.sh" "$S/run-f32-i.sh"  # (never under a running driver)
cd "$R"
for pair in f32-table2:study-f32 f32-walker-v4:study-f32-walker-v4 f32-walker-1m-s01:study-f32-walker-1m/s01 \
            f32-walker-1m-s23:study-f32-walker-1m/s23 f32-walker-1m-s4:study-f32-walker-1m/s4 \
            f32-walker-relu-seeds5-9:study-f32-seeds5-9 f32-walker-v4-seeds5-9:study-f32-walker-v4-seeds5-9 \
            table2-walker-swim-bf16:study-table2-walker-swim-bf16; do
  d=runs/curated/${pair##*:}
  [ -d "$d" ] && .venv/bin/python -m swim_jax.study "configs/studies/${pair%%:*}.yaml" --adopt "$d"
done
[ "$start" = --no-start ] && exit 0
[ -n "$running" ] && { echo "the driver runs already (pid $running)"; exit 0; }
cd "$S" && nohup ./run-f32-i.sh >> "$HOME/swim-runs/study-f32.log" 2>&1 &
echo "driver started; log: ~/swim-runs/study-f32.log"
