#!/bin/bash
# Session 42's second call: where a finite-film rotor sweep's GPU time goes (main 9ce3a3a's
# binary, built-in kernel): BEARING_SWEEP_MG_TRACE=1 per chunk of every call, summed; and the
# 64-state bench's CPU rows beside its GPU rows. Outputs: $OUT/raw42b.tgz.
set -u
O="${OUT:-/tmp/run42b}/raw42b"; mkdir -p "$O"
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
[ -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ] && export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
[ -f /usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json ] && export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
mkdir -p /tmp/b42; xz -dc .devbin/bearing-sweep-main.xz > /tmp/b42/bs; chmod +x /tmp/b42/bs; B=/tmp/b42/bs
export BEARING_SWEEP_CACHE_DIR=$(mktemp -d) RAYON_NUM_THREADS=16 BEARING_SWEEP_REQUIRE_GPU=1
timeout 60 $B finite --bench --gpu --states 1024 --reps 1 > /dev/null 2>&1   # warm-up
timeout 60 $B finite --bench --gpu --states 64 --reps 1 > "$O/bench-64.md" 2>&1
grep "^| \(cpu\|gpu\)" "$O/bench-64.md" | sed 's/(NVIDIA[^)]*), //'
s0=$(date +%s.%N)
BEARING_SWEEP_MG_TRACE=1 timeout 90 $B run reports/h200/sweeps41/finite-1024.json --backend gpu --out /tmp/s42t > "$O/sweep-gpu-trace.txt" 2>&1
echo "rc $? wall $(awk -v a=$s0 -v b=$(date +%s.%N) 'BEGIN{print b-a}') s" | tee -a "$O/sweep-gpu-trace.txt"
python3 - "$O/sweep-gpu-trace.txt" <<'PY' | tee "$O/trace-summary.txt"
import re, sys, collections
chunks = []; passes = 0; sizes = collections.Counter()
for line in open(sys.argv[1]):
    m = re.match(r"mg chunk of (\d+) states: buffers ([\d.]+) ms, dispatches and status ([\d.]+) ms \((\d+) dispatches\), fields read ([\d.]+) ms", line)
    if m:
        n, b, k, d, f = int(m[1]), float(m[2]), float(m[3]), int(m[4]), float(m[5])
        chunks.append((n, b, k, d, f)); sizes[(n // 256) * 256] += 1
    if line.startswith("mg pass"): passes += 1
print(f"chunks {len(chunks)}, passes (re-runs) {passes}")
for i, name in ((1, "buffers"), (2, "kernel"), (4, "fields")):
    print(f"{name}: total {sum(c[i] for c in chunks)/1e3:.3f} s")
print("states per chunk, by 256-bucket:", dict(sorted(sizes.items())))
ks = sorted(c[2] for c in chunks)
if ks: print(f"kernel ms per chunk: min {ks[0]:.2f} median {ks[len(ks)//2]:.2f} max {ks[-1]:.2f}")
ds = collections.Counter(c[3] for c in chunks); print("dispatches per chunk:", dict(ds))
PY
grep -v "^mg " "$O/sweep-gpu-trace.txt" | tail -3
grep "^mg" "$O/sweep-gpu-trace.txt" | head -30 > "$O/trace-head.txt"
tar -C "$O" -czf "${OUT:-/tmp/run42b}/raw42b.tgz" . && rm -rf "$O"
