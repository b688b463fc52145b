#!/bin/bash
# Session 32's H200 run: branch binaries (kernel = s32-kernel 7221942, mg = s32-mgwgsl), base = main 9685e34.
set -u
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
export XDG_RUNTIME_DIR=$(mktemp -d)
[ -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ] && export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
for x in kernel mg base; do [ -f .devbin/bearing-sweep-$x.xz ] && { xz -dc .devbin/bearing-sweep-$x.xz > /tmp/b-$x; chmod +x /tmp/b-$x; }; done
T0=$(date +%s); mkdir -p $OUT/raw
echo "== kernel (t=$(( $(date +%s)-T0 )))"
bash .devbin/kernel-commands.sh /tmp/b-kernel $OUT/raw/kernel > $OUT/raw/kernel.log 2>&1; tail -5 $OUT/raw/kernel.log
echo "== mg (t=$(( $(date +%s)-T0 )))"
[ -x /tmp/b-mg ] && B=/tmp/b-mg bash .devbin/mg-commands.sh > $OUT/raw/mg.log 2>&1; tail -25 $OUT/raw/mg.log
echo "== base (t=$(( $(date +%s)-T0 )))"
O=$OUT/raw/base; mkdir -p $O; W=$(mktemp -d)
python3 - "$W" <<'PY'
import json, sys
d = json.load(open('sweeps/clearance-viscosity.json'))
d['axes'][0]['logspace'][2] = 64; d['axes'][1]['logspace'][2] = 64
d['base']['integrator']['t_end'] = 0.1
json.dump(d, open(sys.argv[1] + '/cv4096.json', 'w'))
PY
export RAYON_NUM_THREADS=16
for be in gpu cpu; do ( /usr/bin/time -f "base-$be: %e s wall, %M KB" timeout 60 /tmp/b-base run $W/cv4096.json --backend $be --out $W/$be --quiet ) 2>&1 | grep -v "^plot" >> $O/sweeps.txt
python3 -c "import json,glob; r=json.load(open(glob.glob('$W/$be/*/result.json')[0])); print('base-$be simulation_wall_s', r['run']['simulation_wall_s'], r['run']['simulator'].get('gpu_dispatch'))" >> $O/sweeps.txt 2>&1; done
BEARING_SWEEP_PEAK_GFLOPS=34000 timeout 60 /tmp/b-base bench backend --backend gpu --threads 16 --sizes 1450,100000,1000000 --min-time 0.5 --max-reps 5 > $O/backend.md 2>&1
cat $O/sweeps.txt; grep "^| gpu" $O/backend.md
echo "== total $(( $(date +%s)-T0 )) s"
