#!/usr/bin/env bash
# One Euro parameter sweep on FPHA subject 5 with the tracker preset (docs/FILTERS.md).
# Usage: scripts/oneeuro_sweep.sh HANDSTEADY_BINARY SHARED_DATA_DIR OUT_DIR
set -euo pipefail
hs=$1; data=$2; out=$3
mkdir -p "$out"
$hs import --format fpha --in "$data/fpha/Subject_5" --out "$out/clean.csv" >/dev/null
$hs corrupt --in "$out/clean.csv" --out "$out/noisy.csv" --preset tracker --seed 1 >/dev/null
args=(--in raw="$out/noisy.csv")
for mc in 1 3 6 10; do
  for beta in 0 5 20 100; do
    $hs filter --in "$out/noisy.csv" --out "$out/oe_${mc}_${beta}.csv" --method oneeuro --mincutoff "$mc" --beta "$beta" >/dev/null
    args+=(--in "oneeuro mincutoff ${mc} Hz beta ${beta}=$out/oe_${mc}_${beta}.csv")
  done
done
$hs compare --truth "$out/clean.csv" "${args[@]}"
