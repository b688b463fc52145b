#!/bin/bash
# A sweep as a Slurm job array: each array task runs one deterministic shard (variant i
# goes to shard i mod N, N = the array's size), streaming finished variants to its own
# .jsonl; a task that is preempted or times out resumes where it stopped when requeued
# (same command, same output folder). The shards' outputs go to
# $OUT/<spec stem>/shard-K-of-N/. Then `--merge` (as a job that depends on the array)
# writes $OUT/<spec stem>/result.json, equal to what `bearing-sweep run SPEC` writes.
#
#   deploy/slurm-submit.sh SPEC.json [N]            # both jobs, the merge after the array
# or by hand:
#   mkdir -p sweep-out
#   sbatch --array=0-15 deploy/slurm-sweep.sh SPEC.json
#   sbatch --dependency=afterok:<array job id> deploy/slurm-sweep.sh --merge SPEC.json
#
# Environment: OUT (default sweep-out), BEARING_SWEEP_BIN (default `bearing-sweep` on
# PATH), BACKEND (default cpu). Tested against a real single-node Slurm 22.05 (Debian
# slurm-wlm) by python/tests/test_slurm.py.
#
#SBATCH --job-name=bearing-sweep
#SBATCH --array=0-15
#SBATCH --cpus-per-task=8
#SBATCH --mem=8G
#SBATCH --time=02:00:00
#SBATCH --output=sweep-out/slurm-%A_%a.log
#SBATCH --requeue

set -euo pipefail
MERGE=0
if [ "${1:-}" = "--merge" ]; then
    MERGE=1
    shift
fi
SPEC=${1:?usage: sbatch [--array=0-N-1] deploy/slurm-sweep.sh [--merge] SPEC.json}
OUT=${OUT:-sweep-out}
BIN=${BEARING_SWEEP_BIN:-bearing-sweep}
BACKEND=${BACKEND:-cpu}
STEM=$(basename "${SPEC%.*}")
mkdir -p "$OUT"

if [ "$MERGE" = 1 ]; then
    # Every shard folder of this spec; refuse a partial set (a shard's result.json
    # names its K and N, and merge checks they cover 0..N-1 exactly once).
    shopt -s nullglob
    shards=("$OUT/$STEM"/shard-*-of-*/result.json)
    [ ${#shards[@]} -gt 0 ] || { echo "no shard results under $OUT/$STEM" >&2; exit 1; }
    exec "$BIN" merge "$OUT/$STEM/result.json" "${shards[@]}"
fi

: "${SLURM_ARRAY_TASK_ID:?run as a Slurm array job (sbatch --array=0-N-1 ...)}"
# The array's size is the shard count (SLURM_ARRAY_TASK_COUNT; the max id + 1 when the
# array is 0..N-1).
SHARDS=${SHARDS:-${SLURM_ARRAY_TASK_COUNT:-$((SLURM_ARRAY_TASK_MAX + 1))}}
# The film kernel's CPU backend uses rayon: one thread per allocated core.
export RAYON_NUM_THREADS=${SLURM_CPUS_PER_TASK:-1}
# Writes $OUT/<spec stem>/shard-K-of-N/result.json (and its result.jsonl stream).
exec "$BIN" run "$SPEC" \
    --shard "${SLURM_ARRAY_TASK_ID}/${SHARDS}" \
    --out "$OUT" \
    --backend "$BACKEND" --quiet
