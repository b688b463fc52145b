#!/bin/bash
# Session 41's hardware-GPU call (issue 20: the multigrid kernel's host side, s41-gpu
# branch: no field read-back where no caller uses it, buffers kept across chunks and
# calls, a scratch budget per device with accuracy-mode passes that hold a whole call in
# one chunk), one device call of < 5 minutes at worst: every command under `timeout`,
# later rows skipped when time runs short. Before and after on the same warm machine: the
# release binary of main before the merge (.devbin/bearing-sweep-s40.xz) and of the
# branch (.devbin/bearing-sweep-new.xz), and the GPU test binaries of the branch
# (.devbin/t-*.xz: finite_gpu_*, backend_suite, shaders_validate), built on the 2-core VM,
# stripped and xz'd, carried with .gl (the Vulkan loader's and libglvnd's .debs,
# /work/.library/device/README.md) as for reports/h200/run40b.sh. Usage there:
#   bash reports/h200/run41.sh          (outputs under $OUT/raw41/)
#  gpu-tests.txt     the kernels against the CPU on this hardware (BEARING_SWEEP_REQUIRE_GPU=1)
#  old-64.md, new-64.md, old-1024.md, new-1024.md   `finite --bench --gpu --states N --reps 1`
#                    with BEARING_SWEEP_MG_TRACE=1 (per chunk: buffers, kernel, fields read;
#                    the new binary also per accuracy-mode pass)
#  new-4096.md       the same at 4096 states per call
#  new-1024-chunks.md   (if time) the new binary without passes (BEARING_SWEEP_MG_TIERED=0):
#                    the chunks of session 40 with the other host changes
set -u
# (lead copy of the s41-gpu script with the lanes rows)
O="${OUT:-/tmp/run41}/raw41"; mkdir -p "$O"
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
[ -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ] && export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
[ -f /usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json ] && export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
mkdir -p /tmp/b41
for x in .devbin/*.xz; do n=$(basename "${x%.xz}"); xz -dc "$x" > /tmp/b41/$n; chmod +x /tmp/b41/$n; done
export BEARING_SWEEP_CACHE_DIR=$(mktemp -d) RAYON_NUM_THREADS=16 BEARING_SWEEP_REQUIRE_GPU=1
T0=$(date +%s); el() { echo $(( $(date +%s) - T0 )); }
{ nvidia-smi --query-gpu=name,driver_version,clocks.max.sm,memory.total --format=csv 2>&1; lscpu | grep -E '^CPU\(s\)|Model name'; } > "$O/machine.txt" 2>&1
cat "$O/machine.txt"
# No adapter (the NVIDIA ICD needs libglvnd's libraries from .gl): stop here, not after the CPU rows.
/tmp/b41/bearing-sweep-new eval sweeps/eval-states.json --backend gpu > /dev/null 2> "$O/adapter.txt" || { cat "$O/adapter.txt"; exit 3; }
for t in /tmp/b41/t-*; do
  [ -e "$t" ] || continue
  [ "$(el)" -lt 80 ] || { echo "--- $(basename $t): not run (time)" >> "$O/gpu-tests.txt"; continue; }
  echo "--- $(basename $t)" >> "$O/gpu-tests.txt"
  timeout 40 "$t" --test-threads 4 >> "$O/gpu-tests.txt" 2>&1
  echo "rc $? (t = $(el) s)" >> "$O/gpu-tests.txt"
done
grep -E "^---|test result|^rc|FAILED|panicked" "$O/gpu-tests.txt"
# One row: binary (old|new), states per call, time limit, the latest start (s), env.
row() {
  local v=$1 n=$2 lim=$3 start=$4; shift 4
  local B=/tmp/b41/bearing-sweep-new; [ $v = old ] && B=/tmp/b41/bearing-sweep-s40
  local f="$O/$v-$n${TAG:-}.md"
  [ "$(el)" -lt "$start" ] || { echo "== $v $n${TAG:-}: not run (time)"; return; }
  echo "== $v $n${TAG:-} (t = $(el) s)"
  env "$@" BEARING_SWEEP_MG_TRACE=1 timeout "$lim" "$B" finite --bench --gpu --states "$n" --reps 1 --rotor-t-end 0.0002 > "$f" 2>&1
  echo "rc $? (t = $(el) s)" >> "$f"
  grep "^| \(cpu\|gpu\)" "$f" | sed 's/(Vulkan[^)]*)//'
  grep -E "^mg (chunk|pass)" "$f" | tail -4
  tail -1 "$f"
}
row old 64 30 120
row new 64 30 130
row old 1024 60 150
row new 1024 60 190
row new 4096 100 195
TAG=-chunks row new 1024 50 240 BEARING_SWEEP_MG_TIERED=0
# The lead's rows (session 41): the multigrid lanes' choice on this host's CPU and 128 × 32
# against PSOR at equal error, one thread (examples built on the VM at 2c5d467; the oracle
# file .devbin/mg_equal_error_128x32.txt from `mg_equal_error table 128x32` there).
if [ "$(el)" -lt 300 ]; then
  echo "== lanes (t = $(el) s)"
  export MGE_DIR=$PWD/.devbin MG_CYCLE=points,2,1
  for i in 1 2 3; do /tmp/b41/ex-lanes_choice; done > "$O/lanes.txt" 2>&1
  for r in 1 2 3 4 5 6; do
    for L in avx512 avx2 ""; do echo "single lanes=${L:-chosen} $(BEARING_SWEEP_LANES=$L timeout 10 /tmp/b41/ex-mg_equal_error prof mg 128 32 2>&1 | grep ms/state)"; done
    echo "single psor $(timeout 10 /tmp/b41/ex-mg_equal_error prof psor 128 32 2>&1 | grep ms/state)"
  done >> "$O/lanes.txt"
  for L in avx512 avx2; do echo "reused lanes=$L $(BEARING_SWEEP_LANES=$L timeout 20 /tmp/b41/ex-mg_equal_error prof mg 128 32 200 2>&1 | grep 'best of')"; done >> "$O/lanes.txt"
  echo "reused psor $(timeout 30 /tmp/b41/ex-mg_equal_error prof psor 128 32 30 2>&1 | grep 'best of')" >> "$O/lanes.txt"
  cat "$O/lanes.txt" | cut -c1-160
fi
echo "== total $(el) s" | tee -a "$O/machine.txt"
