#!/bin/bash
# Issue 26 on a hardware GPU (written for the H200 host: 16 cores, no network, no Rust).
# Run from the repository root:  bash reports/h200/gpu-commands.sh [BINARY] [OUTDIR]
# BINARY defaults to target/release/bearing-sweep (built on the 2-core machine and
# carried); OUTDIR to $OUT or /tmp/h200-gpu. Run it once with the new binary and once
# with the old one (same machine, same script) for the baseline. Total ~1-2 minutes.
# If the Vulkan loader is missing: for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
# SIDE, TEND and SIZES shrink it for a dry run on a small machine (defaults: the H100 runs).
set -u
SIDE=${SIDE:-64}; TEND=${TEND:-0.1}; SIZES=${SIZES:-100000,1000000}
B=${1:-target/release/bearing-sweep}
O=${2:-${OUT:-/tmp/h200-gpu}}
mkdir -p "$O"
export XDG_RUNTIME_DIR=$(mktemp -d)
# A private calibration cache, so that `auto` measures on this machine (issue 26, item 3).
export BEARING_SWEEP_CACHE_DIR=$(mktemp -d)
W=$(mktemp -d)
{ nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm --format=csv; lscpu | grep -E '^CPU\(s\)|Model name'; $B --version; } > "$O/machine.txt" 2>&1
# The 4 096-variant short-film sweep of reports/h100/run-bench-and-sweeps.sh.
python3 - "$W" "$SIDE" "$TEND" <<'PY'
import json, sys
d = json.load(open('sweeps/clearance-viscosity.json'))
n = int(sys.argv[2])
d['axes'][0]['logspace'][2] = n; d['axes'][1]['logspace'][2] = n
d['base']['integrator']['t_end'] = float(sys.argv[3])
json.dump(d, open(sys.argv[1] + '/cv4096.json', 'w'))
PY
cat > "$W/cmp.py" <<'PY'
import json,sys,glob
a=json.load(open(glob.glob(sys.argv[1]+'/*/result.json')[0])); c=json.load(open(glob.glob(sys.argv[2]+'/*/result.json')[0]))
va={v['id']:v for v in a['variants']}; vc={v['id']:v for v in c['variants']}
worst=0; where=None
def walk(x,y,p):
    global worst,where
    if isinstance(x,dict):
        for k in x:
            if k in ('t_s','stats','series','wall_time_s'): continue
            if k in y: walk(x[k],y[k],p+'.'+k)
    elif isinstance(x,list):
        for i,(u,v) in enumerate(zip(x,y)): walk(u,v,p+'[%d]'%i)
    elif isinstance(x,(int,float)) and isinstance(y,(int,float)) and not isinstance(x,bool):
        d=abs(x-y)/abs(y) if y!=0 else abs(x)
        if d>worst: worst=d; where=(p,x,y)
for i in va: walk(va[i],vc[i],'v%d'%i)
ok=lambda r: sum(1 for v in r['variants'] if v.get('status')=='ok')
print('variants', len(va), 'ok', ok(a), ok(c), 'max rel diff (values, not times)', worst, where)
PY
report() { python3 - "$1" <<'PY'
import json, glob, sys
r = json.load(open(glob.glob(sys.argv[1] + '/*/result.json')[0]))
s = r['run']['simulator']
print(sys.argv[1], 'simulation_wall_s', r['run']['simulation_wall_s'], 'backend', s.get('name'),
      'threads', s.get('variant_threads'), 'choice', json.dumps(s.get('backend_choice')))
if s.get('gpu_dispatch'): print('gpu_dispatch', json.dumps(s['gpu_dispatch']))
PY
}
run() { name=$1; shift; ( /usr/bin/time -f "$name: %e s wall, %M KB" timeout 120 "$@" --quiet ) 2>&1 | grep -v "^plot"; }
# 1. The sweep on the GPU and on the 16-thread CPU (issue goal: GPU >= 3x CPU).
RAYON_NUM_THREADS=16 run gpu16 $B run $W/cv4096.json --backend gpu --out $W/g16 | tee -a "$O/sweeps.txt"
RAYON_NUM_THREADS=16 run cpu16 $B run $W/cv4096.json --backend cpu --out $W/c16 | tee -a "$O/sweeps.txt"
# 2. Reductions GPU vs CPU (within the integrator tolerance), and the GPU host report.
python3 $W/cmp.py $W/g16 $W/c16 | tee -a "$O/sweeps.txt"
for d in $W/g16 $W/c16; do report $d; done | tee -a "$O/sweeps.txt"
# 3. `auto` from a fresh calibration: its choice, reason and wall time.
RAYON_NUM_THREADS=16 run auto16 $B run $W/cv4096.json --out $W/a16 | tee -a "$O/sweeps.txt"
report $W/a16 | tee -a "$O/sweeps.txt"
cat $BEARING_SWEEP_CACHE_DIR/*.json > "$O/calibration.json" 2>/dev/null
# 4. Film loads alone at 1e6 states, 16 threads (goal: GPU end to end >= 2e7 states/s;
#    kernel GFLOP/s against the 34 TFLOP/s FP64 peak).
timeout 120 $B bench backend --threads 16 --sizes $SIZES --min-time 1 --max-reps 5 > "$O/backend.md" 2>&1
grep "^| \(cpu\|gpu\)" "$O/backend.md"
ls "$O"
