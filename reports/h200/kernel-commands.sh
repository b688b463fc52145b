#!/bin/bash
# Issue 26 items 2-3 on a hardware GPU (written for the H200 host: 16 cores, no network, no
# Rust): the short-film kernel with LANES invocations per state, the dispatcher's slots,
# fence wait and merge policy, against the 16-thread CPU on the 4 096-variant sweep, and
# `bench backend` (latency at a sweep-sized dispatch, throughput at 1e5 and 1e6 states,
# % of the FP64 peak).
# Run from the repository root:  bash reports/h200/kernel-commands.sh [BINARY] [OUTDIR]
# BINARY defaults to target/release/bearing-sweep; OUTDIR to $OUT/raw/kernel. Three files
# come back: machine.txt, sweeps.txt, backend.md. Device time ~1.5-2 minutes (each command
# bounded by `timeout`). An older binary ignores the BEARING_SWEEP_GPU_* variables below:
# run it with the same script for the baseline (its rows then all show the old kernel).
# If the Vulkan loader is missing: for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
# SIDE, TEND, SIZES shrink it for a dry run on a small machine (defaults: 64, 0.1 s,
# 1450,100000,1000000).
set -u
SIDE=${SIDE:-64}; TEND=${TEND:-0.1}; SIZES=${SIZES:-1450,100000,1000000}
B=${1:-target/release/bearing-sweep}
O=${2:-${OUT:-/tmp/h200-kernel}/raw/kernel}
mkdir -p "$O"
export XDG_RUNTIME_DIR=$(mktemp -d)
[ -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ] && export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
W=$(mktemp -d)
{ nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm --format=csv; lscpu | grep -E '^CPU\(s\)|Model name'; $B --version; } > "$O/machine.txt" 2>&1
# The 4 096-variant short-film sweep of reports/h100 and reports/h200/gpu-commands.sh.
python3 - "$W" "$SIDE" "$TEND" <<'PY'
import json, sys
d = json.load(open('sweeps/clearance-viscosity.json'))
n = int(sys.argv[2])
d['axes'][0]['logspace'][2] = n; d['axes'][1]['logspace'][2] = n
d['base']['integrator']['t_end'] = float(sys.argv[3])
json.dump(d, open(sys.argv[1] + '/cv4096.json', 'w'))
PY
# Largest relative difference of every reduction (not times) between two runs.
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
print('  vs', sys.argv[2].split('/')[-1], ': variants', len(va), 'ok', ok(a), ok(c), 'max rel diff (values, not times)', worst, where)
PY
report() { python3 - "$1" <<'PY'
import json, glob, sys
r = json.load(open(glob.glob(sys.argv[1] + '/*/result.json')[0]))
s = r['run']['simulator']
print('  ', sys.argv[1].split('/')[-1], 'simulation_wall_s', r['run']['simulation_wall_s'], 'backend', s.get('name'), 'threads', s.get('variant_threads'))
g = s.get('gpu_dispatch')
if g:
    keys = ['dispatches', 'states_per_dispatch', 'slots', 'max_in_flight', 'lingered', 'device_busy_s', 'span_s', 'device_idle_fraction', 'host_us_per_variant_stage', 'wall_s']
    print('   gpu_dispatch', {k: g.get(k) for k in keys})
    if g.get('dispatches'): print('   ms per dispatch (busy / dispatches)', 1e3 * g['device_busy_s'] / g['dispatches'])
PY
}
run() { name=$1; shift; ( /usr/bin/time -f "$name: %e s wall, %M KB" timeout 60 "$@" --quiet ) 2>&1 | grep -v "^plot"; }
export RAYON_NUM_THREADS=16
# 1. The CPU on 16 threads: the goal's reference (GPU >= 3x this).
run cpu16 $B run $W/cv4096.json --backend cpu --out $W/cpu16 | tee -a "$O/sweeps.txt"
report $W/cpu16 | tee -a "$O/sweeps.txt"
# 2. The GPU: lanes per state, dispatch slots, wait (block on the fence or spin) and merge
#    policy (off, or wait up to T µs for M requests). L1 S1 block off is the old kernel's
#    organisation; L4 S1 block off is the new default. The early run (raw/kernel-early/)
#    showed 2 slots hurting and lanes barely mattering: ~0.24 ms fixed cost per dispatch.
for cfg in 1:1:block:off 4:1:block:off 16:1:block:off 4:1:spin:off 4:1:block:12:200 4:1:block:16:400 4:1:spin:16:400; do
  IFS=: read L S WAIT M T <<< "$cfg"; MERGE=$M${T:+:$T}; n=gpu-L$L-S$S-$WAIT-merge${MERGE/:/x}
  BEARING_SWEEP_GPU_LANES=$L BEARING_SWEEP_GPU_SLOTS=$S BEARING_SWEEP_GPU_WAIT=$WAIT BEARING_SWEEP_GPU_MERGE=$MERGE \
    run $n $B run $W/cv4096.json --backend gpu --out $W/$n | tee -a "$O/sweeps.txt"
  report $W/$n | tee -a "$O/sweeps.txt"
  python3 $W/cmp.py $W/$n $W/cpu16 | tee -a "$O/sweeps.txt"
done
# 3. Film loads alone: a sweep-sized dispatch (1 450 states: latency), 1e5 and 1e6 states
#    (throughput; goal 2e7 states/s end to end, kernel >= 10 % of the 34 TFLOP/s FP64 peak).
export BEARING_SWEEP_PEAK_GFLOPS=34000
echo "## bench backend, default lanes (CPU and GPU)" >> "$O/backend.md"
timeout 90 $B bench backend --backend both --threads 16 --sizes $SIZES --min-time 0.5 --max-reps 5 >> "$O/backend.md" 2>&1
for L in 1 16; do
  echo "## bench backend, BEARING_SWEEP_GPU_LANES=$L" >> "$O/backend.md"
  BEARING_SWEEP_GPU_LANES=$L timeout 60 $B bench backend --backend gpu --threads 16 --sizes $SIZES --min-time 0.5 --max-reps 5 >> "$O/backend.md" 2>&1
done
grep -E "^## |^- .gpu|^\| (cpu|gpu)" "$O/backend.md"
ls "$O"
