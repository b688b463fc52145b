#!/bin/bash
# Session 39's hardware-GPU run (issue 20's figures: the finite film's multigrid kernel at the
# default accuracy and at 1e-4 on a hardware GPU), one device call of < 9.5 minutes at worst
# (~4 expected). Every command is under `timeout` (90 s for the 64-state benchmark, 60 s for
# each GPU test binary, none started after 150 s; 120 s for the big benchmark, not started
# after 300 s; 2 x 45 s for the finite-film rotor sweep; 2 x 30 s for the short-film sweep,
# not started after 420 s).
#
# The release binary of main (BIN, default .devbin/bearing-sweep-s39.xz) and the GPU test
# binaries (.devbin/t-*.xz) are built on the 2-core VM, stripped, xz-compressed and carried
# (with .gl, the Vulkan loader's .debs) by the device tool. Usage there, from the repository
# root (OUT set by the tool):
#   bash reports/h200/run39.sh
# A dry run on the VM (lavapipe, small sizes; the binaries of target/release):
#   LOCAL=1 STATES=4 BIG=8 SIDE=2 CVSIDE=4 THREADS=2 OUT=/tmp/run39 bash reports/h200/run39.sh
#
# Outputs (raw, under $OUT/raw39/), and where they go in BENCHMARKS.md ("Issue 20: the
# multigrid kernel on a hardware GPU (session 39)"):
#  machine.txt       GPU, driver, CPU model and count, binary version, sizes, elapsed times.
#  gpu-tests.txt     the GPU test binaries with BEARING_SWEEP_REQUIRE_GPU=1 (the kernels
#                    against the CPU on this hardware: multigrid, ladder rule, resumable
#                    kernel, JFO kernel, the short-film backend suite).
#  finite-64.md      `finite --bench --gpu --states 64 --reps 3`: states/s of the paper
#                    bearing's states, "cpu (16 thread(s))" against "gpu (...)" rows at
#                    32x8/64x16 (PSOR kernel), 128x32 (multigrid kernel), accuracy 5e-4
#                    (the default) and 1e-4; errors against the 1024x128 Richardson
#                    reference, equal on both backends. Comparable with session 32's H200
#                    table (64 states per call).
#  finite-big.md     the same with BIG states per call (1024): enough workgroups to fill
#                    the GPU's 132 multiprocessors (one workgroup per state).
#  fin-sweep.txt     a SIDE x SIDE finite-film rotor sweep (sweeps/finite-film.json with
#                    every bearing "finite" at the default accuracy, t_end 0.02 s) on
#                    --backend gpu and --backend cpu (THREADS threads): walls, variants
#                    ok, the largest relative difference of the reductions.
#  cv-sweep.txt      the 4 096-variant short-film sweep (issue 26's workload) on both
#                    backends, only if the elapsed time allows (context: issue 26 ended
#                    blocked on it).
set -u
STATES=${STATES:-64}; BIG=${BIG:-1024}; SIDE=${SIDE:-16}; CVSIDE=${CVSIDE:-64}; THREADS=${THREADS:-16}
O="${OUT:-/tmp/run39}/raw39"; mkdir -p "$O"
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
if [ -z "${LOCAL:-}" ]; then
  for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
  [ -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ] && export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
  mkdir -p /tmp/b39
  for x in .devbin/*.xz; do n=$(basename "${x%.xz}"); xz -dc "$x" > /tmp/b39/$n; chmod +x /tmp/b39/$n; done
  B=/tmp/b39/bearing-sweep-s39
  TESTS=$(ls /tmp/b39/t-* 2>/dev/null)
else
  B=$PWD/target/release/bearing-sweep
  TESTS=${TESTS:-}
fi
export BEARING_SWEEP_CACHE_DIR=$(mktemp -d)   # a private calibration cache
W=$(mktemp -d)
T0=$(date +%s)
el() { echo $(( $(date +%s) - T0 )); }
{ nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm --format=csv 2>&1
  lscpu | grep -E '^CPU\(s\)|Model name'; "$B" --version
  echo "STATES=$STATES BIG=$BIG SIDE=$SIDE CVSIDE=$CVSIDE THREADS=$THREADS"; } > "$O/machine.txt" 2>&1
cat "$O/machine.txt"

# 1. The finite film's benchmark, 64 states per call (session 32's size).
echo "== finite bench $STATES (t = $(el) s)"
RAYON_NUM_THREADS=$THREADS BEARING_SWEEP_REQUIRE_GPU=1 timeout 90 "$B" finite --bench --gpu \
  --states "$STATES" --reps 3 --rotor-t-end 0.0002 > "$O/finite-64.md" 2>&1
echo "finite bench rc $?" | tee -a "$O/finite-64.md"
grep "^| \(cpu\|gpu\)" "$O/finite-64.md" | sed 's/(Vulkan[^)]*)//'
# 2. The GPU tests on this hardware (each under 60 s; none started after 150 s).
echo "== gpu tests (t = $(el) s)"
for t in $TESTS; do
  [ "$(el)" -lt 150 ] || { echo "--- $(basename $t): not run (time)" >> "$O/gpu-tests.txt"; continue; }
  echo "--- $(basename $t)" >> "$O/gpu-tests.txt"
  BEARING_SWEEP_REQUIRE_GPU=1 timeout 60 "$t" --test-threads 4 >> "$O/gpu-tests.txt" 2>&1
  echo "rc $? (t = $(el) s)" >> "$O/gpu-tests.txt"
done
grep -E "^---|test result|^rc|FAILED|panicked" "$O/gpu-tests.txt"

# 3. The same with BIG states per call (none started after 300 s).
if [ "$(el)" -lt 300 ]; then
echo "== finite bench $BIG (t = $(el) s)"
RAYON_NUM_THREADS=$THREADS BEARING_SWEEP_REQUIRE_GPU=1 timeout 120 "$B" finite --bench --gpu \
  --states "$BIG" --reps 2 --rotor-t-end 0.0002 > "$O/finite-big.md" 2>&1
echo "finite bench rc $?" | tee -a "$O/finite-big.md"
grep "^| \(cpu\|gpu\)" "$O/finite-big.md" | sed 's/(Vulkan[^)]*)//'
fi

# 4. Rotor sweeps on both backends: the finite film at the default accuracy, then the short film.
cat > "$W/cmp.py" <<'PY'
import json, sys, glob
def load(d):
    return json.load(open(glob.glob(d + '/*/result.json')[0]))
a, c = load(sys.argv[1]), load(sys.argv[2])
va = {v['id']: v for v in a['variants']}; vc = {v['id']: v for v in c['variants']}
worst, where = 0.0, None
def walk(x, y, p):
    global worst, where
    if isinstance(x, dict):
        for k in x:
            if k in ('t_s', 'stats', 'series', 'wall_time_s'): continue
            if k in y: walk(x[k], y[k], p + '.' + k)
    elif isinstance(x, list):
        for i, (u, v) in enumerate(zip(x, y)): walk(u, v, p + '[%d]' % i)
    elif isinstance(x, (int, float)) and isinstance(y, (int, float)) and not isinstance(x, bool):
        d = abs(x - y) / abs(y) if y != 0 else abs(x)
        if d > worst: worst, where = d, (p, x, y)
for i in va:
    if i in vc: walk(va[i], vc[i], 'v%d' % i)
ok = lambda r: sum(1 for v in r['variants'] if v.get('status') == 'ok')
print('variants', len(va), 'ok gpu', ok(a), 'ok cpu', ok(c),
      'max rel diff (values, not times)', worst, where)
for name, r in (('gpu', a), ('cpu', c)):
    s = r['run']['simulator']
    print(name, 'simulation_wall_s', r['run']['simulation_wall_s'], 'backend', s.get('name'),
          'threads', s.get('variant_threads'))
    if s.get('gpu_dispatch'): print('gpu_dispatch', json.dumps(s['gpu_dispatch']))
PY
python3 - "$W" "$SIDE" "$CVSIDE" <<'PY'
import json, sys
w, n, m = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
f = json.load(open('sweeps/finite-film.json'))
f['name'] = 'finite %dx%d default accuracy' % (n, n)
f['axes'] = [{'path': 'bearings[*].clearance', 'logspace': [0.0002, 0.0006, n]},
             {'path': 'bearings[*].viscosity', 'logspace': [0.01, 0.05, n]}]
for b in f['base']['bearings']:
    b['model'] = 'finite'
    b.pop('finite', None)          # the default accuracy 5e-4
f['base']['integrator']['t_end'] = 0.02   # 256 variants: ~6 s on 16 CPU threads (0.4 s a variant on the VM)
f['base']['integrator']['sample_interval'] = 1e-4
json.dump(f, open(w + '/fin.json', 'w'))
d = json.load(open('sweeps/clearance-viscosity.json'))
d['axes'][0]['logspace'][2] = m; d['axes'][1]['logspace'][2] = m
d['base']['integrator']['t_end'] = 0.1
json.dump(d, open(w + '/cv.json', 'w'))
PY
run() { name=$1; lim=$2; shift 2; ( /usr/bin/time -f "$name: %e s wall, %M KB" timeout $lim "$@" --quiet ) 2>&1 | grep -v "^plot"; echo "$name rc ${PIPESTATUS[0]}"; }
echo "== finite sweep (t = $(el) s)"
RAYON_NUM_THREADS=$THREADS BEARING_SWEEP_REQUIRE_GPU=1 run fin-gpu 45 "$B" run "$W/fin.json" --backend gpu --out "$W/fg" | tee -a "$O/fin-sweep.txt"
RAYON_NUM_THREADS=$THREADS run fin-cpu 45 "$B" run "$W/fin.json" --backend cpu --out "$W/fc" | tee -a "$O/fin-sweep.txt"
wc -l "$W"/f?/*/result.jsonl 2>&1 | tee -a "$O/fin-sweep.txt"   # variants finished (if a run timed out)
python3 "$W/cmp.py" "$W/fg" "$W/fc" 2>&1 | tee -a "$O/fin-sweep.txt"
if [ "$(el)" -lt 420 ]; then
  echo "== short sweep (t = $(el) s)"
  RAYON_NUM_THREADS=$THREADS BEARING_SWEEP_REQUIRE_GPU=1 run cv-gpu 30 "$B" run "$W/cv.json" --backend gpu --out "$W/g" | tee -a "$O/cv-sweep.txt"
  RAYON_NUM_THREADS=$THREADS run cv-cpu 30 "$B" run "$W/cv.json" --backend cpu --out "$W/c" | tee -a "$O/cv-sweep.txt"
  python3 "$W/cmp.py" "$W/g" "$W/c" 2>&1 | tee -a "$O/cv-sweep.txt"
fi
echo "== total $(el) s" | tee -a "$O/machine.txt"
ls -l "$O"
