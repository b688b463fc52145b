#!/bin/bash
# Session 42's third call: the multigrid kernel's workgroup size against the states per
# call (main 9ce3a3a's binary, built-in kernel): BEARING_SWEEP_MG_WG = 64, 128, 256 on the
# 64- and 1024-state benches and on the finite-film rotor sweep of 1,024 variants (2,048
# easy states per call: 17 ms a call at 256 invocations, run42b). Outputs: $OUT/raw42c.tgz.
set -u
O="${OUT:-/tmp/run42c}/raw42c"; mkdir -p "$O"
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
[ -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ] && export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
[ -f /usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json ] && export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
mkdir -p /tmp/b42; xz -dc .devbin/bearing-sweep-main.xz > /tmp/b42/bs; chmod +x /tmp/b42/bs; B=/tmp/b42/bs
export BEARING_SWEEP_CACHE_DIR=$(mktemp -d) RAYON_NUM_THREADS=16 BEARING_SWEEP_REQUIRE_GPU=1
T0=$(date +%s); el() { echo $(( $(date +%s) - T0 )); }
timeout 60 $B finite --bench --gpu --states 1024 --reps 1 > /dev/null 2>&1   # warm-up
for wg in 64 128 256; do
  for n in 64 1024; do
    [ "$(el)" -lt 150 ] || { echo "== wg $wg $n: not run (time)"; continue; }
    BEARING_SWEEP_MG_WG=$wg timeout 40 $B finite --bench --gpu --states $n --reps 1 > "$O/bench-wg$wg-$n.md" 2>&1
    echo "== wg $wg, $n states (t = $(el) s)"; grep "^| gpu multigrid\|^| cpu.*accuracy\|^| cpu.*128" "$O/bench-wg$wg-$n.md" | sed 's/(NVIDIA[^)]*), //'
  done
done
for wg in 64 128 256; do
  [ "$(el)" -lt 200 ] || { echo "== sweep wg $wg: not run (time)"; continue; }
  s0=$(date +%s.%N)
  BEARING_SWEEP_MG_WG=$wg BEARING_SWEEP_MG_TRACE=1 timeout 40 $B run reports/h200/sweeps41/finite-1024.json --backend gpu --out /tmp/s42c-$wg > "$O/sweep-wg$wg.txt" 2>&1
  echo "== sweep wg $wg: rc $? wall $(awk -v a=$s0 -v b=$(date +%s.%N) 'BEGIN{print b-a}') s" | tee -a "$O/sweep-wg$wg.txt"
  grep -o '"simulation_wall_s": *[^,}]*' /tmp/s42c-$wg/finite-1024/result.json | head -1
  grep "^mg chunk of 2048" "$O/sweep-wg$wg.txt" | sed 's/.*status \([0-9.]*\) ms.*/\1/' | sort -n | awk '{a[NR]=$1} END {print "2048-state chunks:", NR, "kernel ms median", a[int(NR/2)+1]}'
  grep -v "^mg " "$O/sweep-wg$wg.txt" > "$O/sweep-wg$wg.short.txt"; rm "$O/sweep-wg$wg.txt"
done
tar -C "$O" -czf "${OUT:-/tmp/run42c}/raw42c.tgz" . && rm -rf "$O"
echo "== total $(el) s"
