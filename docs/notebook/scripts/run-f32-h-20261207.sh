#!/bin/bash
# 2026-12-07 (sixth session, 09:20), Z4 (AMD EPYC family 25 model 17). The 1M Walker2d cells go in
# pieces of seeds 0-1, 2-3 and 4 (configs/studies/f32-walker-1m-s01, -s23, -s4; 44af3ff): each piece
# finishes within a session (~1.1 h for 1 lane, ~1.8 h for 2 lanes on Z4), where a whole 5-seed cell
# needs ~4 h of one machine and the machine changed twice within that time. 2 lanes (one per core)
# train at the rate of 5 (355 vs 358 env-steps/s, docs/PERFORMANCE.md: walker-1m-pieces).
# Order: what is left of the 300k cells of f32-table2 (swimmer_relu), the 1-lane pieces (s4), the
# 2-lane pieces (s01, s23), the ReLU seeds 5-9 (v5, v4; ccc3cbb), Table II's bfloat16 walker_swim (644b99b).
S=$HOME/swim-study
py=$S/venv/bin/python
cd $S/src || exit 1
for f in f32-walker-v4 f32-table2; do $py -m swim_jax.study $S/$f.yaml || exit $?; done
cd $S/src-b || exit 1
for f in f32-walker-1m-s4 f32-walker-1m-s01 f32-walker-1m-s23; do $py -m swim_jax.study $S/$f.yaml || exit $?; done
cd $S/src || exit 1
for f in f32-walker-relu-seeds5-9 f32-walker-v4-seeds5-9; do $py -m swim_jax.study $S/$f.yaml || exit $?; done
cd $S/src-t2 || exit 1
$py -m swim_jax.study $S/table2-walker-swim-bf16.yaml
