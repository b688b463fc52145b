#!/bin/bash
# Session 42 (issue 20, s42-kernel): A/B of the finite film's multigrid kernel on one binary.
# Usage: B=/path/to/bearing-sweep bash reports/h200/kernel42/ab.sh
# For the built-in kernel and then the batched loops with B = 2, 4, 8 nodes per invocation and
# round trip (BEARING_SWEEP_MG_WGSL: b4.wgsl, and b2/b8 made from it by setting its `const B`;
# measured
# and not taken: BENCHMARKS.md "Issue 20, session 42: the multigrid kernel's batched loops";
# their base is the kernel of main 9ce3a3a), the GPU's states/s of `finite --bench --gpu`
# at 64 and at 1024 states per call (the flags of reports/h200/run41b.sh's bench), each under
# `timeout 60`. One untimed call first: the H200's clock ramps up from 345 MHz.
# The bench also times the CPU; only the multigrid kernel's rows are printed.
set -u
: "${B:?set B to a bearing-sweep binary}"
D=$(dirname "$0")
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
bench() { # $1 states, then the environment of the kernel
  timeout 60 "$B" finite --bench --gpu --states "$1" --reps 1 --rotor-t-end 0.0002 2>&1
  echo "rc $?"
}
rows() { # the multigrid kernel's rows: setting | states/s | sweeps/state | errors
  grep -E "^\| gpu .*multigrid kernel|^rc [^0]" | sed 's/^| gpu ([^|]*multigrid kernel) //'
}
# The B = 2 and 8 variants differ from b4.wgsl in `const B` only.
V=$(mktemp -d)
for b in 2 4 8; do
  sed "s/^const B: u32 = 4u;/const B: u32 = ${b}u;/" "$D/b4.wgsl" > "$V/b$b.wgsl"
done
echo "== warm-up (untimed)"
bench 64 > /dev/null
for k in builtin "$V"/*.wgsl; do
  for n in 64 1024; do
    echo "== kernel $(basename "$k") states $n"
    if [ "$k" = builtin ]; then
      bench "$n" | rows
    else
      BEARING_SWEEP_MG_WGSL="$k" bench "$n" | rows
    fi
  done
done
