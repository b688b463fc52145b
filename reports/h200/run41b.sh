#!/bin/bash
# Session 41's second hardware-GPU call (issue 20), < 6 minutes at worst, every command under
# `timeout`: (1) the GPU tests of main after the s41-honest merge (its kernel mirrors the
# ladder's one-grid extension) on this hardware; (2) the finite benchmark at 1024 states per
# call with that kernel; (3) a finite-film rotor sweep (reports/h200/sweeps41/) on the CPU's
# 16 threads and on the GPU: whether `auto` should take the GPU for finite-film sweeps.
# Binaries built on the 2-core VM, stripped, xz'd in .devbin (bearing-sweep-new, t-*), with
# .gl as in run41.sh. Usage there: bash reports/h200/run41b.sh (outputs under $OUT/raw41b/).
set -u
O="${OUT:-/tmp/run41b}/raw41b"; mkdir -p "$O"
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
[ -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ] && export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
[ -f /usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json ] && export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
mkdir -p /tmp/b41
for x in .devbin/*.xz; do n=$(basename "${x%.xz}"); xz -dc "$x" > /tmp/b41/$n; chmod +x /tmp/b41/$n; done
export BEARING_SWEEP_CACHE_DIR=$(mktemp -d) RAYON_NUM_THREADS=16 BEARING_SWEEP_REQUIRE_GPU=1
T0=$(date +%s); el() { echo $(( $(date +%s) - T0 )); }
B=/tmp/b41/bearing-sweep-new
$B eval sweeps/eval-states.json --backend gpu > /dev/null 2> "$O/adapter.txt" || { cat "$O/adapter.txt"; exit 3; }
for t in /tmp/b41/t-*; do
  [ -e "$t" ] || continue
  [ "$(el)" -lt 90 ] || { echo "--- $(basename $t): not run (time)" >> "$O/gpu-tests.txt"; continue; }
  echo "--- $(basename $t)" >> "$O/gpu-tests.txt"
  timeout 40 "$t" --test-threads 4 >> "$O/gpu-tests.txt" 2>&1
  echo "rc $? (t = $(el) s)" >> "$O/gpu-tests.txt"
done
grep -E "^---|test result|^rc|FAILED|panicked" "$O/gpu-tests.txt"
echo "== bench 1024 (t = $(el) s)"
BEARING_SWEEP_MG_TRACE=1 timeout 60 $B finite --bench --gpu --states 1024 --reps 1 --rotor-t-end 0.0002 > "$O/bench-1024.md" 2>&1
echo "rc $?" >> "$O/bench-1024.md"
grep "^| \(cpu\|gpu\)" "$O/bench-1024.md" | sed 's/(Vulkan[^)]*)//'
# The rotor sweeps: wall time of the whole run (`run.wall_s`), variants done.
sweep() {
  local n=$1 be=$2 lim=$3 start=$4
  [ "$(el)" -lt "$start" ] || { echo "== sweep $n $be: not run (time)"; return; }
  echo "== sweep $n $be (t = $(el) s)"
  local out=/tmp/s41/$n-$be; rm -rf $out
  local s0=$(date +%s.%N)
  timeout $lim $B run reports/h200/sweeps41/finite-$n.json --backend $be --out $out > "$O/sweep-$n-$be.txt" 2>&1
  echo "rc $? wall $(awk -v a=$s0 -v b=$(date +%s.%N) 'BEGIN{print b-a}') s (t = $(el) s)" >> "$O/sweep-$n-$be.txt"
  grep -E "variants in this run|^rc|notice" "$O/sweep-$n-$be.txt" | head -6
  local r=$out/finite-$n/result.json
  [ -f $r ] && grep -o '"\(wall_s\|simulation_wall_s\|backend\|reason\)": *[^,}]*' $r | head -8 | tee -a "$O/sweep-$n-$be.txt"
}
sweep 1024 cpu 60 200
sweep 1024 gpu 90 210
sweep 4096 cpu 60 300
sweep 4096 gpu 90 320
sweep 1024 auto 40 400
echo "== total $(el) s"
