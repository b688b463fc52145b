#!/bin/bash
# The hardware-GPU run of this session (NVIDIA H200 through the device tool): the release
# binaries (new = this commit, old = the main before this session, for the baseline on the
# same machine) were built on the 2-core VM, stripped, xz-compressed into .devbin/ and
# carried over. Every figure of BENCHMARKS.md "H200" comes from this script's outputs,
# kept beside it in reports/h200/. Usage there: bash reports/h200/run.sh (OUT set by the tool).
set -u
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
export XDG_RUNTIME_DIR=$(mktemp -d)
[ -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ] && export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
for x in .devbin/*.xz; do xz -dc "$x" > "${x%.xz}"; chmod +x "${x%.xz}"; done
export NEW=$PWD/.devbin/bearing-sweep OLD=$PWD/.devbin/bearing-sweep-old
REAL_OUT=$OUT; export RES=$(mktemp -d)
mkdir -p target/release && cp "$NEW" target/release/bearing-sweep
{ nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm --format=csv; lscpu | grep -E '^CPU\(s\)|Model name'; } > "$RES/machine.txt" 2>&1
cat "$RES/machine.txt"
T0=$(date +%s)
step() { # name, command...: output under $RES/name, log beside it
  local n=$1; shift; echo "== $n (t = $(( $(date +%s) - T0 )) s)"
  mkdir -p "$RES/$n"; OUT="$RES/$n" B="$NEW" "$@" 2>&1 | tee "$RES/$n.log" | tail -40
}
# The new binary first, then the old one on the same workloads (the baseline on this host).
step gpu-new bash reports/h200/gpu-commands.sh "$NEW"
step finite bash reports/h200/finite-commands.sh
[ -f reports/h200/jfo-commands.sh ] && step jfo bash reports/h200/jfo-commands.sh
step gpu-old bash reports/h200/gpu-commands.sh "$OLD"
echo "== total $(( $(date +%s) - T0 )) s"
tar -C "$RES" -czf "$REAL_OUT/h200-results.tar.gz" .
