#!/bin/bash
# Session 42's last hardware-GPU call (issue 20): main after the merges (the ladder's
# V(2,0) cycles mirrored in the kernel, s42-ladder; the workgroup size per chunk with the
# loads' sums in fixed lanes, s42-wg). (1) the GPU test binaries with
# BEARING_SWEEP_REQUIRE_GPU=1; (2) the finite bench at 64, 1024 and 2048 states per call
# (workgroup per chunk); (3) the finite-film rotor sweep of 1,024 variants on the CPU's 16
# threads, on the GPU with the per-chunk choice and with 256 forced: wall times, and the
# two GPU runs' results compared bit for bit (the kernel's bits do not depend on the
# size). Every command under `timeout`. Outputs: $OUT/raw42d.tgz.
set -u
O="${OUT:-/tmp/run42d}/raw42d"; mkdir -p "$O"
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
[ -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ] && export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
[ -f /usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json ] && export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
mkdir -p /tmp/b42
for x in .devbin/*.xz; do n=$(basename "${x%.xz}"); xz -dc "$x" > /tmp/b42/$n; chmod +x /tmp/b42/$n; done
export BEARING_SWEEP_CACHE_DIR=$(mktemp -d) RAYON_NUM_THREADS=16 BEARING_SWEEP_REQUIRE_GPU=1
T0=$(date +%s); el() { echo $(( $(date +%s) - T0 )); }
B=/tmp/b42/bearing-sweep-new
$B eval sweeps/eval-states.json --backend gpu > /dev/null 2> "$O/adapter.txt" || { cat "$O/adapter.txt"; exit 3; }
for t in /tmp/b42/t-*; do
  [ -e "$t" ] || continue
  [ "$(el)" -lt 70 ] || { echo "--- $(basename $t): not run (time)" >> "$O/gpu-tests.txt"; continue; }
  echo "--- $(basename $t)" >> "$O/gpu-tests.txt"
  timeout 40 "$t" --test-threads 4 >> "$O/gpu-tests.txt" 2>&1
  echo "rc $? (t = $(el) s)" >> "$O/gpu-tests.txt"
done
grep -E "^---|test result|^rc|FAILED|panicked" "$O/gpu-tests.txt"
for n in 64 1024 2048; do
  [ "$(el)" -lt 110 ] || { echo "== bench $n: not run (time)"; continue; }
  BEARING_SWEEP_MG_TRACE=1 timeout 40 $B finite --bench --gpu --states $n --reps 1 > "$O/bench-$n.md" 2>&1
  echo "== bench $n (t = $(el) s)"; grep "^| \(cpu\|gpu\).*\(128\|accuracy\)" "$O/bench-$n.md" | sed 's/(NVIDIA[^)]*), //'
done
sweep() {  # $1 label, $2 backend, $3 forced workgroup or ""
  [ "$(el)" -lt 160 ] || { echo "== sweep $1: not run (time)"; return; }
  local out=/tmp/s42d/$1; rm -rf $out; local s0=$(date +%s.%N)
  if [ -n "$3" ]; then BEARING_SWEEP_MG_WG=$3 timeout 30 $B run reports/h200/sweeps41/finite-1024.json --backend $2 --out $out > "$O/sweep-$1.txt" 2>&1
  else timeout 30 $B run reports/h200/sweeps41/finite-1024.json --backend $2 --out $out > "$O/sweep-$1.txt" 2>&1; fi
  echo "rc $? wall $(awk -v a=$s0 -v b=$(date +%s.%N) 'BEGIN{print b-a}') s (t = $(el) s)" >> "$O/sweep-$1.txt"
  echo "== sweep $1"; tail -1 "$O/sweep-$1.txt"
  grep -o '"simulation_wall_s": *[^,}]*' $out/finite-1024/result.json 2>/dev/null | head -1 | tee -a "$O/sweep-$1.txt"
}
sweep gpu-auto gpu ""
sweep gpu-256 gpu 256
sweep cpu cpu ""
sweep gpu-auto2 gpu ""
python3 - <<'PY' 2>&1 | tee "$O/sweep-compare.txt"
import json
def load(l):
    try: return [v["reductions"] for v in json.load(open(f"/tmp/s42d/{l}/finite-1024/result.json"))["variants"]]
    except Exception as e: return None
a, b, c = load("gpu-auto"), load("gpu-256"), load("cpu")
if a is None or b is None: print("missing GPU results")
else: print("GPU per-chunk workgroup vs 256 forced: reductions", "identical" if a == b else "DIFFER")
def nums(x):
    if isinstance(x, dict):
        for k in sorted(x): yield from nums(x[k])
    elif isinstance(x, list):
        for v in x: yield from nums(v)
    elif isinstance(x, (int, float)) and not isinstance(x, bool): yield float(x)
if a is not None and c is not None:
    d = max((abs(u - v) / max(abs(u), 1e-300) for p, q in zip(c, a) for u, v in zip(nums(p), nums(q)) if u != 0), default=0)
    print(f"GPU vs CPU: largest relative difference of a reduced number {d:.3e}")
PY
tar -C "$O" -czf "${OUT:-/tmp/run42d}/raw42d.tgz" . && rm -rf "$O"
echo "== total $(el) s"
