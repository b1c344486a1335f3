#!/bin/bash
# 2026-12-07 (sixth session, 08:45): a new machine again, an AMD EPYC Zen 4 ("Z4": avx512f,
# avx512_bf16, no AMX); ~/swim-runs was gone, swimmer_relu (a few k) lost. Two machine changes in
# three hours: a cell that needs longer than one machine's life is lost whole, and a 1M Walker2d cell
# needs ~2.8 h of an idle XE, longer on a Z4. So the 300k cells, which finish within a session and are
# curated as they finish, go first; the 1M cells go last and finish on a machine that lives long enough.
# Order: swimmer_relu (ccc3cbb), walker_relu seeds 5-9 v5 then v4 (ccc3cbb), Table II's bfloat16
# walker_swim (644b99b), Walker2d-v5 x 3 to 1M from 0 (44af3ff).
S=$HOME/swim-study
cd $S/src || exit 1
for f in f32-walker-v4 f32-table2 f32-walker-relu-seeds5-9 f32-walker-v4-seeds5-9; do
  $S/venv/bin/python -m swim_jax.study $S/$f.yaml || exit $?
done
cd $S/src-t2 || exit 1
$S/venv/bin/python -m swim_jax.study $S/table2-walker-swim-bf16.yaml || exit $?
cd $S/src-b || exit 1
$S/venv/bin/python -m swim_jax.study $S/f32-walker-1m.yaml
