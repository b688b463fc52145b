#!/bin/bash
# Issue 20 figures on the hardware GPU machine (H200, 16 cores), from the repository root
# with the release binary built (target/release/bearing-sweep) and the Vulkan driver
# installed (as for reports/h100/run-bench-and-sweeps.sh). Outputs under $OUT.
# Time bounds: 60 + 110 s (each command under `timeout`); ~2.5 min in all.
#
# What each output is and where it goes in BENCHMARKS.md (section "Issue 20: cost at the
# default accuracy", a new "H200" paragraph):
#  finite-bench-h200.md  1st table: PSOR vs multigrid per state, one thread, explicit grids;
#                        2nd table: states/s, CPU 16 threads, explicit grids 32x8..128x32,
#                        accuracy 5e-4 (default) and 1e-4, errors against the ladder's
#                        1024x128 extrapolated reference; GPU rows: the PSOR kernel on the
#                        explicit grids (accuracy mode has no GPU kernel yet: it runs on the
#                        CPU, so its CPU rows are the figures for a GPU machine too);
#                        3rd table: paper rotor 0.002 s, short vs finite film.
#  fin1024-default.txt   wall of a 1024-variant finite-film sweep (clearance x viscosity
#                        32 x 32, paper rotor, t_end 0.0005 s) at the default accuracy 5e-4,
#                        CPU backend, 16 threads; simulation_wall_s from the result (on the
#                        loaded 2-core VM a 2 x 2 version took 4.9 s: 1024 variants there
#                        would be ~1250 s; variants done by the timeout are in
#                        result.jsonl, counted below). The GPU backend is not run: accuracy
#                        mode has no GPU kernel yet and would fall back to these CPU threads.
set -u
B=${B:-target/release/bearing-sweep}
OUT=${OUT:-/tmp/finite-h200}
mkdir -p "$OUT"
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
{ lscpu | grep 'Model name'; nproc; nvidia-smi -L 2>&1; } > "$OUT/machine.txt"

BEARING_SWEEP_REQUIRE_GPU=1 timeout 60 "$B" finite --bench --gpu --states 64 --reps 3 \
  --rotor-t-end 0.002 > "$OUT/finite-bench-h200.md" 2>&1
echo "bench rc $?"

python3 - <<'PY'
import json
f = json.load(open('sweeps/finite-film.json'))
f['name'] = 'finite 32x32 default accuracy'
f['axes'] = [{'path': 'bearings[*].clearance', 'logspace': [0.0002, 0.0006, 32]},
             {'path': 'bearings[*].viscosity', 'logspace': [0.01, 0.05, 32]}]
for b in f['base']['bearings']:
    b['model'] = 'finite'
    b.pop('finite', None)          # the default accuracy 5e-4
f['base']['integrator']['t_end'] = 0.0005   # ~40 s expected on 16 cores (below)
json.dump(f, open('/tmp/fin1024-default.json', 'w'))
PY
( /usr/bin/time -f "cpu16 finite default accuracy: %e s wall, %M KB" timeout 110 \
  "$B" run /tmp/fin1024-default.json --backend cpu --out /tmp/fin1024-default --quiet ) \
  > "$OUT/fin1024-default.txt" 2>&1
echo "sweep rc $?"
python3 -c "
import json,glob
r=json.load(open(glob.glob('/tmp/fin1024-default/*/result.json')[0]))
ok=sum(1 for v in r['variants'] if v.get('status')=='ok')
print('variants', len(r['variants']), 'ok', ok, 'simulation_wall_s', r['run']['simulation_wall_s'])
" >> "$OUT/fin1024-default.txt" 2>&1
wc -l /tmp/fin1024-default/*/result.jsonl >> "$OUT/fin1024-default.txt" 2>&1
cat "$OUT/fin1024-default.txt"
