#!/bin/sh
# A space-time solve as N shards on this machine, JOBS (default 2) at a time with
# xargs -P, each on one thread, then merged:
#
#   tools/farm/local.sh N OUT_DIR SCENE [solve settings...]
#
# Writes OUT_DIR/part-K.rhier and OUT_DIR/merged.rhier. RHIER names the binary.
# A failed shard leaves the others' parts; run the script again: shards whose part
# exists are skipped, the others resume from their journals.
set -eu
N=$1; OUT=$2; shift 2
RHIER=${RHIER:-rhier}
mkdir -p "$OUT"
seq 0 $((N - 1)) | while read -r k; do
  [ -f "$OUT/part-$k.rhier" ] || echo "$k"
done | xargs -r -P "${JOBS:-2}" -I{} "$RHIER" solve "$@" --shard "{}/$N" --threads 1 \
  --resume -q -o "$OUT/part-{}.rhier"
exec "$RHIER" merge "$OUT"/part-*.rhier -o "$OUT/merged.rhier"
