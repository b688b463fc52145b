#!/bin/bash
# Session 39's second hardware-GPU call: after the stop-bound change of the finite film's
# ladder (solver.rs simpson_stop_bound, the kernel's `estimate`/`reported`) and `auto`
# taking the CPU for finite-film sweeps. One device call of < 5 minutes at worst (~2
# expected): the kernel's GPU tests (60 s each), `finite --bench --gpu --states 1024`
# (120 s) and the 256-variant finite-film sweep under `--backend auto` (45 s). Binaries
# carried as for reports/h200/run39.sh (.devbin/*.xz, .gl). Usage there:
#   bash reports/h200/run39b.sh        (outputs under $OUT/raw39b/)
set -u
O="${OUT:-/tmp/run39b}/raw39b"; mkdir -p "$O"
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
[ -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ] && export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
mkdir -p /tmp/b39
for x in .devbin/*.xz; do n=$(basename "${x%.xz}"); xz -dc "$x" > /tmp/b39/$n; chmod +x /tmp/b39/$n; done
B=/tmp/b39/bearing-sweep-s39
export BEARING_SWEEP_CACHE_DIR=$(mktemp -d) RAYON_NUM_THREADS=16
W=$(mktemp -d); T0=$(date +%s); el() { echo $(( $(date +%s) - T0 )); }
{ nvidia-smi --query-gpu=name,driver_version --format=csv 2>&1; lscpu | grep -E '^CPU\(s\)|Model name'; } > "$O/machine.txt"
for t in /tmp/b39/t-*; do
  echo "--- $(basename $t)" >> "$O/gpu-tests.txt"
  BEARING_SWEEP_REQUIRE_GPU=1 timeout 60 "$t" --test-threads 4 >> "$O/gpu-tests.txt" 2>&1
  echo "rc $? (t = $(el) s)" >> "$O/gpu-tests.txt"
done
grep -E "^---|test result|^rc|FAILED|panicked" "$O/gpu-tests.txt"
echo "== finite bench 1024 (t = $(el) s)"
BEARING_SWEEP_REQUIRE_GPU=1 timeout 120 "$B" finite --bench --gpu --states 1024 --reps 2 \
  --rotor-t-end 0.0002 > "$O/finite-big.md" 2>&1
echo "finite bench rc $?" | tee -a "$O/finite-big.md"
grep "^| \(cpu\|gpu\)" "$O/finite-big.md" | sed 's/(Vulkan[^)]*)//'
echo "== finite sweep, --backend auto (t = $(el) s)"
python3 - "$W" <<'PY'
import json, sys
f = json.load(open('sweeps/finite-film.json'))
f['name'] = 'fin'
f['axes'] = [{'path': 'bearings[*].clearance', 'logspace': [0.0002, 0.0006, 16]},
             {'path': 'bearings[*].viscosity', 'logspace': [0.01, 0.05, 16]}]
for b in f['base']['bearings']:
    b['model'] = 'finite'; b.pop('finite', None)
f['base']['integrator']['t_end'] = 0.02; f['base']['integrator']['sample_interval'] = 1e-4
json.dump(f, open(sys.argv[1] + '/fin.json', 'w'))
PY
( /usr/bin/time -f "fin-auto: %e s wall" timeout 45 "$B" run "$W/fin.json" --out "$W/fa" --quiet ) > "$O/fin-auto.txt" 2>&1
echo "rc $?" >> "$O/fin-auto.txt"
python3 -c "import json,glob; r=json.load(open(glob.glob('$W/fa/*/result.json')[0])); print('ok', sum(v.get('status')=='ok' for v in r['variants']), 'of', len(r['variants']), 'simulation_wall_s', r['run']['simulation_wall_s'], 'choice', r['run']['simulator'].get('backend_choice'))" >> "$O/fin-auto.txt" 2>&1
cat "$O/fin-auto.txt"
echo "== total $(el) s" | tee -a "$O/machine.txt"
