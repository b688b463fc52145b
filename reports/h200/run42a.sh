#!/bin/bash
# Session 42's first hardware-GPU call (issue 20 and "the GPU wins every sweep"): the
# multigrid kernel with batched strided loops (branch s42-kernel: each invocation reads B
# nodes' inputs before it stores any, so their device-memory loads overlap) against the
# built-in kernel of main 9ce3a3a, with one binary (main's, .devbin/bearing-sweep-main.xz)
# through BEARING_SWEEP_MG_WGSL, alternating old/new in two rounds after a warm-up call
# (the H200's clock ramps up from 345 MHz). Then a finite-film rotor sweep
# (reports/h200/sweeps41/finite-1024.json) on the CPU's 16 threads and on the GPU with
# each kernel. Every command under `timeout`. Usage there: bash reports/h200/run42a.sh
# (outputs under $OUT/raw42a/). Kernels: reports/h200/kernel42/b4.wgsl, and the B = 2 and 8
# variants made from it by setting its `const B` (the files the call ran, b2/b4/b8.wgsl).
set -u
O="${OUT:-/tmp/run42a}/raw42a"; mkdir -p "$O"
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
[ -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ] && export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
[ -f /usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json ] && export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
mkdir -p /tmp/b42
for x in .devbin/*.xz; do n=$(basename "${x%.xz}"); xz -dc "$x" > /tmp/b42/$n; chmod +x /tmp/b42/$n; done
export BEARING_SWEEP_CACHE_DIR=$(mktemp -d) RAYON_NUM_THREADS=16 BEARING_SWEEP_REQUIRE_GPU=1
T0=$(date +%s); el() { echo $(( $(date +%s) - T0 )); }
B=/tmp/b42/bearing-sweep-main
{ nvidia-smi --query-gpu=name,driver_version,clocks.max.sm,memory.total --format=csv 2>&1; lscpu | grep -E '^CPU\(s\)|Model name'; } > "$O/machine.txt" 2>&1
$B eval sweeps/eval-states.json --backend gpu > /dev/null 2> "$O/adapter.txt" || { cat "$O/adapter.txt"; exit 3; }
# Warm-up (untimed): one 1024-state call of the built-in kernel.
timeout 60 $B finite --bench --gpu --states 1024 --reps 1 > /dev/null 2>&1
bench() {  # $1 label, $2 kernel file or "", $3 states
  local f="$O/bench-$1-$3.md"
  [ "$(el)" -lt 330 ] || { echo "== $1 $3: not run (time)"; return; }
  if [ -n "$2" ]; then BEARING_SWEEP_MG_WGSL="$2" timeout 60 $B finite --bench --gpu --states $3 --reps 1 >> "$f" 2>&1
  else timeout 60 $B finite --bench --gpu --states $3 --reps 1 >> "$f" 2>&1; fi
  echo "rc $? (t = $(el) s)" >> "$f"
  echo "== $1 $3 (t = $(el) s)"; grep "^| gpu" "$f" | tail -5 | sed 's/(NVIDIA[^)]*), //;s/ kernel)//'
}
KD=$(mktemp -d)
for b in 2 4 8; do
  sed "s/^const B: u32 = 4u;/const B: u32 = ${b}u;/" reports/h200/kernel42/b4.wgsl > "$KD/b$b.wgsl"
done
for round in 1 2; do
  for n in 64 1024; do
    bench builtin "" $n
    for k in "$KD"/*.wgsl; do bench "$(basename ${k%.wgsl})" "$k" $n; done
  done
done
sweep() {  # $1 label, $2 backend, $3 kernel file or ""
  [ "$(el)" -lt 420 ] || { echo "== sweep $1: not run (time)"; return; }
  local out=/tmp/s42/$1; rm -rf $out; local s0=$(date +%s.%N)
  if [ -n "$3" ]; then BEARING_SWEEP_MG_WGSL="$3" timeout 60 $B run reports/h200/sweeps41/finite-1024.json --backend $2 --out $out > "$O/sweep-$1.txt" 2>&1
  else timeout 60 $B run reports/h200/sweeps41/finite-1024.json --backend $2 --out $out > "$O/sweep-$1.txt" 2>&1; fi
  echo "rc $? wall $(awk -v a=$s0 -v b=$(date +%s.%N) 'BEGIN{print b-a}') s (t = $(el) s)" >> "$O/sweep-$1.txt"
  echo "== sweep $1"; grep -E "^rc" "$O/sweep-$1.txt"
  local r=$out/finite-1024/result.json
  [ -f $r ] && grep -o '"simulation_wall_s": *[^,}]*' $r | head -1 | tee -a "$O/sweep-$1.txt"
}
sweep cpu cpu ""
sweep gpu-builtin gpu ""
K=$KD/b4.wgsl
sweep gpu-new gpu "$K"
# The two GPU sweeps' orbits against the CPU's (largest difference of any reduced number).
python3 - <<'PY' 2>&1 | tee "$O/sweep-compare.txt"
import json, itertools
def nums(x):
    if isinstance(x, dict):
        for k in sorted(x): yield from nums(x[k])
    elif isinstance(x, list):
        for v in x: yield from nums(v)
    elif isinstance(x, (int, float)) and not isinstance(x, bool): yield float(x)
def load(l):
    try: return json.load(open(f"/tmp/s42/{l}/finite-1024/result.json"))["variants"]
    except Exception as e: return None
c = load("cpu")
for l in ("gpu-builtin", "gpu-new"):
    g = load(l)
    if c is None or g is None: print(l, "missing"); continue
    d = 0.0; n = 0
    for a, b in zip(c, g):
        for u, v in zip(nums(a.get("reductions", a)), nums(b.get("reductions", b))):
            d = max(d, abs(u - v) / max(abs(u), 1e-12)); n += 1
    print(f"{l}: {n} numbers, largest relative difference from the CPU run {d:.3e}")
PY
echo "== total $(el) s"
