#!/bin/bash
# The next hardware-GPU run for issues 26 and 20 (written for the H200 host: 16 cores, no
# network, no Rust), one device call of < 8 minutes: every command is under `timeout`
# (120 + 150 + 150 s at most, ~7 min; the H200 runs of session 32 took ~30 s for the
# finite benchmark and ~35 + ~12 s for the sweep on an H100).
#
# Run from the repository root with the release binary (B, default
# target/release/bearing-sweep) and the Vulkan driver installed (for the .gl/*.deb of
# reports/h200/run.sh: for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig):
#   bash reports/h200/next-commands.sh
# Raw outputs under $OUT/raw/next/ (OUT as the device tool sets it; else /tmp/h200-next).
#
# Sizes (environment; defaults are the hardware run's): STATES finite-film states per
# benchmark call (64), REPS timed calls per row (3), SIDE the sweep's variants per axis
# (64: 4 096 variants), TEND the sweep's simulated time, s (0.1), THREADS the CPU
# backend's threads (16). A dry run on a small machine (lavapipe):
#   STATES=4 REPS=1 SIDE=4 TEND=0.002 THREADS=2 bash reports/h200/next-commands.sh
#
# What each output is and where it goes in BENCHMARKS.md:
#  machine.txt        GPU, driver, CPU model and count, binary version.
#  finite-bench.md    `finite --bench --gpu`: 2nd table, states/s of the paper bearing's
#                     states, "cpu (N thread(s))" against "gpu (...)" rows: 128x32 (the
#                     multigrid kernel, explicit grid), accuracy 5e-4 (the default: the
#                     ladder inside the kernel, up to 1024x128 on the device since the
#                     kernel is resumable) and 1e-4; errors against the 1024x128
#                     Richardson-extrapolated reference, equal on both backends (the rows
#                     ask for loads only, so accuracy mode runs on the kernel: a "GPU
#                     notices" line under the table means a fallback). Issue 26's
#                     goal: GPU >= 20x the 16-thread CPU at the default accuracy (session
#                     32, H200: 1.2-2.1x). Section "Issue 20/26: the multigrid kernel".
#  sweeps.txt         the 4 096-variant short-film rotor sweep (sweeps/clearance-viscosity
#                     .json at 64 x 64, t_end 0.1 s, as reports/h100/) on --backend gpu and
#                     --backend cpu with THREADS threads: wall times (issue 26's goal: GPU
#                     >= 3x the 16-thread CPU; H100 before issue 26: 0.33x), variants ok,
#                     the largest relative difference of the reductions (within the
#                     integrator tolerance), the GPU host report (gpu_dispatch). Section
#                     "Issue 26: GPU sweeps with the host work on all threads".
set -u
STATES=${STATES:-64}; REPS=${REPS:-3}; SIDE=${SIDE:-64}; TEND=${TEND:-0.1}; THREADS=${THREADS:-16}
B=${B:-target/release/bearing-sweep}
O="${OUT:-/tmp/h200-next}/raw/next"
mkdir -p "$O"
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
[ -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ] && export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
# A private calibration cache (the sweep names its backend; `auto` is not measured here).
export BEARING_SWEEP_CACHE_DIR=$(mktemp -d)
W=$(mktemp -d)
T0=$(date +%s)
{ nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm --format=csv 2>&1
  lscpu | grep -E '^CPU\(s\)|Model name'; "$B" --version
  echo "STATES=$STATES REPS=$REPS SIDE=$SIDE TEND=$TEND THREADS=$THREADS"; } > "$O/machine.txt" 2>&1
cat "$O/machine.txt"

# 1. The finite film: default accuracy and 128x32 on the GPU against the CPU backend.
echo "== finite bench (t = $(( $(date +%s) - T0 )) s)"
RAYON_NUM_THREADS=$THREADS BEARING_SWEEP_REQUIRE_GPU=1 timeout 120 "$B" finite --bench --gpu \
  --states "$STATES" --reps "$REPS" --rotor-t-end 0.0002 > "$O/finite-bench.md" 2>&1
echo "finite bench rc $?" | tee -a "$O/finite-bench.md"
grep "^| \(cpu\|gpu\)" "$O/finite-bench.md"

# 2. The short-film rotor sweep, GPU and CPU backends.
python3 - "$W" "$SIDE" "$TEND" <<'PY'
import json, sys
d = json.load(open('sweeps/clearance-viscosity.json'))
n = int(sys.argv[2])
d['axes'][0]['logspace'][2] = n; d['axes'][1]['logspace'][2] = n
d['base']['integrator']['t_end'] = float(sys.argv[3])
json.dump(d, open(sys.argv[1] + '/cv.json', 'w'))
PY
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
run() { name=$1; shift; ( /usr/bin/time -f "$name: %e s wall, %M KB" timeout 150 "$@" --quiet ) 2>&1 | grep -v "^plot"; echo "$name rc ${PIPESTATUS[0]}"; }
echo "== sweep gpu (t = $(( $(date +%s) - T0 )) s)"
RAYON_NUM_THREADS=$THREADS BEARING_SWEEP_REQUIRE_GPU=1 run gpu "$B" run "$W/cv.json" --backend gpu --out "$W/g" | tee -a "$O/sweeps.txt"
echo "== sweep cpu (t = $(( $(date +%s) - T0 )) s)"
RAYON_NUM_THREADS=$THREADS run cpu "$B" run "$W/cv.json" --backend cpu --out "$W/c" | tee -a "$O/sweeps.txt"
python3 "$W/cmp.py" "$W/g" "$W/c" 2>&1 | tee -a "$O/sweeps.txt"
echo "== total $(( $(date +%s) - T0 )) s" | tee -a "$O/machine.txt"
ls -l "$O"
