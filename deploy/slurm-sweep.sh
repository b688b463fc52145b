#!/bin/bash
# A sweep as a Slurm job array: 16 tasks, each runs one deterministic shard (variant i
# goes to shard i mod 16), streaming finished variants to its own .jsonl. A task that is
# preempted or times out resumes where it stopped when resubmitted (same command, same
# --out). When all tasks are done, merge (see the last lines, or submit merge as a
# dependent job: sbatch --dependency=afterok:<jobid> ...). The shards' outputs go to
# sweep-out/<spec stem>/shard-K-of-16/.
#
#   sbatch deploy/slurm-sweep.sh sweeps/clearance-viscosity.json
#
#SBATCH --job-name=bearing-sweep
#SBATCH --array=0-15
#SBATCH --cpus-per-task=8
#SBATCH --mem=8G
#SBATCH --time=02:00:00
#SBATCH --output=sweep-out/slurm-%A_%a.log
#SBATCH --requeue

set -euo pipefail
SPEC=${1:?usage: sbatch deploy/slurm-sweep.sh SPEC.json}
SHARDS=16
OUT=sweep-out
mkdir -p "$OUT"
# The film kernel's CPU backend uses rayon: one thread per allocated core.
export RAYON_NUM_THREADS=${SLURM_CPUS_PER_TASK:-1}
# Writes $OUT/<spec stem>/shard-K-of-16/result.json (and its result.jsonl stream).
bearing-sweep run "$SPEC" \
    --shard "${SLURM_ARRAY_TASK_ID}/${SHARDS}" \
    --out "$OUT" \
    --backend cpu --quiet

# After the whole array has finished (e.g. in a job submitted with
# --dependency=afterok:$SLURM_ARRAY_JOB_ID), for sweeps/clearance-viscosity.json:
#   bearing-sweep merge sweep-out/clearance-viscosity/result.json \
#       sweep-out/clearance-viscosity/shard-*/result.json
