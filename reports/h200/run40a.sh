#!/bin/bash
# Session 40's first hardware-GPU call (issue 20: where the finite film's multigrid kernel
# spends its time on a hardware GPU). One device call of < 4 minutes at worst: every
# command under `timeout`. Binaries built on the 2-core VM, stripped, xz'd into .devbin/
# and carried with .gl (the Vulkan loader's .deb), as for reports/h200/run39.sh.
#   bash reports/h200/run40a.sh          (outputs under $OUT/raw40a/)
# 1. `finite --bench --gpu --states 64 --reps 1` with BEARING_SWEEP_MG_TRACE (dispatch
#    rounds of 8 dispatches, elapsed ms per round, running states): trace-64.txt.
# 2. The same with BEARING_SWEEP_MG_LOOP_LIMIT=2000000 (67× the llvmpipe-safe 30 000 loop
#    iterations per dispatch; the same arithmetic, fewer dispatches and read-backs):
#    limit-64.txt. If the GPU rows move much, dispatch overhead matters; if not, the
#    per-state chain inside the kernel does.
# 3. 1024 states with the large limit, no trace: limit-1024.md (against session 39's
#    467 states/s at the default accuracy).
set -u
O="${OUT:-/tmp/run40a}/raw40a"; mkdir -p "$O"
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
[ -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ] && export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
mkdir -p /tmp/b40
for x in .devbin/*.xz; do n=$(basename "${x%.xz}"); xz -dc "$x" > /tmp/b40/$n; chmod +x /tmp/b40/$n; done
B=/tmp/b40/bearing-sweep-s40
export BEARING_SWEEP_CACHE_DIR=$(mktemp -d) RAYON_NUM_THREADS=16 BEARING_SWEEP_REQUIRE_GPU=1
T0=$(date +%s); el() { echo $(( $(date +%s) - T0 )); }
{ nvidia-smi --query-gpu=name,driver_version,clocks.max.sm --format=csv 2>&1; lscpu | grep -E '^CPU\(s\)|Model name'; "$B" --version; } > "$O/machine.txt" 2>&1
cat "$O/machine.txt"
echo "== trace 64 (t = $(el) s)"
BEARING_SWEEP_MG_TRACE=1 timeout 60 "$B" finite --bench --gpu --states 64 --reps 1 --rotor-t-end 0.0002 > "$O/trace-64.txt" 2>&1
echo "rc $?" >> "$O/trace-64.txt"
grep "^| \(cpu\|gpu\)" "$O/trace-64.txt" | sed 's/(Vulkan[^)]*)//'
grep -c "^mg dispatches" "$O/trace-64.txt"
echo "== limit 64 (t = $(el) s)"
BEARING_SWEEP_MG_LOOP_LIMIT=2000000 BEARING_SWEEP_MG_TRACE=1 timeout 60 "$B" finite --bench --gpu --states 64 --reps 1 --rotor-t-end 0.0002 > "$O/limit-64.txt" 2>&1
echo "rc $?" >> "$O/limit-64.txt"
grep "^| \(cpu\|gpu\)" "$O/limit-64.txt" | sed 's/(Vulkan[^)]*)//'
grep -c "^mg dispatches" "$O/limit-64.txt"
if [ "$(el)" -lt 130 ]; then
echo "== limit 1024 (t = $(el) s)"
BEARING_SWEEP_MG_LOOP_LIMIT=2000000 timeout 70 "$B" finite --bench --gpu --states 1024 --reps 1 --rotor-t-end 0.0002 > "$O/limit-1024.md" 2>&1
echo "rc $?" >> "$O/limit-1024.md"
grep "^| \(cpu\|gpu\)" "$O/limit-1024.md" | sed 's/(Vulkan[^)]*)//'
fi
echo "== total $(el) s" | tee -a "$O/machine.txt"
xz -9 "$O"/trace-64.txt "$O"/limit-64.txt 2>/dev/null; ls -l "$O"
