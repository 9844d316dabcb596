#!/bin/sh
# The farm benchmark (BENCHMARKS.md, "Farm"): for each scene, the single-machine
# solve's time, then for N = 2, 4, 8, 16 every shard solved one at a time (the
# per-shard times; a farm's wall time is the slowest shard plus the merge), the
# merge, and the merged file against the single-machine solve at every frame
# (tools/farm/compare.py). One CSV row per run: wall seconds and CPU seconds (user +
# system, which a machine shared with other jobs inflates less than the wall time).
#
#   tools/farm/bench.sh BIN OUT_DIR [SCENE ...]      (default: light750 actor750)
#
# Settings per scene: the fast settings of BENCHMARKS.md's space-time tables.
set -eu
BIN=$(realpath "$1"); OUT=$2; shift 2
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
mkdir -p "$OUT"
CSV=$OUT/farm.csv
[ -f "$CSV" ] || echo "scene,run,n,k,windows,seconds,cpu_seconds,cost" > "$CSV"
settings() {
  case $1 in
    light*) echo "--eps 0.5 --recon-tol 0.06 --key-motion 0.04 --interp-motion 0.045" ;;
    actor*) echo "--eps 1 --recon-tol 0.09 --recon-tol-moving 0.08 --key-motion 0.06 --interp-motion 0.04 --moving-power-tol 0.06" ;;
  esac
}
# Runs a command under /usr/bin/time; sets WALL and CPU (seconds).
timed() {
  /usr/bin/time -f "%e %U %S" -o "$OUT/time.txt" "$@"
  WALL=$(cut -d' ' -f1 "$OUT/time.txt"); CPU=$(awk '{printf "%.2f", $2 + $3}' "$OUT/time.txt")
}
for scene in ${*:-light750 actor750}; do
  file=$ROOT/formats/examples/$scene.json
  set -- $(settings "$scene")
  timed "$BIN" solve "$file" "$@" -q --report "$OUT/$scene-single.csv" -o "$OUT/$scene-single.rhier"
  echo "$scene,single,1,0,all,$WALL,$CPU," >> "$CSV"
  for n in 2 4 8 16; do
    "$BIN" plan "$file" "$@" --shards "$n" --json > "$OUT/$scene-plan-$n.json"
    k=0
    while [ "$k" -lt "$n" ]; do
      timed "$BIN" solve "$file" "$@" -q --shard "$k/$n" -o "$OUT/$scene-n$n-part-$k.rhier"
      info=$(python3 -c "import json; s=json.load(open('$OUT/$scene-plan-$n.json'))['shards'][$k]; print(f\"{s['windows'][0]}..{s['windows'][1]},{s['cost']:.1f}\")")
      echo "$scene,shard,$n,$k,$(echo "$info" | cut -d, -f1),$WALL,$CPU,$(echo "$info" | cut -d, -f2)" >> "$CSV"
      k=$((k + 1))
    done
    timed "$BIN" merge -q "$OUT"/$scene-n$n-part-*.rhier -o "$OUT/$scene-n$n-merged.rhier"
    echo "$scene,merge,$n,,,$WALL,$CPU," >> "$CSV"
    python3 "$ROOT/tools/farm/compare.py" --rhier "$BIN" --scene "$file" --quiet \
      "$OUT/$scene-n$n-merged.rhier" "$OUT/$scene-single.rhier" | sed "s/^/$scene N=$n: /" | tee -a "$OUT/compare.txt" || true
  done
done
