#!/bin/bash
# Sweep throughput of the paper rotor (MODEL.md section 8, 0.5 s simulated, dopri5
# rtol = atol = 1e-6, samples every 5e-4 s, film accuracy 1e-6) at N variants: a Latin
# hypercube over clearance [2e-4, 4e-4] m x viscosity [0.015, 0.04] Pa·s. Prints
# N, batch size, wall seconds, variants per second and peak RSS (VmHWM) per run.
#   [BATCH_SIZES="auto 1024"] bash benches/scripts/sweep-bench.sh [BIN] [N...]
set -euo pipefail
BIN=${1:-target/release/bearing-sweep}
shift || true
NS=${*:-1 64 1024 4096}
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
for N in $NS; do
  for BS in ${BATCH_SIZES:-auto}; do
    cat > "$TMP/bench-$N.json" <<JSON
{"kind": "rotor",
 "base": {"rotor": {"mass": 1.0, "inertia": [0.01, 0.01, 0.3], "static_unbalance": [0.001, 0.0]},
          "bearings": [{"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242, "axial_position": 0.2},
                       {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242, "axial_position": -0.1}],
          "initial": {"spin": 100.0},
          "integrator": {"method": "dopri5", "rtol": 1e-6, "atol": 1e-6, "t_end": 0.5, "sample_interval": 5e-4}},
 "axes": [{"path": "bearings[*].clearance", "linspace": [2e-4, 4e-4, 2]},
          {"path": "bearings[*].viscosity", "linspace": [0.015, 0.04, 2]}],
 "mode": {"latin_hypercube": {"samples": $N, "seed": 1}},
 "reductions": {"window": {"revolutions": 3}}}
JSON
    "$BIN" run "$TMP/bench-$N.json" --out "$TMP/out-$N" --quiet --backend cpu --batch-size $BS 2>/dev/null
    python3 - "$TMP/out-$N/bench-$N/result.json" "$N" "$BS" <<'PY'
import json, sys
d = json.load(open(sys.argv[1])); r = d["run"]
ok = sum(v["status"] == "ok" for v in d["variants"])
print(f"N={sys.argv[2]:>5} batch={sys.argv[3]:>4} ok={ok:>5} wall={r['simulation_wall_s']:8.2f} s "
      f"rate={r['variants_per_s']:7.2f} variants/s peak_rss={r['peak_rss_bytes']/2**20:7.1f} MiB "
      f"device={r['simulator']['device']}")
PY
  done
done
