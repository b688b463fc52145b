#!/bin/bash
# Submits a sweep to Slurm: an array job of N shards (deploy/slurm-sweep.sh), then the
# merge as a job that runs when every shard has succeeded (afterok). Prints the two job
# ids ("ARRAY_ID MERGE_ID"). Extra sbatch options (partition, account, --mem, ...) go in
# SBATCH_EXTRA, e.g. SBATCH_EXTRA="--partition=compute --mem=4G".
#
#   deploy/slurm-submit.sh sweeps/clearance-viscosity.json 16
#   # result: sweep-out/clearance-viscosity/result.json once the merge job is done
set -euo pipefail
SPEC=${1:?usage: deploy/slurm-submit.sh SPEC.json [SHARDS]}
SHARDS=${2:-16}
HERE=$(cd "$(dirname "$0")" && pwd)
OUT=${OUT:-sweep-out}
mkdir -p "$OUT"
# shellcheck disable=SC2086 # SBATCH_EXTRA is a list of options
ARRAY=$(sbatch --parsable --array="0-$((SHARDS - 1))" --output="$OUT/slurm-%A_%a.log" \
    ${SBATCH_EXTRA:-} "$HERE/slurm-sweep.sh" "$SPEC")
ARRAY=${ARRAY%%;*}
# shellcheck disable=SC2086
MERGE=$(sbatch --parsable --dependency="afterok:$ARRAY" --kill-on-invalid-dep=yes \
    --array=0 --output="$OUT/slurm-%A-merge.log" ${SBATCH_EXTRA:-} \
    "$HERE/slurm-sweep.sh" --merge "$SPEC")
MERGE=${MERGE%%;*}
echo "$ARRAY $MERGE"
