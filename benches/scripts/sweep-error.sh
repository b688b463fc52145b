#!/bin/bash
# Error of the sweep benchmark's settings (dopri5 rtol = atol = 1e-6) against 1e-11 over
# the benchmark's parameter box (3 clearances x 3 viscosities, corners and centre):
# max |G - G_ref| over the 1001 samples, |h_min - h_min_ref|, relative friction error.
#   bash benches/scripts/sweep-error.sh [BIN]
set -euo pipefail
BIN=${1:-target/release/bearing-sweep}
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
"$BIN" run "$(dirname "$0")/sweep-error.json" --out "$TMP" --quiet 2>/dev/null
python3 - "$TMP/sweep-error/result.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
vs = {}
for v in d["variants"]:
    p = v["params"]
    vs[(p["bearings[*].clearance"], p["bearings[*].viscosity"], p["integrator.rtol"])] = v
worst = 0.0
for (c, mu, tol), v in sorted(vs.items()):
    if tol != 1e-6:
        continue
    ref = vs[(c, mu, 1e-11)]
    s, r = v["series"], ref["series"]
    e = max(((a - b) ** 2 + (x - y) ** 2) ** 0.5
            for a, b, x, y in zip(s["x_g"], r["x_g"], s["y_g"], r["y_g"]))
    dh = abs(v["reductions"]["h_min"]["value_m"] - ref["reductions"]["h_min"]["value_m"])
    f0 = v["reductions"]["bearings"][0]["friction_coefficient"]["mean"]
    f1 = ref["reductions"]["bearings"][0]["friction_coefficient"]["mean"]
    worst = max(worst, e)
    print(f"clearance {c:.0e} m, viscosity {mu} Pa·s: max |G - G_ref| = {e:.2e} m, "
          f"|h_min - ref| = {dh:.1e} m, friction rel. error {abs(f0 / f1 - 1):.1e}, "
          f"steps {v['sim']['steps']} (ref {ref['sim']['steps']})")
print(f"worst max |G - G_ref| = {worst:.2e} m")
PY
