#!/bin/sh
# Submits a space-time solve to Slurm as a job array of N shards and a dependent
# merge job; prints the two job ids.
#
#   tools/farm/slurm/submit.sh N OUT_DIR SCENE [solve settings...]
#
# OUT_DIR must be on a file system every node sees. CPUS (default 1) is each
# task's --cpus-per-task; RHIER (default: rhier on PATH) is passed to the jobs in
# their environment. `rhier plan SCENE [settings] --shards N` shows the split.
set -eu
DIR=$(cd "$(dirname "$0")" && pwd)
N=$1; OUT=$2; shift 2
mkdir -p "$OUT"
array=$(sbatch --parsable --chdir="$OUT" --array=0-$((N - 1)) --cpus-per-task="${CPUS:-1}" \
  "$DIR/shard.sbatch" "$N" "$OUT" "$@")
merge=$(sbatch --parsable --chdir="$OUT" --dependency=afterany:"$array" "$DIR/merge.sbatch" "$OUT")
echo "$array $merge"
