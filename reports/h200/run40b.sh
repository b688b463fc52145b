#!/bin/bash
# Session 40's hardware-GPU call (issue 20: the finite film's multigrid kernel after the
# s40-gpu branch's cuts of its per-state chain), one device call of < 5 minutes at worst:
# every command under `timeout`. Before and after on the same warm machine: the release
# binary of main before the merge (.devbin/bearing-sweep-s40.xz, 389eafb) and after
# (.devbin/bearing-sweep-new.xz), and the GPU test binaries of the new tree
# (.devbin/t-*.xz), built on the 2-core VM, stripped and xz'd, carried with .gl (the
# Vulkan loader's and libglvnd's .debs, /work/.library/device/README.md) as for reports/h200/run39.sh. Usage there:
#   bash reports/h200/run40b.sh          (outputs under $OUT/raw40b/)
#  gpu-tests.txt   the kernels against the CPU on this hardware (BEARING_SWEEP_REQUIRE_GPU=1)
#  old-64.md, new-64.md, new-wg256-64.md   `finite --bench --gpu --states 64 --reps 2` with
#                  BEARING_SWEEP_MG_TRACE (the new kernel also with 256-wide workgroups)
#  new-1024.md              the same at 1024 states per call (session 39: 467 states/s)
set -u
O="${OUT:-/tmp/run40b}/raw40b"; mkdir -p "$O"
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
[ -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ] && export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
[ -f /usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json ] && export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
mkdir -p /tmp/b40
for x in .devbin/*.xz; do n=$(basename "${x%.xz}"); xz -dc "$x" > /tmp/b40/$n; chmod +x /tmp/b40/$n; done
export BEARING_SWEEP_CACHE_DIR=$(mktemp -d) RAYON_NUM_THREADS=16 BEARING_SWEEP_REQUIRE_GPU=1
T0=$(date +%s); el() { echo $(( $(date +%s) - T0 )); }
{ nvidia-smi --query-gpu=name,driver_version,clocks.max.sm --format=csv 2>&1; lscpu | grep -E '^CPU\(s\)|Model name'; } > "$O/machine.txt" 2>&1
cat "$O/machine.txt"
# No adapter (the NVIDIA ICD needs libglvnd's libraries from .gl): stop here, not after the CPU rows.
/tmp/b40/bearing-sweep-new eval sweeps/eval-states.json --backend gpu > /dev/null 2> "$O/adapter.txt" || { cat "$O/adapter.txt"; exit 3; }
for t in /tmp/b40/t-*; do
  [ -e "$t" ] || continue
  [ "$(el)" -lt 100 ] || { echo "--- $(basename $t): not run (time)" >> "$O/gpu-tests.txt"; continue; }
  echo "--- $(basename $t)" >> "$O/gpu-tests.txt"
  timeout 50 "$t" --test-threads 4 >> "$O/gpu-tests.txt" 2>&1
  echo "rc $? (t = $(el) s)" >> "$O/gpu-tests.txt"
done
grep -E "^---|test result|^rc|FAILED|panicked" "$O/gpu-tests.txt"
# TRACE: per dispatch round the elapsed ms (old) / buffers, kernel and read-back ms (new).
for v in old new new-wg256; do
  B=/tmp/b40/bearing-sweep-new; [ $v = old ] && B=/tmp/b40/bearing-sweep-s40
  WGV=""; [ $v = new-wg256 ] && WGV=256
  [ "$(el)" -lt 170 ] || { echo "== $v: not run (time)"; continue; }
  echo "== $v 64 (t = $(el) s)"
  BEARING_SWEEP_MG_WG=$WGV BEARING_SWEEP_MG_TRACE=1 timeout 45 "$B" finite --bench --gpu --states 64 --reps 2 --rotor-t-end 0.0002 > "$O/$v-64.md" 2>&1
  echo "rc $?" >> "$O/$v-64.md"
  grep "^| gpu" "$O/$v-64.md" | sed 's/(Vulkan[^)]*)//'
  grep "^mg " "$O/$v-64.md" | tail -3
done
if [ "$(el)" -lt 190 ]; then
  echo "== new 1024 (t = $(el) s)"
  timeout 80 /tmp/b40/bearing-sweep-new finite --bench --gpu --states 1024 --reps 1 --rotor-t-end 0.0002 > "$O/new-1024.md" 2>&1
  echo "rc $?" >> "$O/new-1024.md"
  grep "^| \(cpu\|gpu\)" "$O/new-1024.md" | sed 's/(Vulkan[^)]*)//'
fi
echo "== total $(el) s" | tee -a "$O/machine.txt"
