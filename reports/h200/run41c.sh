#!/bin/bash
# Session 41's third device call (issue 20): A/B on one machine of the finite benchmark at
# 1024 states per call, because the second call (run41b.sh) measured the multigrid kernel
# at 128 × 32 5× slower than the first call (run41-lead.sh) did: A = s41-gpu at 5ce223e
# (the first call's "new"), B = main at f63e13b (after the s41-honest merge: the kernel's
# ladder extension), alternating A B A B, BEARING_SWEEP_MG_TRACE=1. Outputs $OUT/raw41c/.
set -u
O="${OUT:-/tmp/run41c}/raw41c"; mkdir -p "$O"
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
[ -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ] && export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
[ -f /usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json ] && export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
mkdir -p /tmp/b41
for x in .devbin/*.xz; do n=$(basename "${x%.xz}"); xz -dc "$x" > /tmp/b41/$n; chmod +x /tmp/b41/$n; done
export BEARING_SWEEP_CACHE_DIR=$(mktemp -d) RAYON_NUM_THREADS=16
T0=$(date +%s); el() { echo $(( $(date +%s) - T0 )); }
nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm,temperature.gpu,power.draw --format=csv > "$O/machine.txt" 2>&1
for r in 1 2; do for v in a b; do
  [ "$(el)" -lt 150 ] || { echo "== $v $r: not run (time)"; continue; }
  echo "== $v $r (t = $(el) s)"
  BEARING_SWEEP_MG_TRACE=1 timeout 45 /tmp/b41/bearing-sweep-$v finite --bench --gpu --states 1024 --reps 1 --rotor-t-end 0.0002 > "$O/$v-$r.md" 2>&1
  echo "rc $?" >> "$O/$v-$r.md"
  grep "^| gpu.*multigrid" "$O/$v-$r.md" | sed 's/(Vulkan[^)]*)//'
  grep "^mg chunk of 1024" "$O/$v-$r.md" | sed -n '2p;4p' | cut -c1-90
done; done
nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm,temperature.gpu,power.draw --format=csv >> "$O/machine.txt" 2>&1
cat "$O/machine.txt"; echo "== total $(el) s"
